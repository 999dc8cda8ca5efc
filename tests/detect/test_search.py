"""graphpose.detect.search: candidate junctions, the ring test, the search levels and the
compiled kernels behind them (``_search.pyx``) against plain NumPy/SciPy written here.

The references are the plain loops the kernels replaced, so that a kernel that samples,
orders or rounds differently fails here and not only, much later, as a junction that moved.
"""

import numpy as np
import pytest

from graphpose import Board, InputError
from graphpose.detect.search import (SearchImage, _response_peaks, downsample, find_candidates, noise_floor,
                                     ring_test, search_levels)
from graphpose.geometry import T_from_params
from graphpose.synth.render import render
from graphpose.synth.scenes import random_scene
from tests.conftest import PROJECT_K as K


@pytest.mark.parametrize("seed", range(4))
def test_candidates_lie_on_every_junction_of_a_board_at_any_rotation(seed):
    R = random_scene(K, Board(), max_roll_deg=180.0, rng=seed).rendering
    cands = find_candidates(R.image)
    d = np.min(np.hypot(*(cands.points[:, :, None] - R.junctions[:, None, :])), axis=0)
    assert d.max() < 1.5, d.max()


def test_ring_test_tells_junctions_from_corners_and_edges():
    R = render(K, T_from_params([0.22, 0.16, -1.0, 0.0, 0.0, 0.1]), Board(), rng=2, margin=1.0)
    cands = find_candidates(R.image)
    square = 0.0635 * 565 / 1.0
    junction = ring_test(cands.view, R.junctions, 0.35 * square)[0]
    corners = ring_test(cands.view, R.outline, 0.35 * square)[0]  # sheet corners: L-shaped
    mid_edge = 0.5 * (R.junctions[:, 0] + R.junctions[:, 1])  # on a square's edge
    edge = ring_test(cands.view, mid_edge[:, None], 0.35 * square)[0]
    assert junction.min() > 0.5 and corners.max() < 0 and edge.max() < 0


@pytest.mark.parametrize("shape, levels", [
    ((480, 640), [1, 0]), ((800, 1000), [1, 0]), ((802, 1000), [2, 1, 0]), ((1080, 1920), [2, 1, 0]),
    ((1600, 2400), [2, 1, 0]), ((1602, 2400), [3, 2, 1, 0]), ((3024, 4032), [3, 2, 1, 0]),
    ((6000, 8000), [4, 3, 2, 1, 0]), ((3, 3), [1, 0])])
def test_search_levels_start_where_the_shorter_side_is_at_most_400_px(shape, levels):
    assert list(search_levels(shape)) == levels


@pytest.mark.parametrize("level", range(6))
@pytest.mark.parametrize("dtype", [np.uint8, np.float64])
def test_downsample_is_the_exact_block_mean(level, dtype):
    rng = np.random.default_rng(level)
    image = (rng.integers(0, 256, (75, 101)) if dtype == np.uint8 else rng.random((75, 101))).astype(dtype)
    s = 2**level
    h, w = 75 // s * s, 101 // s * s
    mean = image[:h, :w].astype(float).reshape(h // s, s, w // s, s).mean(axis=(1, 3))
    out = downsample(image, level)
    assert out.dtype == np.float32 and out.shape == mean.shape
    np.testing.assert_allclose(out, mean, rtol=0, atol=0 if dtype == np.uint8 else 1e-6)


@pytest.mark.parametrize("level", [-1, 1.5])
def test_find_candidates_refuses_a_level_that_is_no_whole_number_from_0(level):
    with pytest.raises(InputError, match="level must be a whole number >= 0"):
        find_candidates(np.zeros((64, 64), np.uint8), level=level)


def test_the_noise_floor_removes_the_peaks_of_pure_noise():
    image = np.random.default_rng(1).normal(128.0, 10.0, (240, 320))
    assert find_candidates(image).points.shape[1] > 300  # relative to the strongest: noise is all there is
    cands = find_candidates(image, noise=10.0)
    assert cands.points.shape[1] == 0 or cands.points.shape[1] < 3
    assert noise_floor(10.0, 2) == pytest.approx(noise_floor(10.0, 1) / 4)


def bilinear_reference(a, x, y):
    """Bilinear samples of ``a`` at columns ``x``, rows ``y``, coordinates clamped to the image."""
    h, w = a.shape
    x, y = np.clip(x, 0, w - 1), np.clip(y, 0, h - 1)
    j0, i0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - j0, y - i0
    j1, i1 = np.minimum(j0 + 1, w - 1), np.minimum(i0 + 1, h - 1)
    a = a.astype(float)
    return (a[i0, j0] * (1 - fy) * (1 - fx) + a[i0, j1] * (1 - fy) * fx
            + a[i1, j0] * fy * (1 - fx) + a[i1, j1] * fy * fx)


def ring_reference(ring):
    """The ChESS ring test on samples (m, 16): score, theta, contrast."""
    ring = ring - ring.mean(axis=1, keepdims=True)
    total = np.abs(ring[:, 0:4] + ring[:, 8:12] - ring[:, 4:8] - ring[:, 12:16]).sum(axis=1)
    diff = np.abs(ring[:, 0:8] - ring[:, 8:16]).sum(axis=1)
    angles = np.arange(16) * (np.pi / 8)
    theta = 0.5 * np.arctan2(ring @ np.sin(2 * angles), ring @ np.cos(2 * angles))
    return (total - 2 * diff) / np.maximum(total + diff, 1e-12), theta, np.ptp(ring, axis=1)


def small_view(rng, level=1, dtype=np.uint8):
    image = (rng.random((23, 31)) * 255).astype(dtype)
    smooth = (rng.random((11, 15)) * 255).astype(np.float32)
    return SearchImage(smooth, level, image)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32, np.float64, bool])
def test_samples_are_bilinear_with_the_edges_repeated(dtype):
    rng = np.random.default_rng(1)
    view = small_view(rng, dtype=dtype)
    P = np.vstack([rng.uniform(-4, 35, 300), rng.uniform(-4, 27, 300)])
    P[:, :3] = [[0.0, 30.0, 29.0], [0.0, 22.0, 22.0]]  # corners and the last row, exactly
    x, y = view.to_level(P)
    expected = bilinear_reference(view.smooth, x, y).astype(np.float32)
    np.testing.assert_array_equal(view.sample(P), expected)
    reach = 0.7
    fine = np.mean([bilinear_reference(view.image, P[0] + dx, P[1] + dy)
                    for dy in (-reach, 0, reach) for dx in (-reach, 0, reach)], axis=0)
    np.testing.assert_allclose(view.sample_fine(P, reach), fine, rtol=0, atol=1e-9)


def test_ring_test_is_the_chess_test_on_sixteen_bilinear_samples():
    rng = np.random.default_rng(2)
    view = small_view(rng, level=1)
    P = np.vstack([rng.uniform(2, 28, 50), rng.uniform(2, 20, 50)])
    radius = rng.uniform(1.0, 6.0, 50)
    angles = np.arange(16) * (np.pi / 8)
    x, y = view.to_level(P)
    rad = radius[:, None] / 2
    ring = bilinear_reference(view.smooth, (x[:, None] + rad * np.cos(angles)).ravel(),
                              (y[:, None] + rad * np.sin(angles)).ravel()).astype(np.float32).reshape(50, 16)
    for got, want in zip(ring_test(view, P, radius), ring_reference(ring.astype(float))):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


def test_a_cross_junction_scores_above_zero_and_an_edge_below():
    u, v = np.meshgrid(np.arange(21.0), np.arange(21.0))
    cross = np.where((u - 10.3) * (v - 9.8) > 0, 200.0, 40.0).astype(np.float32)
    edge = np.where(u > 10.3, 200.0, 40.0).astype(np.float32)
    for image, sign in ((cross, 1), (edge, -1)):
        score = ring_test(SearchImage(image, 0, image), np.array([[10.3], [9.8]]), 5.0)[0]
        assert sign * score[0] > 0


def response_reference(S):
    """The saddle response and its 3 x 3 maxima above 0 (edges repeated), in NumPy."""
    Ixx = S[1:-1, 2:] - 2 * S[1:-1, 1:-1] + S[1:-1, :-2]
    Iyy = S[2:, 1:-1] - 2 * S[1:-1, 1:-1] + S[:-2, 1:-1]
    Ixy = 0.25 * (S[2:, 2:] - S[2:, :-2] - S[:-2, 2:] + S[:-2, :-2])
    r = Ixy * Ixy - Ixx * Iyy
    p = np.pad(r, 1, mode="edge")
    local = np.max([p[a:a + r.shape[0], b:b + r.shape[1]] for a in range(3) for b in range(3)], axis=0)
    ys, xs = np.nonzero((r >= local) & (r > 0))
    return r, ys, xs


@pytest.mark.parametrize("shape", [(3, 3), (4, 9), (17, 12)])
def test_the_saddle_response_and_its_peaks_are_numpys_to_the_bit(shape):
    rng = np.random.default_rng(3)
    S = (rng.random(shape) * 100).astype(np.float32)
    S[1:3, 1:3] = S[1, 1]  # a plateau: equal neighbours are peaks together
    r, ys, xs = _response_peaks(S)
    R, YS, XS = response_reference(S)
    np.testing.assert_array_equal(r, R)
    np.testing.assert_array_equal(ys, YS)
    np.testing.assert_array_equal(xs, XS)
    assert _response_peaks(S[:2])[1].size == 0  # no interior pixel


def test_the_median_is_numpys_to_the_bit():
    from graphpose.detect.search import median

    rng = np.random.default_rng(10)
    for trial in range(2000):
        n = int(rng.integers(1, 80))
        # Ties (whole numbers, rounded values) as well as distinct values, odd and even counts.
        for x in (rng.normal(size=n), rng.integers(0, 4, n).astype(float), np.round(rng.normal(size=n), 1)):
            assert median(x) == np.median(x), (trial, x)
    assert np.isnan(median([1.0, np.nan, 2.0]))
    assert np.isnan(median([]))  # as np.median of nothing, and no read past an empty buffer


def test_an_image_narrower_than_a_search_block_smooths_to_nothing_and_finds_nothing():
    # Half resolution of a one-pixel-wide image has no column: the smoothing must return (it
    # reflects about the line's ends) and the search must find nothing, as SciPy's did.
    from graphpose.detect.search import smooth

    assert smooth(np.zeros((5, 0), np.float32)).shape == (5, 0)
    assert find_candidates(np.zeros((40, 1), np.uint8), level=1).points.shape == (2, 0)


@pytest.mark.parametrize("shape", [(480, 640), (7, 9), (33, 17), (16, 16)])
def test_block_means_are_the_same_compiled_and_strided(shape):
    # A C-contiguous 8-bit image goes through the compiled pass, a strided view of the same
    # pixels through NumPy's strided sums: the same exact integer sums, the same float32.
    from graphpose.detect.search import downsample

    image = np.random.default_rng(12).integers(0, 256, shape).astype(np.uint8)
    padded = np.zeros((shape[0], 2 * shape[1]), np.uint8)
    padded[:, ::2] = image
    view = padded[:, ::2]
    assert image.flags.c_contiguous and not view.flags.c_contiguous
    for level in range(1, 5):
        if min(shape) < 2**level:
            continue
        a, b = downsample(image, level), downsample(view, level)
        assert a.dtype == np.float32 and a.shape == (shape[0] // 2**level, shape[1] // 2**level)
        np.testing.assert_array_equal(a, b)
        # and each is the block's plain mean
        s = 2**level
        h, w = a.shape
        plain = image[:h * s, :w * s].reshape(h, s, w, s).sum(axis=(1, 3)) / 4.0**level
        np.testing.assert_allclose(a, plain, rtol=1e-6)


def test_a_nan_sample_position_is_refused_not_read():
    # The kernels clamp positions to the image; a NaN would escape the clamp (floor(NaN) as an
    # index), so the samplers refuse it.
    image = np.zeros((20, 20), dtype=np.float32)
    view = SearchImage(image, 0, image)
    for centre in (np.array([[np.nan], [4.0]]), np.array([[4.0], [np.inf]])):
        with pytest.raises(InputError, match="finite"):
            ring_test(view, centre, 2.5)
        with pytest.raises(InputError, match="finite"):
            view.sample(centre)


@pytest.mark.parametrize("shape", [(240, 320), (7, 5), (2, 9), (1, 1)])
def test_the_search_smoothing_is_scipys_gaussian_to_the_bit(shape):
    # SciPy is the reference here (a runtime dependency): the kernel must give what
    # ndimage.gaussian_filter gave the search before it, edges (reflected) included, and
    # lines shorter than the kernel, where the reflection folds more than once.
    from scipy import ndimage

    from graphpose.detect.search import RESPONSE_SIGMA, smooth

    a = np.random.default_rng(3).uniform(0, 255, shape).astype(np.float32)
    expected = ndimage.gaussian_filter(a, RESPONSE_SIGMA, truncate=3.0)
    assert smooth(a).dtype == np.float32
    np.testing.assert_array_equal(smooth(a), expected)


def test_in_polygon_is_scikit_images_points_in_poly():
    """The search's polygon test (seeds inside the bounds, candidates inside a lattice's box)
    replaced scikit-image's ``points_in_poly``: the same verdicts inside, outside, on edges
    and on corners, for convex and non-convex polygons of either turn."""
    from skimage.measure import points_in_poly

    from graphpose.detect.search import in_polygon

    rng = np.random.default_rng(3)
    for trial in range(60):
        V = int(rng.integers(3, 8))
        polygon = rng.uniform(0, 100, (2, V))
        points = rng.uniform(-10, 110, (2, 300))
        if trial % 2:  # whole numbers: many points on horizontal and vertical edges
            polygon, points = np.round(polygon / 10) * 10, np.round(points / 10) * 10
        a, i = rng.uniform(0, 1, 40), rng.integers(0, V, 40)
        on_edges = polygon[:, i] * (1 - a) + polygon[:, (i + 1) % V] * a
        points = np.hstack([points, on_edges, polygon])
        np.testing.assert_array_equal(in_polygon(points, polygon), points_in_poly(points.T, polygon.T))
    assert in_polygon(np.array([[5.0], [5.0]]), np.array([[0, 10, 10, 0], [0, 0, 10, 10.0]])).tolist() == [True]
    assert in_polygon(np.array([[15.0], [5.0]]), np.array([[0, 10, 10, 0], [0, 0, 10, 10.0]])).tolist() == [False]

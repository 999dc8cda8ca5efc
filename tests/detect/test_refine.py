"""The re-centred saddle refinement (graphpose.detect.refine) and the fits it batches."""

import numpy as np
import pytest

from graphpose import Board, FisheyeCamera, extract_junctions
from graphpose.geometry import to_camera
from graphpose.detect.refine import refine_junctions
from graphpose.detect._refine import (fit_through_lens, fit_weighted_grid, lens_centres, lens_disc, refine_grid,
                                      ring_crosses, smoothed_patches)
from graphpose.detect.refine import _RING_COS, _RING_SIN, _gaussian_kernel, _lagrange
from graphpose.synth.calibration import fisheye_camera
from graphpose.synth.render import render
from tests.conftest import PROJECT_K


def weighted_lstsq(v, W, x, y):
    """The weighted quadric fit by a plain least-squares solve: coefficients (6,)."""
    A = np.column_stack([x * x, x * y, y * y, x, y, np.ones_like(x)])
    s = np.sqrt(W)
    return np.linalg.lstsq(A * s[:, None], v * s, rcond=None)[0]


def stationary(c):
    a, b, g, d, e, _ = c
    return np.linalg.solve([[2 * a, b], [b, 2 * g]], [-d, -e])


def weighted_rms(c, v, W, x, y):
    a, b, g, d, e, z = c
    r = v - (a * x * x + b * x * y + g * y * y + d * x + e * y + z)
    return np.sqrt(np.sum(W * r * r) / W.sum())


def test_fit_through_the_lens_is_the_weighted_least_squares_fit_in_its_window():
    rng = np.random.default_rng(3)
    m, n = 5, 300
    x, y = rng.uniform(-9, 9, (m, n)), rng.uniform(-9, 9, (m, n))
    u0, v0 = rng.uniform(-2, 2, (2, m, 1))
    values = (x - u0) * (y - v0) + 0.3 * (x - u0) ** 2 + rng.normal(0, 0.5, (m, n))
    g2 = rng.uniform(0, 1, (m, n))
    centre, radius = rng.uniform(-1, 1, (2, m)), rng.uniform(6, 9, m)
    act = np.arange(1, m)  # the first patch is not fitted
    points, saddle, rms = np.empty((2, m - 1)), np.zeros(m - 1, dtype=np.uint8), np.empty(m - 1)
    fit_through_lens(x, y, values, g2, act, np.ascontiguousarray(centre[:, act]), radius[act], 9.0, points, saddle, rms)
    for k, i in enumerate(act):
        # refine_points' window: a smooth taper of the radius, the squared gradient, over the
        # squared distance (at least 1).
        r2 = (x[i] - centre[0, i]) ** 2 + (y[i] - centre[1, i]) ** 2
        W = np.maximum(1 - r2 / radius[i] ** 2, 0) ** 2 * g2[i] / np.maximum(r2, 1)
        c = weighted_lstsq(values[i], W, x[i], y[i])
        np.testing.assert_allclose(points[:, k], stationary(c), atol=1e-9)
        assert rms[k] == pytest.approx(weighted_rms(c, values[i], W, x[i], y[i]), rel=1e-6)
    assert saddle.all()
    # No undistorted centre: no weight, no saddle.
    fit_through_lens(x, y, values, g2, act[:1], np.full((2, 1), np.nan), radius[:1], 9.0, points, saddle, rms)
    assert not saddle[0] and np.isnan(points[:, 0]).all()


def test_lens_kernels_place_pixels_by_the_polynomial_through_the_nodes():
    # lens_disc and lens_centres against the NumPy tensor product L^T V L of the Lagrange
    # basis (which the lens-aware refinement used before the kernels), NaN nodes included.
    rng = np.random.default_rng(8)
    m, half = 4, 7
    offs = np.arange(-half, half + 1, dtype=float)
    P = offs.size
    V = rng.normal(0.0, 3.0, (2, m, 5, 5))
    V[:, 3, 4, 0] = np.nan  # a node the lens does not image: patch 3 has no positions there
    L = _lagrange(np.linspace(-half, half, 5), offs)
    disc = offs[:, None] ** 2 + offs[None, :] ** 2 <= 6.5 ** 2
    rows, cols = np.nonzero(disc)
    patches = rng.uniform(0, 1, (m, P, P))
    grad2 = rng.uniform(0, 1, (m, P, P)).astype(np.float32)
    x, y, values, g2 = (np.empty((m, rows.size)) for _ in range(4))
    lens_disc(V, L, rows.astype(np.intp), cols.astype(np.intp), patches, grad2, x, y, values, g2)
    flat = (L.T @ (V @ L))[:, :, rows, cols] - V[:, :, 2, 2][:, :, None]
    valid = np.all(np.isfinite(flat), axis=0)
    assert not valid[3].all() and valid[:3].all()
    np.testing.assert_allclose(x, np.where(valid, flat[0], 0.0), atol=1e-12)
    np.testing.assert_allclose(y, np.where(valid, flat[1], 0.0), atol=1e-12)
    np.testing.assert_array_equal(values, patches[:, rows, cols])
    np.testing.assert_array_equal(g2, np.where(valid, grad2[:, rows, cols], 0.0))
    act = np.array([2, 0, 1], dtype=np.intp)
    offset = rng.uniform(-2, 2, (2, act.size))
    out = np.empty((2, act.size))
    lens_centres(V, act, offset, float(half), out)
    Lo = _lagrange(np.linspace(-half, half, 5), offset.ravel()).reshape(5, 2, -1)
    want = np.einsum("cmab,am,bm->cm", V[:, act], Lo[:, 1], Lo[:, 0]) - V[:, act, 2, 2]
    np.testing.assert_allclose(out, want, atol=1e-12)


def test_the_refinement_gives_the_undistorted_points_of_its_fits():
    # The rays of the fits through the lens, as the verdict uses them instead of inverting
    # the lens again: the refined points' undistort_pixels.
    from graphpose.detect.refine import grey_and_scale, refine_points

    camera = fisheye_camera()
    board = Board()
    T = np.array([[1.0, 0, 0, 0.12], [0, 1, 0, 0.09], [0, 0, 1, -0.45], [0, 0, 0, 1]])
    r = render(camera, T, board, noise_sigma=1.0, rng=5)
    image, _ = grey_and_scale(r.image)
    start = r.junctions + np.random.default_rng(6).uniform(-0.3, 0.3, r.junctions.shape)
    flat = np.empty_like(start)
    points, trusted, _ = refine_points(image, start, np.full(start.shape[1], 8.0), 0.5, lens=camera, undistorted=flat)
    assert trusted.sum() >= 40
    np.testing.assert_allclose(flat[:, trusted], camera.undistort_pixels(points[:, trusted]), atol=1e-8)


def test_fit_on_the_grid_is_the_weighted_least_squares_fit():
    rng = np.random.default_rng(4)
    m, h, w = 4, 9, 13
    v, u = np.mgrid[0:h, 0:w].astype(float)
    x, y = u - (w - 1) / 2, v - (h - 1) / 2
    P = np.stack([(x - rng.uniform(-2, 2)) * (y - rng.uniform(-2, 2)) + rng.normal(0, 0.3, (h, w)) for _ in range(m)])
    W = rng.uniform(0, 1, (m, h, w))
    W[0, :, :5] = 0.0  # zero weights are skipped, not miscounted
    coeffs, rms = np.empty((6, m)), np.empty(m)
    fit_weighted_grid(P, W, coeffs, rms)
    for i in range(m):
        c = weighted_lstsq(P[i].ravel(), W[i].ravel(), x.ravel(), y.ravel())
        np.testing.assert_allclose(coeffs[:, i], c, rtol=1e-7, atol=1e-9)  # the ridge: 1e-12 of the trace
        assert rms[i] == pytest.approx(weighted_rms(c, P[i].ravel(), W[i].ravel(), x.ravel(), y.ravel()), rel=1e-6)


def convolve(a, kernel, axis):
    """'Valid' correlation tap by tap, single precision (the reference for the patches)."""
    n = a.shape[axis] - len(kernel) + 1
    index = [slice(None)] * a.ndim
    out = 0.0
    for j, k in enumerate(kernel):
        index[axis] = slice(j, j + n)
        out = out + k * a[tuple(index)]
    return out


def reference_patches(image, base, half, kernel):
    """Smoothed patches about ``base`` (clamped at the border) and squared gradients, in NumPy."""
    height, width = image.shape
    margin = len(kernel) // 2 + 1
    offs = np.arange(-half - margin, half + margin + 1)
    rows = np.clip(base[1][:, None] + offs, 0, height - 1)
    cols = np.clip(base[0][:, None] + offs, 0, width - 1)
    raw = image[rows[:, :, None], cols[:, None, :]].astype(np.float32)
    smooth = convolve(convolve(raw, kernel, 1), kernel, 2)
    gx = 0.5 * (smooth[:, 1:-1, 2:] - smooth[:, 1:-1, :-2])
    gy = 0.5 * (smooth[:, 2:, 1:-1] - smooth[:, :-2, 1:-1])
    return smooth[:, 1:-1, 1:-1].astype(float), gx * gx + gy * gy


@pytest.mark.parametrize("dtype", [np.uint8, np.float64])
@pytest.mark.parametrize("sigma", [0.0, 0.5, 1.3])
def test_patches_are_the_numpy_patches_bit_for_bit(dtype, sigma):
    rng = np.random.default_rng(5)
    image = rng.integers(0, 256, (40, 50)).astype(dtype)
    if dtype == np.float64:
        image /= 255.0
    base = np.array([[0, 10, 49, 25], [0, 20, 39, 3]], dtype=np.intp)  # corners clamp
    half = 6
    kernel = _gaussian_kernel(sigma).astype(np.float32)
    patches, grad2 = np.empty((4, 13, 13)), np.empty((4, 13, 13), dtype=np.float32)
    smoothed_patches(image, base, half, kernel, patches, grad2)
    expected, expected_g2 = reference_patches(image, base, half, kernel)
    assert np.array_equal(patches, expected) and np.array_equal(grad2, expected_g2)


def test_ring_test_matches_bilinear_samples():
    from scipy import ndimage

    rng = np.random.default_rng(6)
    v, u = np.mgrid[0:15, 0:15].astype(float)
    cross = np.tanh(u - 7.3) * np.tanh(v - 6.8)
    patches = np.stack([cross, np.tanh(u - 7.3), rng.normal(0, 1, (15, 15)), -cross])
    centre = np.array([[7.3, 7.0, 7.0, 7.3], [6.8, 7.0, 7.0, 6.8]])
    radius = np.array([4.0, 4.0, 4.0, 9.0])  # the last ring leaves the patch: samples clamp
    out = np.zeros(4, dtype=np.uint8)
    ring_crosses(patches, centre, radius, _RING_COS, _RING_SIN, out)
    x = centre[0][:, None] + radius[:, None] * _RING_COS
    y = centre[1][:, None] + radius[:, None] * _RING_SIN
    k = np.repeat(np.arange(4), 16)
    ring = ndimage.map_coordinates(patches, [k, y.ravel(), x.ravel()], order=1, mode="nearest").reshape(4, 16)
    total = np.abs(ring[:, 0:4] + ring[:, 8:12] - ring[:, 4:8] - ring[:, 12:16]).sum(axis=1)
    diff = np.abs(ring[:, 0:8] - ring[:, 8:16]).sum(axis=1)
    assert np.array_equal(out.view(bool), total > 2.0 * diff)
    assert out.tolist()[:3] == [1, 0, 0]


def reference_refine(image, start, radius, sigma, max_iter=8, tol=0.02, slack=2):
    """One junction's re-centred refinement in NumPy: (point, converged, residual)."""
    half = int(np.ceil(radius)) + slack
    kernel = _gaussian_kernel(sigma).astype(np.float32)
    offs = np.arange(-half, half + 1, dtype=float)
    current = np.array(start, dtype=float)
    base = np.rint(current).astype(int)
    patch, g2 = (a[0] for a in reference_patches(image, base[:, None], half, kernel))
    residual = np.nan
    for _ in range(max_iter):
        if np.any(np.abs(current - base) > slack - 0.5):
            base = np.rint(current).astype(int)
            patch, g2 = (a[0] for a in reference_patches(image, base[:, None], half, kernel))
        r2 = (offs[:, None] - (current[1] - base[1])) ** 2 + (offs[None, :] - (current[0] - base[0])) ** 2
        W = np.maximum(1 - r2 / radius ** 2, 0) ** 2 * g2 / np.maximum(r2, 1)
        c = weighted_lstsq(patch.ravel(), W.ravel(), np.tile(offs, offs.size), np.repeat(offs, offs.size))
        residual = weighted_rms(c, patch.ravel(), W.ravel(), np.tile(offs, offs.size), np.repeat(offs, offs.size))
        a, b, g = c[:3]
        new = base + stationary(c)
        step = np.hypot(*(new - current))
        if not (4 * a * g - b * b < 0 and np.all(np.abs(new - base) <= half) and step < radius):
            return current, False, np.nan
        current = new
        if step < tol:
            return current, True, residual
    return current, False, residual


def test_refinement_kernel_follows_the_numpy_refinement():
    from graphpose.synth.render import render
    from graphpose import Board
    from graphpose.synth.poses import random_pose

    rng = np.random.default_rng(8)
    K = PROJECT_K
    R = render(K, random_pose(K, Board(), (640, 480), rng=rng), Board(), (640, 480), noise_sigma=2.0, rng=rng)
    truth = R.junctions[:, :12]
    start = truth + rng.uniform(-2, 2, truth.shape)
    radius = np.full(12, 7.0)
    for image in (R.image, R.image / 255.0):
        current, trusted, residual = start.copy(), np.zeros(12, dtype=np.uint8), np.empty(12)
        refine_grid(image, current, radius, _gaussian_kernel(0.5).astype(np.float32), 9, 8, 0.02, 2.0,
                    _RING_COS, _RING_SIN, trusted, residual)
        for i in range(12):
            point, converged, rms = reference_refine(image, start[:, i], 7.0, 0.5)
            np.testing.assert_allclose(current[:, i], point, atol=1e-9)
            assert bool(trusted[i]) == converged  # inside the image and crosses, all of them
            assert residual[i] == pytest.approx(rms, rel=1e-6)
        assert np.max(np.hypot(*(current - truth))) < 0.1


def test_a_point_whose_ray_is_past_90_degrees_is_refined_through_the_lens():
    # A fisheye sees rays past 90 degrees off its axis, which have no undistorted (pinhole)
    # position; the fit through the lens works in each patch's own frame (the pinhole
    # looking along the patch's ray), so it places them and refines them as any other.
    camera = FisheyeCamera([[203.0, 0.0, 321.0], [0.0, 203.0, 241.0], [0.0, 0.0, 1.0]],
                           [-0.013, -0.004, 0.0035, -0.001], size=(640, 480))
    assert np.isnan(camera.undistort_pixels([[2.0], [241.0]])).all()
    board = Board(4, 3, 0.03)
    # The board facing the camera's +x, its centre 93 degrees off the axis: its columns of
    # junctions lie at 86, 90.5, 95 and 100 degrees (the last two beyond the image's edge).
    R = np.column_stack([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])  # board axes in the camera
    t = 0.35 * np.array([np.sin(np.radians(93.0)), 0.0, np.cos(np.radians(93.0))]) - R @ board.world_points().mean(axis=1)
    T_WC = np.eye(4)
    T_WC[:3, :3], T_WC[:3, 3] = R.T, -R.T @ t
    rendering = render(camera, T_WC, board, noise_sigma=0.0, rng=0)
    P_C = to_camera(T_WC, board.world_points())
    past = np.degrees(np.arctan2(np.hypot(P_C[0], P_C[1]), P_C[2])) > 90.0
    in_image = rendering.junctions[0] < 630.0
    assert np.any(past & in_image)
    points, trusted, residual = refine_junctions(rendering.image, rendering.junctions + 0.4, 5.0, camera=camera)
    assert trusted[in_image].all() and not trusted[~in_image].any()
    assert np.all(np.hypot(*(points - rendering.junctions))[in_image] < 0.05)
    # On noise the fit there fails as anywhere: untrusted, no residual, no error.
    image = np.random.default_rng(0).integers(0, 256, (480, 640)).astype(np.uint8)
    start = np.array([[2.0, 320.0], [241.0, 240.0]])
    points, trusted, residual = refine_junctions(image, start, 6.0, camera=camera)
    assert not trusted[0] and np.isnan(residual[0])

def test_junctions_near_a_fisheyes_rim_are_refined_without_bias():
    # A noise-free board 30-82 degrees off the axis of the 185-degree fisheye of the
    # calibration sets: the fit in each patch's own frame finds every junction to a few
    # thousandths of a pixel. (In the camera's distortion-free image, stretched by
    # 1 / cos^2 of the field angle along the radius, 14 of the 48 were not trusted and the
    # others were off by up to 0.065 px.)
    camera = fisheye_camera()
    board = Board()
    W = board.world_points()
    ray = np.array([np.sin(np.radians(60.0)), 0.0, np.cos(np.radians(60.0))])
    z = np.array([np.sin(np.radians(40.0)), 0.0, np.cos(np.radians(40.0))])  # 20 degrees off the ray
    R = np.column_stack([np.cross([0.0, 1.0, 0.0], z), [0.0, 1.0, 0.0], z])
    T_WC = np.eye(4)
    T_WC[:3, :3], T_WC[:3, 3] = R.T, -R.T @ (0.45 * ray - R @ W.mean(axis=1))
    P_C = to_camera(T_WC, W)
    assert np.degrees(np.arctan2(np.hypot(P_C[0], P_C[1]), P_C[2])).max() > 80.0
    rendering = render(camera, T_WC, board, noise_sigma=0.0, rng=0)
    J = extract_junctions(rendering.image, bounds=None, board=board, camera=camera)
    assert J.trusted.all()
    assert np.max(np.hypot(*(J.points - rendering.junctions))) < 0.01

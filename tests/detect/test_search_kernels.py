"""The board search's compiled kernels against plain NumPy written here, on small inputs.

Each kernel (``graphpose/detect/_search.pyx``, ``_lattice.pyx``) replaces a NumPy or Python
loop; the references below are those loops written out the plain way, so that a kernel
that samples, orders or rounds differently fails here and not only, much later, as a
junction that moved.
"""

import math

import numpy as np
import pytest

from graphpose import InputError
from graphpose.detect import _lattice
from graphpose.detect.lattice import KeyGrid, grow_lattices, predict
from graphpose.detect.search import SearchImage, _response_peaks, find_candidates, ring_test

STEPS = ((1, 0), (-1, 0), (0, 1), (0, -1))


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


def predict_reference(nodes, key):
    """:func:`predict` in plain Python."""
    i, j = key
    su = sv = 0.0
    steps = []
    for di, dj in STEPS:
        a, b = nodes.get((i - di, j - dj)), nodes.get((i - 2 * di, j - 2 * dj))
        if a is None or b is None:
            continue
        c = nodes.get((i - 3 * di, j - 3 * dj))
        if c is None:
            su, sv = su + (2 * a[0] - b[0]), sv + (2 * a[1] - b[1])
        else:
            su, sv = su + (3 * a[0] - 3 * b[0] + c[0]), sv + (3 * a[1] - 3 * b[1] + c[1])
        steps.append(math.hypot(a[0] - b[0], a[1] - b[1]))
    if not steps:
        for di, dj in STEPS:
            a = nodes.get((i - di, j - dj))
            for ei, ej in STEPS:
                if a is None or ei * di + ej * dj:
                    continue
                b1, b2 = nodes.get((i - di + ei, j - dj + ej)), nodes.get((i + ei, j + ej))
                if b1 is not None and b2 is not None:
                    su, sv = su + (a[0] + b2[0] - b1[0]), sv + (a[1] + b2[1] - b1[1])
                    steps.append(math.hypot(b2[0] - b1[0], b2[1] - b1[1]))
    if not steps:
        return None
    return (su / len(steps), sv / len(steps)), float(np.median(steps))


def test_predictions_are_the_plain_extrapolations():
    rng = np.random.default_rng(4)
    for trial in range(20):
        nodes = {(i, j): (30.0 * i + 4.0 * j + rng.normal(0, 0.5), 28.0 * j - 3.0 * i + rng.normal(0, 0.5))
                 for i in range(-3, 4) for j in range(-3, 3) if rng.random() < 0.6}
        if not nodes:
            continue
        for key in [(i, j) for i in range(-5, 6) for j in range(-5, 5) if (i, j) not in nodes]:
            got, want = predict(nodes, key), predict_reference(nodes, key)
            if want is None:
                assert got is None
            else:
                assert got[0] == pytest.approx(want[0], abs=1e-9) and got[1] == pytest.approx(want[1], rel=1e-12)


def test_a_growth_round_predicts_each_free_neighbour_once_in_order():
    nodes = {(0, 0): (0.0, 0.0), (1, 0): (10.0, 0.0), (0, 1): (0.0, 10.0), (1, 1): (10.0, 10.0)}
    grid = KeyGrid(nodes)
    fresh = np.array(list(nodes), dtype=np.int64)
    keys, guess, step = np.empty((16, 2), np.int64), np.empty((16, 2)), np.empty(16)
    stamp = np.zeros(grid.array.shape[:2], np.int32)
    n = _lattice.predict_round(grid.array, int(grid.origin[0]), int(grid.origin[1]), fresh, stamp, 1, keys, guess, step)
    expected = []
    for i, j in nodes:
        for di, dj in STEPS:
            key = (i + di, j + dj)
            if key not in nodes and key not in [k for k, _ in expected] and predict_reference(nodes, key):
                expected.append((key, predict_reference(nodes, key)))
    assert [tuple(k) for k in keys[:n].tolist()] == [k for k, _ in expected]
    np.testing.assert_allclose(guess[:n], [p for _, (p, _) in expected], atol=1e-12)
    np.testing.assert_allclose(step[:n], [s for _, (_, s) in expected], atol=1e-12)


def test_growth_keeps_the_grid_growing_past_its_first_box():
    # A board of 30 x 5 squares: its lattice (29 x 4 junctions) grows far beyond the seed's
    # key box (KeyGrid.cover regrows it between compiled calls), and every junction is found once, where it is.
    u, v = np.meshgrid(np.arange(720.0), np.arange(170.0))
    image = np.where((np.floor((u - 20.3) / 22) + np.floor((v - 30.6) / 22)) % 2 == 0, 200, 40).astype(np.uint8)
    image[:, :20] = image[:, 20 + 660:] = image[:30] = image[30 + 110:] = 120
    lattice = max((lat for _, lat in grow_lattices(find_candidates(image), max_nodes=1000) if lat is not None),
                  key=lambda lat: len(lat.keys))
    assert len(lattice.keys) == 29 * 4 and len({tuple(k) for k in lattice.keys.tolist()}) == 29 * 4
    assert np.ptp(lattice.keys, axis=0).max() == 28
    # The square edges fall between pixel centres: at 20.5 + 22 c, 30.5 + 22 r.
    truth = np.array([[20.5 + 22 * c, 30.5 + 22 * r] for c in range(1, 30) for r in range(1, 5)]).T
    d = np.hypot(*(lattice.points[:, :, None] - truth[:, None, :])).min(axis=1)
    assert d.max() < 0.75


def along_reference(vec, length, pool, direction):
    """The entry of ``pool`` nearest ``direction`` within 15 degrees and 0.7-1.4 of its length."""
    size = np.hypot(*direction)
    best, best_err = None, None
    for n in pool:
        cos = (direction[0] * vec[0, n] + direction[1] * vec[1, n]) / (size * max(length[n], 1e-12))
        ratio = length[n] / size
        if cos > np.cos(np.radians(15)) and 0.7 < ratio < 1.4:
            err = np.hypot(*(vec[:, n] - direction))
            if best is None or err < best_err:
                best, best_err = n, err
    return best


def cross_reference(vec, length, opposite):
    """Arms (a, b, c, d) and node count of a seed's cross, as lattice._seed_cross chooses them."""
    best, arms = 0, None
    for a in opposite[:3]:
        b = along_reference(vec, length, opposite, -vec[:, a])
        sideways = [n for n in opposite if n not in (a, b)
                    and abs(vec[0, a] * vec[1, n] - vec[1, a] * vec[0, n]) > 0.5 * length[a] * length[n]]
        if not sideways:
            continue
        c = sideways[0]
        d = along_reference(vec, length, opposite, -vec[:, c])
        count = 3 + (b is not None) + (d is not None)
        if count >= 4 and count > best:
            best, arms = count, (a, -1 if b is None else b, c, -1 if d is None else d)
    return best, arms


def test_the_seed_cross_picks_the_arms_the_plain_loop_picks():
    rng = np.random.default_rng(5)
    grid = np.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1) if (i, j) != (0, 0)] + [(2, 0), (0, 2), (2, 1)], float)
    found = 0
    for trial in range(200):
        angle = rng.uniform(0, np.pi)
        R = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        vec = np.ascontiguousarray(R @ (25.0 * grid.T) + rng.normal(0, rng.choice([0.5, 4.0]), (2, grid.shape[0])))
        length = np.hypot(*vec)
        opposite = np.flatnonzero(rng.random(grid.shape[0]) < 0.7).astype(np.int64)
        arms = np.full(4, -7, dtype=np.int64)
        count = _lattice.pick_cross(vec, length, opposite, arms)
        want, want_arms = cross_reference(vec, length, opposite)
        assert count == want
        if want:
            assert tuple(arms) == want_arms
            found += 1
    assert 20 < found < 200  # crosses found and refused, both


def side_reference(P, value, expect, rows, depths, width, height, mid, contrast, alternates=0.5, plain=0.35):
    """identify's verdict on one side from its samples, in NumPy."""
    inside = (P[:, 0] >= 0) & (P[:, 1] >= 0) & (P[:, 0] <= width - 1) & (P[:, 1] <= height - 1)
    dark = np.where(inside, np.clip((mid - value) / (0.5 * contrast), -1.0, 1.0), np.nan)
    outer = dark[:, 0] * expect
    square = np.floor(depths).astype(int)
    if np.sum(np.isfinite(outer)) < 2 or np.mean(outer > alternates) < 0.75:
        return 0
    pairs = np.flatnonzero(np.diff(rows) == 1)
    pair = 0.5 * (dark[pairs] - dark[pairs + 1]) * expect[pairs, None] * np.where(square % 2 == 1, -1.0, 1.0)
    per = {}
    for k in (1, 2, 3):
        seen = np.isfinite(pair[:, square == k])
        total = np.where(seen, pair[:, square == k], 0.0).sum(axis=1)
        per[k] = np.where(seen.sum(axis=1) >= 2, total / np.maximum(seen.sum(axis=1), 1), np.nan)
    first = per[1][np.isfinite(per[1])]
    if not first.size:
        return 0
    if first.mean() > alternates:
        return 1
    if not (first.mean() < plain and np.sum(first > alternates) <= first.size // 4):
        return 0
    for k in (2, 3):
        later = per[k][np.isfinite(per[k])]
        if later.size and (later.mean() > plain or np.sum(later > alternates) > max(1, later.size // 3)):
            return 0
    return 2


def test_the_side_verdict_is_the_plain_one_on_random_sides():
    from graphpose.detect import _identify
    from graphpose.detect.identify import BEYOND_DEPTHS, OUTER_DEPTH, RESUME_DEPTHS

    rng = np.random.default_rng(6)
    depths = np.array((OUTER_DEPTH,) + BEYOND_DEPTHS + RESUME_DEPTHS)
    verdicts = []
    for trial in range(400):
        m = int(rng.integers(2, 10))
        rows = np.sort(rng.choice(12, m, replace=False)).astype(np.int64) if rng.random() < 0.3 else np.arange(m)
        expect = np.where(np.arange(m) % 2 == 0, 1.0, -1.0)
        # Dark where the pattern says, to a degree: a board going on, an edge, or clutter.
        colour = expect[:, None] * np.where(np.floor(depths) % 2 == 1, -1.0, 1.0)
        kind = rng.integers(3)
        pattern = np.where(np.floor(depths) == 0, 1.0, [1.0, 0.0, rng.uniform(-1, 1)][kind])
        value = 120.0 - 80.0 * colour * pattern + rng.normal(0, rng.choice([5.0, 40.0]), (m, depths.size))
        edge = rng.uniform(-40, 140, (m, 2))
        step = rng.uniform(10, 40, (m, 2)) * rng.choice([-1, 1], 2)
        P = np.ascontiguousarray(edge[:, :, None] + step[:, :, None] * depths)
        got = _identify.side_verdict(P, value, expect, rows, np.floor(depths).astype(np.int64), 160.0, 120.0, 120.0,
                                     160.0, 0.5, 0.35)
        assert got == side_reference(P, value, expect, rows, depths, 160.0, 120.0, 120.0, 160.0), trial
        verdicts.append(got)
    assert set(verdicts) == {0, 1, 2}


def side_geometry_reference(grid, keys, side, depths, flat_side, dark_parity):
    """identify's side geometry the plain NumPy way: (P, rows, expect, steps), or None where
    the side is not flat (or fewer than 2 rows)."""
    axis, direction = side
    along, across = keys[:, axis], keys[:, 1 - axis]
    extreme = int(along.min() if direction < 0 else along.max())
    line, at = np.unique(across, return_inverse=True)
    ends = np.full(line.size, extreme - direction * (int(np.ptp(along)) + 1))
    (np.minimum if direction < 0 else np.maximum).at(ends, at, along)
    if np.mean(ends == extreme) < flat_side:
        return None
    b = np.sort(across[along == extreme])
    four = np.empty((b.size, 4, 2), dtype=int)
    four[:, :, axis] = np.array([0, 0, -direction, -direction]) + extreme
    four[:, :, 1 - axis] = b[:, None] + np.array([0, 1, 0, 1])
    C = grid.at(four.reshape(-1, 2)).T.reshape(b.size, 4, 2)
    whole = np.isfinite(C).all(axis=(1, 2))
    rows, C = b[whole], C[whole]
    if len(rows) < 2:
        return None
    expect = np.where((extreme + (direction - 1) // 2 + rows) % 2 == dark_parity, 1.0, -1.0)
    edge = 0.5 * (C[:, 0] + C[:, 1])
    step = edge - 0.5 * (C[:, 2] + C[:, 3])
    return edge[:, :, None] + step[:, :, None] * depths, rows, expect, np.hypot(step[:, 0], step[:, 1])


def ragged_keys(rng, min_side, drop):
    """A random grid of lattice keys with holes and ragged edges, about a random (also
    negative) origin: (M, 2) int, possibly empty; ``drop`` the fractions of keys to drop."""
    cols, rows = int(rng.integers(min_side, 9)), int(rng.integers(min_side, 7))
    i, j = np.meshgrid(np.arange(cols), np.arange(rows), indexing="ij")
    keys = np.column_stack([i.ravel(), j.ravel()]) + rng.integers(-5, 5, 2)
    return keys[rng.random(len(keys)) > rng.choice(drop)]


def test_the_side_geometry_is_the_plain_one_on_random_lattices():
    from graphpose.detect import _identify
    from graphpose.detect.identify import _DEPTHS, FLAT_SIDE, SIDES

    rng = np.random.default_rng(8)
    flat = 0
    for trial in range(300):
        keys = ragged_keys(rng, 2, [0.0, 0.1, 0.3])
        if len(keys) < 2:
            continue
        H = np.array([[30.0, 2.0, 100.0], [-1.0, 28.0, 80.0], [1e-3, 2e-3, 1.0]]) + rng.normal(0, 1e-3, (3, 3))
        q = H @ np.vstack([keys.T, np.ones(len(keys))])
        grid = KeyGrid.of(keys, q[:2] / q[2])
        for side in SIDES:
            for parity in (0, 1):
                want = side_geometry_reference(grid, keys, side, _DEPTHS, FLAT_SIDE, parity)
                n = len(keys)
                P, r, e, s = np.empty((n, 2, _DEPTHS.size)), np.empty(n, np.int64), np.empty(n), np.empty(n)
                m = _identify.side_geometry(grid.array, int(grid.origin[0]), int(grid.origin[1]),
                                            np.ascontiguousarray(keys, dtype=np.int64), side[0], side[1], _DEPTHS,
                                            FLAT_SIDE, parity, P, r, e, s)
                if want is None:
                    assert m < 2, (trial, side)
                    continue
                flat += 1
                assert m == len(want[1]), (trial, side)
                np.testing.assert_array_equal(P[:m], want[0])
                np.testing.assert_array_equal(r[:m], want[1])
                np.testing.assert_array_equal(e[:m], want[2])
                np.testing.assert_array_equal(s[:m], want[3])
    assert flat > 200  # most sides were compared, not refused


def test_step_lengths_are_the_plain_mean_distances_to_the_neighbours():
    from graphpose.detect.lattice import step_lengths

    rng = np.random.default_rng(9)
    for trial in range(50):
        keys = {(int(i), int(j)) for i, j in rng.integers(-4, 5, (int(rng.integers(1, 40)), 2))}
        nodes = {key: rng.uniform(0, 300, 2) for key in keys}
        asked = list(keys) + [(9, 9), (-20, 3)]  # two keys that are no nodes
        want = []
        for i, j in asked:
            here = nodes.get((i, j))
            d = [np.hypot(*(nodes[(i + a, j + b)] - here)) for a, b in STEPS
                 if here is not None and (i + a, j + b) in nodes]
            want.append(np.sum(d) / len(d) if d else np.nan)
        np.testing.assert_allclose(step_lengths(nodes, asked), want, rtol=1e-15)


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


def test_the_grey_range_of_an_eight_bit_image_is_the_partitions():
    from graphpose.detect.noise import grey_range

    rng = np.random.default_rng(11)
    for trial in range(200):
        image = rng.integers(0, 256, tuple(rng.integers(1, 60, 2))).astype(np.uint8)
        if trial % 3 == 0:
            image = image[::2, 1:]  # a strided view, as a board's crop is
        stride, tail = int(rng.integers(1, 5)), float(rng.choice([0.0, 1.0, 5.0, 25.0, 50.0, 70.0]))
        values = image[::stride, ::stride].ravel()
        if values.size == 0:
            assert grey_range(image, stride=stride, tail=tail) == 0.0
            continue
        k = np.rint(np.array([tail, 100.0 - tail]) / 100.0 * (values.size - 1)).astype(int)
        lo, hi = np.partition(values, k)[k]
        assert grey_range(image, stride=stride, tail=tail) == float(hi) - float(lo), trial
        assert grey_range(image.astype(float), stride=stride, tail=tail) == float(hi) - float(lo), trial


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


def test_whole_squares_are_the_plain_ones_on_random_lattices():
    from graphpose.detect import _identify

    rng = np.random.default_rng(13)
    compared = 0
    for trial in range(200):
        keys = ragged_keys(rng, 1, [0.0, 0.2, 0.5])
        if not len(keys):
            continue
        grid = KeyGrid.of(keys, rng.uniform(0, 500, (2, len(keys))))
        # The plain way: the four nodes of each key's square, those with all four seen.
        P = np.stack([grid.at(keys + step) for step in ((0, 0), (1, 0), (0, 1), (1, 1))])
        whole = np.isfinite(P).all(axis=(0, 1))
        n = len(keys)
        centres, steps, parity = np.empty((2, n)), np.empty(n), np.empty(n, np.int64)
        m = _identify.whole_squares(grid.array, int(grid.origin[0]), int(grid.origin[1]),
                                    np.ascontiguousarray(keys, dtype=np.int64), centres, steps, parity)
        assert m == whole.sum(), trial
        P = P[:, :, whole]
        np.testing.assert_array_equal(centres[:, :m], (P[0] + P[1] + P[2] + P[3]) / 4)
        np.testing.assert_array_equal(steps[:m], np.hypot(*(P[1] - P[0])))
        np.testing.assert_array_equal(parity[:m], keys[whole].sum(axis=1) % 2)
        compared += m
    assert compared > 500


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


def immerkaer_reference(image, s):
    """|Immerkaer's mask| at every s-th row and column, float32, the plain way."""
    a = image.astype(np.float32)
    h, w = a.shape
    out = []
    for i in range(0, h - 2, s):
        for j in range(0, w - 2, s):
            p = a[i:i + 3, j:j + 3]
            out.append(abs(p[0, 0] - 2 * p[0, 1] + p[0, 2] - 2 * (p[1, 0] - 2 * p[1, 1] + p[1, 2])
                           + p[2, 0] - 2 * p[2, 1] + p[2, 2]))
    return np.array(out, dtype=np.float32)


@pytest.mark.parametrize("s", [1, 3, 4])
def test_the_noise_median_of_an_eight_bit_image_is_the_partitions(s):
    from graphpose.detect.noise import _MAD_TO_SIGMA, estimate_noise

    rng = np.random.default_rng(s)
    for image in (rng.integers(0, 256, (41, 57)).astype(np.uint8), np.full((9, 9), 7, np.uint8),
                  (rng.uniform(size=(30, 40)) > 0.5).astype(np.uint8) * 255):
        r = immerkaer_reference(image, s)
        median = np.partition(r, r.size // 2)[r.size // 2]
        assert estimate_noise(image, stride=s) == pytest.approx(float(median) * _MAD_TO_SIGMA / 6.0, rel=1e-15)
        # The float path (the same responses, partitioned) agrees with the counted one.
        assert estimate_noise(image.astype(np.float32), stride=s) == estimate_noise(image, stride=s)


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


def test_nearest_candidates_are_the_k_d_trees():
    """A seed's neighbours (``_lattice.nearest``, brute force) replaced SciPy's k-d tree: the
    same neighbours at the same distances, nearest first, equal distances in index order."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(4)
    for trial in range(40):
        P = rng.uniform(0, 640, (2, int(rng.integers(3, 600))))
        if trial % 2:
            P = np.round(P / 8) * 8  # many equal distances
        k, queries = min(13, P.shape[1]), np.arange(min(16, P.shape[1]), dtype=np.int64)
        out = np.empty((len(queries), k), dtype=np.int64)
        _lattice.nearest(np.ascontiguousarray(P), queries, out)
        d2 = ((P[:, None, :] - P[:, queries][:, :, None]) ** 2).sum(axis=0)
        for q in range(len(queries)):
            np.testing.assert_array_equal(out[q], np.lexsort((np.arange(P.shape[1]), d2[q]))[:k])
        distance, tree = cKDTree(P.T).query(P[:, queries].T, k=k)
        np.testing.assert_allclose(np.hypot(*(P[:, out] - P[:, queries][:, :, None])), distance, rtol=1e-14, atol=1e-12)
        if trial % 2 == 0:
            np.testing.assert_array_equal(out, tree)

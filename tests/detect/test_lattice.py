"""graphpose.detect.lattice: growing a lattice of junctions from candidates, its predictions,
step lengths and peeling, and the compiled kernels behind them (``_lattice.pyx``) against
plain Python written here."""

import math

import numpy as np
import pytest

from graphpose import Board
from graphpose.detect import _lattice
from graphpose.detect.grid import fit_homography
from graphpose.detect.identify import identify
from graphpose.detect.lattice import KeyGrid, Lattice, grow_lattices, peel, predict, step_lengths
from graphpose.detect.search import find_candidates
from graphpose.synth.scenes import random_scene
from tests.conftest import PROJECT_K as K

STEPS = ((1, 0), (-1, 0), (0, 1), (0, -1))


def test_predict_extrapolates_a_straight_line_and_completes_a_parallelogram():
    line = {(0, 0): (0.0, 0.0), (1, 0): (10.0, 1.0), (2, 0): (20.0, 2.0)}
    (u, v), step = predict(line, (3, 0))
    assert (u, v) == pytest.approx((30.0, 3.0)) and step == pytest.approx(np.hypot(10, 1))
    square = {(0, 0): (0.0, 0.0), (1, 0): (10.0, 0.0), (0, 1): (0.0, 10.0)}
    assert predict(square, (1, 1))[0] == pytest.approx((10.0, 10.0))
    assert predict({(0, 0): (0.0, 0.0)}, (5, 5)) is None


def test_step_lengths_are_the_mean_distance_to_the_lattice_neighbours_present():
    rng = np.random.default_rng(4)
    nodes = {(i, j): np.array([31.0 * i + 3.0 * j, 29.0 * j - 2.0 * i]) + rng.normal(0, 0.5, 2)
             for i in range(-3, 4) for j in range(-2, 3) if rng.random() < 0.7}
    nodes[(9, 9)] = np.array([500.0, 500.0])  # no neighbours: NaN
    keys = list(nodes)
    for key, got in zip(keys, step_lengths(nodes, keys)):
        i, j = key
        d = [np.hypot(*(nodes[k] - nodes[key])) for k in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)) if k in nodes]
        assert (np.isnan(got) and not d) or got == pytest.approx(np.mean(d), abs=1e-12)
    # A lattice's own step lengths, read from its arrays, are the same numbers.
    lattice = Lattice(np.array(keys), np.array([nodes[k] for k in keys]).T, 0.0)
    assert np.array_equal(lattice.step_lengths(), step_lengths(nodes, keys), equal_nan=True)


def test_peel_drops_strays_with_fewer_than_two_neighbours():
    nodes = {(i, j): np.zeros(2) for i in range(3) for j in range(3)}
    nodes[(5, 0)] = nodes[(3, 0)] = np.zeros(2)  # (3, 0) has one neighbour, (5, 0) none
    assert set(peel(nodes)) == {(i, j) for i in range(3) for j in range(3)}


def test_peel_keeps_what_dropping_strays_one_pass_at_a_time_keeps():
    rng = np.random.default_rng(8)
    for _ in range(20):
        nodes = {(int(i), int(j)): np.array([i, j], float) for i, j in rng.integers(-4, 5, (30, 2))}
        left = dict(nodes)  # the plain reference: whole passes over a dict until none drops
        while drop := [k for k in left if sum((k[0] + a, k[1] + b) in left for a, b in
                                              ((1, 0), (-1, 0), (0, 1), (0, -1))) < 2]:
            for k in drop:
                del left[k]
        assert list(peel(nodes)) == list(left)


def test_lattice_of_a_clean_board_holds_every_junction_right_handed():
    R = random_scene(K, Board(), rng=3).rendering
    cands = find_candidates(R.image)
    lattice = next(lat for _, lat in grow_lattices(cands) if lat is not None)
    assert len(lattice.keys) == 48
    extent = lattice.keys.max(axis=0) - lattice.keys.min(axis=0) + 1
    assert sorted(extent) == [6, 8]
    # Right-handed: the key step (1, 0) turned by +90 degrees in (u, v) is the step (0, 1).
    nodes = lattice.as_dict()
    i, j = lattice.keys[np.argmin(np.abs(lattice.keys - lattice.keys.mean(axis=0)).sum(axis=1))]
    a, b = nodes[(i + 1, j)] - nodes[(i, j)], nodes[(i, j + 1)] - nodes[(i, j)]
    assert a[0] * b[1] - a[1] * b[0] > 0
    # The growth's homography is the fit of its keys to its points, and the labelling it
    # spares is the labelling of the same lattice without it.
    assert np.array_equal(lattice.homography, fit_homography(lattice.keys.T.astype(float), lattice.points))
    bare = identify(Lattice(lattice.keys, lattice.points, lattice.theta0), cands.view, Board())
    assert np.array_equal(bare.index, identify(lattice, cands.view, Board()).index)



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

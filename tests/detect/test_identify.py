"""graphpose.detect.identify: labelling a lattice as the board, and the compiled kernels
behind it (``_identify.pyx``) against plain NumPy written here."""

import numpy as np
import pytest

from graphpose import Board, BoardMismatchError
from graphpose.detect.identify import ROTATIONS, SIDES, identify
from graphpose.detect.lattice import KeyGrid, grow_lattices
from graphpose.detect.search import find_candidates
from graphpose.synth.scenes import random_scene
from tests.conftest import PROJECT_K as K


def side_reference(P, value, expect, rows, depths, width, height, mid, contrast, alternates=0.5, plain=0.35,
                   every_depth=True):
    """identify's verdict on one side from its samples, in NumPy (``every_depth`` False: without
    the rule that the square beyond an edge is plain at each of its depths)."""
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
    # Plain at each depth of the square beyond too (a bar along the line beyond the lattice).
    for d in np.flatnonzero(square == 1) if every_depth else ():
        o = -0.5 * (dark[pairs, d] - dark[pairs + 1, d]) * expect[pairs]
        o = o[np.isfinite(o)]
        if o.size >= 2 and o.mean() > plain:
            return 0
    return 2


def test_the_side_verdict_is_the_plain_one_on_random_sides():
    from graphpose.detect import _identify
    from graphpose.detect.identify import BEYOND_DEPTHS, OUTER_DEPTH, RESUME_DEPTHS

    rng = np.random.default_rng(6)
    depths = np.array((OUTER_DEPTH,) + BEYOND_DEPTHS + RESUME_DEPTHS)
    verdicts, by_depth = [], 0
    for trial in range(400):
        m = int(rng.integers(2, 10))
        rows = np.sort(rng.choice(12, m, replace=False)).astype(np.int64) if rng.random() < 0.3 else np.arange(m)
        expect = np.where(np.arange(m) % 2 == 0, 1.0, -1.0)
        # Dark where the pattern says, to a degree: a board going on, an edge, or clutter.
        colour = expect[:, None] * np.where(np.floor(depths) % 2 == 1, -1.0, 1.0)
        kind = rng.integers(4)
        pattern = np.where(np.floor(depths) == 0, 1.0, [1.0, 0.0, rng.uniform(-1, 1), 0.0][kind])
        if kind == 3:  # a bar along the line beyond: the squares show at one or two depths of square 1
            pattern[rng.choice(np.flatnonzero(np.floor(depths) == 1), int(rng.integers(1, 3)), replace=False)] = 1.0
        value = 120.0 - 80.0 * colour * pattern + rng.normal(0, rng.choice([5.0, 40.0]), (m, depths.size))
        edge = rng.uniform(-40, 140, (m, 2))
        step = rng.uniform(10, 40, (m, 2)) * rng.choice([-1, 1], 2)
        P = np.ascontiguousarray(edge[:, :, None] + step[:, :, None] * depths)
        got = _identify.side_verdict(P, value, expect, rows, np.floor(depths).astype(np.int64), 160.0, 120.0, 120.0,
                                     160.0, 0.5, 0.35)
        assert got == side_reference(P, value, expect, rows, depths, 160.0, 120.0, 120.0, 160.0), trial
        verdicts.append(got)
        by_depth += got == 0 and side_reference(P, value, expect, rows, depths, 160.0, 120.0, 120.0, 160.0,
                                                  every_depth=False) == 2
    assert set(verdicts) == {0, 1, 2}
    assert by_depth > 5  # the rule at each depth decided some sides


def line_passes_reference(view, H, keys, axis, line, at, theta0):
    """Do two neighbouring keys of line ``at`` (over the span of lattice line ``line`` along
    ``axis``) pass the ring test through ``H`` with their parity: identify's check, in NumPy."""
    from graphpose.detect.lattice import MIN_SCORE, PARITY_COS, RING_FRACTION
    span = np.unique(keys[keys[:, axis] == line][:, 1 - axis])
    if not span.size:
        return False
    K_ = np.empty((2, span.size))
    K_[axis], K_[1 - axis] = at, span
    q = H @ np.vstack([K_, np.ones(span.size)])
    if np.any(q[2] * np.sign(np.median(q[2])) <= 0):
        return False
    P = q[:2] / q[2]
    K2 = K_.copy()
    K2[axis] -= np.sign(at - line)
    q2 = H @ np.vstack([K2, np.ones(span.size)])
    step = np.hypot(*(P - q2[:2] / q2[2]))
    height, width = view.shape
    margin = RING_FRACTION * step + 1.0
    inside = (P[0] >= margin) & (P[1] >= margin) & (P[0] <= width - 1 - margin) & (P[1] <= height - 1 - margin)
    inside &= step >= 4.0
    if inside.sum() < 2:
        return False
    score, theta, _ = view.ring_test(np.ascontiguousarray(P[:, inside]), RING_FRACTION * step[inside])
    turn = np.cos(2 * (theta - theta0))
    parity = (K_[0, inside] + K_[1, inside]).astype(int) % 2
    passed = np.zeros(span.size, dtype=bool)
    passed[inside] = (score > MIN_SCORE) & np.where(parity == 0, turn > PARITY_COS, turn < -PARITY_COS)
    return bool(np.any(passed[1:] & passed[:-1] & (np.diff(span) == 1)))


def test_the_line_beyond_a_side_is_the_plain_one_on_rendered_boards():
    from graphpose.detect import _identify
    from graphpose.detect.grid import fit_homography
    from graphpose.detect.lattice import MIN_SCORE, PARITY_COS, RING_FRACTION

    rng = np.random.default_rng(5)
    outcomes = []
    for seed in range(3):
        scene = random_scene(K, Board(9, 6, 0.03), distance=(0.45, 1.0), max_roll_deg=180.0, rng=seed)
        lattice, view = _lattice_of(scene)
        H = fit_homography(lattice.keys.T.astype(float), lattice.points)
        for trial in range(40):
            keys = lattice.keys[rng.random(len(lattice.keys)) > rng.choice([0.0, 0.3])]
            keys = np.ascontiguousarray(keys, dtype=np.int64)
            if not len(keys):
                continue
            axis = int(rng.integers(2))
            lo, hi = keys[:, axis].min(), keys[:, axis].max()
            line = int(rng.integers(lo - 1, hi + 2))
            inwards = -1 if line > (lo + hi) / 2 else 1  # mostly inwards: lines that come back
            direction = inwards if rng.random() < 0.7 else -inwards
            Ht = H @ np.array([[1.0, 0.0, rng.normal(0, 0.05)], [0.0, 1.0, rng.normal(0, 0.05)], [0.0, 0.0, 1.0]])
            first = int(rng.integers(2, 5))
            want = next((out for out in range(first, 5) if line_passes_reference(
                view, Ht, keys, axis, line, line + out * direction, lattice.theta0)), 0)
            height, width = view.shape
            got = _identify.line_returns(view.smooth, view.level, float(width), float(height), Ht, keys, axis, line,
                                         direction, first, 4, lattice.theta0, RING_FRACTION, MIN_SCORE, PARITY_COS)
            assert got == want, (seed, trial)
            outcomes.append(got)
    assert set(outcomes) == {0, 2, 3, 4}  # lines that come back, at several distances, and lines that do not


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


@pytest.mark.slow  # 0.6 s or so on two idle cores: a render, a calibration or a subprocess
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


def _lattice_of(scene):
    cands = find_candidates(scene.image)
    lattice = max((lat for _, lat in grow_lattices(cands) if lat is not None), key=lambda lat: len(lat.keys))
    return lattice, cands.view


@pytest.mark.parametrize("seed", range(3))
def test_an_asymmetric_boards_lattice_is_labelled_as_the_truth(seed):
    board = Board(9, 6, 0.03)
    scene = random_scene(K, board, distance=(0.45, 1.0), max_roll_deg=180.0, rng=seed)
    lattice, view = _lattice_of(scene)
    found = identify(lattice, view, board)
    assert not found.orientation_ambiguous and found.junction0_square == "dark"
    assert sorted(found.index.tolist()) == list(range(board.n))  # every junction, once
    # Each node lies on the true junction of its label.
    truth = scene.rendering.junctions
    assert np.hypot(*(lattice.points - truth[:, found.index])).max() < 1.5
    # The labels are the rotation and offset the identity names: (c, r) = M (i, j) + t.
    assert any(np.array_equal(found.rotation, M) for M in ROTATIONS)
    cr = lattice.keys @ found.rotation.T + found.offset
    np.testing.assert_array_equal(found.index, cr[:, 1] * board.cols + cr[:, 0])
    assert set(found.sides.values()) <= {"edge", "continues", "unknown"} and set(found.sides) == set(SIDES)


def test_a_lattice_of_another_size_than_the_spec_is_refused_as_a_mismatch():
    scene = random_scene(K, Board(), rng=11)
    lattice, view = _lattice_of(scene)
    with pytest.raises(BoardMismatchError, match="found a 8 x 6 board of junctions; the board spec says"):
        identify(lattice, view, Board(7, 5))


def test_bounds_that_leave_out_junctions_the_labels_place_refuse_them():
    # A part of a 6 x 6 board whose sides passed for edges (a highlight beside it taken for the
    # margin) is placed at the board's corner; bounds round the whole board say otherwise.
    from graphpose.detect.identify import _check_bounds_enclose
    from graphpose.errors import BoardNotFoundError
    board = Board(6, 6, 0.04)
    H = np.array([[20.0, 0.0, 100.0], [0.0, 20.0, 80.0], [0.0, 0.0, 1.0]])  # grid key -> pixel
    fit = (np.eye(2, dtype=int), np.array([0, 0]))
    # Round the board the labels place (one square out, a rough hand): accepted.
    around = np.array([[80.0, 222.0, 218.0, 78.0], [58.0, 61.0, 202.0, 200.0]])
    _check_bounds_enclose(fit, H, board, around, np.array([3, 3]))
    # The same bounds 3 squares along: the labels put two lines of junctions outside them.
    with pytest.raises(BoardNotFoundError, match="bounds disagree"):
        _check_bounds_enclose(fit, H, board, around + [[60.0], [0.0]], np.array([3, 3]))

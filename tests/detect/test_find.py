"""Finding and labelling the board without a polygon: candidates, lattices, identity.

Every scene is rendered with exact truth (graphpose.synth.scenes); a result is right when
each junction it reports seen lies on the true junction of the same label (or, for a
board whose pattern a half turn maps onto itself, of the label the documented rule
gives), and a refusal is a BoardNotFoundError that says why.
"""

import numpy as np
import pytest

from graphpose import Board, BoardNotFoundError, InputError, K_from_params
from graphpose.geometry import T_from_params
from graphpose.detect import find as find_module
from graphpose.detect.find import find_board
from graphpose.detect.search import find_candidates, search_levels
from graphpose.synth.render import render
from graphpose.synth.scenes import random_scene
from tests.conftest import PROJECT_K as K


def half_turn(board: Board) -> np.ndarray:
    """Label permutation of a half turn: junction k <-> n - 1 - k."""
    return np.arange(board.n)[::-1]


def label_error(found, truth: np.ndarray, perm=None) -> float:
    """Largest distance (px) between seen junctions and the true junctions of their labels."""
    idx = np.arange(truth.shape[1]) if perm is None else perm
    return float(np.max(np.hypot(*(found.points[:, found.seen] - truth[:, idx[found.seen]]))))


@pytest.mark.slow  # 0.6 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("seed", range(12))
def test_an_asymmetric_board_is_labelled_as_the_truth_at_any_rotation(seed):
    # 9 x 6 junctions = 10 x 7 squares: a half turn changes the pattern, so the square
    # colours fix junction 0 (its outer corner square is dark) whatever the roll.
    board = Board(9, 6, 0.03)
    scene = random_scene(K, board, distance=(0.45, 1.0), rng=seed)
    found = find_board(scene.image, board)
    assert not found.orientation_ambiguous
    assert found.seen.all() and label_error(found, scene.rendering.junctions) < 1.5


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("seed", range(8))
def test_a_symmetric_board_is_flagged_and_labelled_by_the_upper_left_rule(seed):
    board = Board()
    scene = random_scene(K, board, rng=100 + seed)
    found = find_board(scene.image, board)
    truth = scene.rendering.junctions
    assert found.orientation_ambiguous and found.seen.all()
    # The rule: of the two labellings a half turn relates, junction 0 is the one nearer
    # the image's upper-left corner.
    rule = np.arange(board.n) if np.hypot(*truth[:, 0]) <= np.hypot(*truth[:, -1]) else half_turn(board)
    assert label_error(found, truth, rule) < 1.5


def test_bounds_fix_the_orientation_of_a_symmetric_board():
    board = Board()
    scene = random_scene(K, board, max_roll_deg=180.0, rng=7)
    found = find_board(scene.image, board, scene.rendering.outline)
    assert not found.orientation_ambiguous
    assert label_error(found, scene.rendering.junctions) < 1.5


def test_bounds_a_little_off_do_not_move_the_labels():
    board = Board()
    scene = random_scene(K, board, rng=8)
    rng = np.random.default_rng(0)
    base = find_board(scene.image, board, scene.rendering.outline)
    for _ in range(5):
        jitter = scene.rendering.outline + rng.uniform(-6, 6, (2, 4))
        moved = find_board(scene.image, board, jitter)
        np.testing.assert_array_equal(moved.seen, base.seen)
        np.testing.assert_allclose(moved.points, base.points)


@pytest.mark.parametrize("spec", [Board(7, 5), Board(9, 6), Board(8, 5)])
def test_a_board_spec_that_does_not_match_the_image_is_refused(spec):
    scene = random_scene(K, Board(), rng=11)
    with pytest.raises(BoardNotFoundError, match="found a 8 x 6 board of junctions; the board spec says"):
        find_board(scene.image, spec)


@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
def test_a_board_cut_by_the_image_edge_keeps_its_labels_from_the_edge_that_is_seen():
    board = Board(9, 6, 0.03)
    labelled = 0
    for seed in range(6):
        scene = random_scene(K, board, occluders=("edge",), distance=(0.45, 0.9), rng=200 + seed)
        try:
            found = find_board(scene.image, board)
        except BoardNotFoundError as exc:
            assert "hidden" in str(exc) or "fits" in str(exc)
            continue
        labelled += 1
        assert label_error(found, scene.rendering.junctions) < 1.5
        assert not np.any(found.seen & ~scene.visible)  # off-image junctions are not seen
        assert np.all(np.isnan(found.points[:, ~found.seen]))
    assert labelled >= 3  # the test is not passed by refusing every scene


def test_both_edges_of_an_axis_hidden_is_refused_with_the_reason():
    # A board that overflows the image on both sides: nothing fixes its columns.
    board = Board(14, 3, 0.05)
    R = render(K, T_from_params([0.325, 0.05, -0.45, 0.0, 0.0, 0.05]), board, rng=4)
    assert R.junctions[0].min() < 0 and R.junctions[0].max() > 640
    with pytest.raises(BoardNotFoundError, match="two opposite edges of the board are hidden"):
        find_board(R.image, board)


def test_two_boards_without_bounds_are_refused():
    # Two halves of one picture, a whole board in each.
    board = Board(5, 4, 0.03)
    half = K_from_params(K[0, 0], K[1, 1], 160.0, 240.0)
    left = render(half, T_from_params([0.06, 0.045, -0.6, 0.0, 0.0, 0.2]), board, (320, 480), rng=5).image
    right = render(half, T_from_params([0.06, 0.045, -0.7, 0.0, 0.0, -0.3]), board, (320, 480), rng=6).image
    with pytest.raises(BoardNotFoundError, match="two checkerboards"):
        find_board(np.hstack([left, right]), board)


@pytest.mark.slow  # many rendered occluded scenes
@pytest.mark.parametrize("occluder", ["bar", "blob", "reflection"])
def test_occluded_boards_are_labelled_right_or_refused(occluder):
    board = Board()
    labelled = 0
    for seed in range(10):
        scene = random_scene(K, board, occluders=(occluder,), rng=300 + seed)
        try:
            found = find_board(scene.image, board)
        except BoardNotFoundError:
            continue
        labelled += 1
        truth = scene.rendering.junctions
        errors = [label_error(found, truth, perm) for perm in (None, half_turn(board))]
        # Coarse positions: a partly covered junction may be a pixel or two off; a wrong
        # label would be a whole square (tens of pixels) off.
        assert min(errors) < 4.0, (seed, errors)
    assert labelled >= 4  # the test is not passed by refusing every scene


@pytest.mark.slow  # many rendered scenes with clutter
def test_clutter_beside_the_board_changes_nothing():
    board = Board(9, 6, 0.03)
    for seed in range(5):
        scene = random_scene(K, board, clutter=("text", "grid"), distance=(0.6, 1.0), rng=400 + seed)
        found = find_board(scene.image, board)
        assert found.seen.all() and label_error(found, scene.rendering.junctions) < 1.5


def test_small_squares_are_found_at_full_resolution():
    board = Board()
    scene = random_scene(K, board, distance=(2.8, 3.2), rng=12)  # squares of about 12 px
    found = find_board(scene.image, board)
    assert found.seen.all()
    truth = scene.rendering.junctions
    assert min(label_error(found, truth), label_error(found, truth, half_turn(board))) < 1.5


def _large_scene(distance, seed):
    """The project camera scaled to 2560 x 1920 (a first search at an eighth), one board."""
    s = 4.0
    Kc = K_from_params(s * K[0, 0], s * K[1, 1], s * (K[0, 2] + 0.5) - 0.5, s * (K[1, 2] + 0.5) - 0.5)
    return random_scene(Kc, Board(), size=(2560, 1920), distance=distance, max_tilt_deg=40.0, rng=seed)


@pytest.mark.slow  # renders and searches a 12 MP image
def test_a_large_image_is_searched_at_an_eighth_and_labelled_right():
    board = Board()
    scene = _large_scene((0.8, 1.2), 3)  # squares of about 120 px: 15 at an eighth
    found = find_board(scene.image, board)
    assert found.seen.all()
    truth = scene.rendering.junctions
    assert min(label_error(found, truth), label_error(found, truth, half_turn(board))) < 3.0
    # It came from the first, coarsest search: that search alone gives the same labels.
    assert list(search_levels(scene.image.shape))[0] == 3
    assert find_candidates(scene.image, level=3).view.smooth.shape == (240, 320)
    eighth = find_module._search(scene.image, board, None, None, level=3)
    assert eighth.seen.all() and np.array_equal(eighth.points, found.points)


def test_a_partial_board_above_half_resolution_is_searched_again_at_half(monkeypatch):
    # Far squares hide at a coarse level: a partial board found above half resolution is
    # searched for at the finer levels down to half resolution too, the more complete kept.
    # A partial board (or none) then calls the noise-aware search, from the coarsest level
    # a board fits down to half resolution, levels searched already marked as such.
    board = Board()
    seen_part = np.arange(board.n) < 30
    whole = find_module.FoundBoard(np.zeros((2, board.n)), np.ones(board.n, bool), np.ones(board.n), False)
    part = find_module.FoundBoard(np.zeros((2, board.n)), seen_part, np.ones(board.n), False)
    calls = []

    def searches(results, noisy=None):
        def search(image, board_, bounds, region, level, noise=None, again=False):
            calls.append(level if noise is None else ("noise", level, again))
            found = results.get(level) if noise is None else (noisy or {}).get(level)
            if found is None:
                raise BoardNotFoundError(f"nothing at level {level}")
            return found
        calls.clear()
        monkeypatch.setattr(find_module, "_search", search)

    image = np.zeros((1200, 1600), np.uint8)  # levels 2, 1, 0; the noise-aware search's 4 to 1
    searches({2: part, 1: whole})
    assert find_board(image, board) is whole and calls == [2, 1]
    # Half resolution refusing, the partial board stands; a whole board at a quarter is final.
    searches({2: part})
    noisy = [("noise", 4, False), ("noise", 3, False), ("noise", 2, True), ("noise", 1, True)]
    assert find_board(image, board) is part and calls == [2, 1] + noisy
    searches({2: whole, 1: part})
    assert find_board(image, board) is whole and calls == [2]
    # Nothing at the coarsest level: the next one's partial board is searched for further.
    searches({1: part, 0: whole})
    assert find_board(np.zeros((3024, 4032), np.uint8), board) is part and calls[:3] == [3, 2, 1]
    # The noise-aware search's whole board is final; its partial one only if more complete.
    searches({}, {3: part, 2: whole})
    assert find_board(image, board) is whole and calls == [2, 1, 0, ("noise", 4, False), ("noise", 3, False),
                                                           ("noise", 2, True)]
    searches({2: part}, {3: find_module.FoundBoard(np.zeros((2, board.n)), np.arange(board.n) < 10,
                                                   np.ones(board.n), False)})
    assert find_board(image, board) is part


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
def test_small_squares_on_a_large_image_fall_back_to_finer_levels():
    board = Board()
    scene = _large_scene((7.0, 7.5), 5)  # squares of about 20 px: 5 at a quarter, too small
    with pytest.raises(BoardNotFoundError):
        find_module._search(scene.image, board, None, None, level=2)
    found = find_board(scene.image, board)
    assert found.seen.all()
    truth = scene.rendering.junctions
    assert min(label_error(found, truth), label_error(found, truth, half_turn(board))) < 1.5


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
def test_square_boards_with_odd_sides_put_a_dark_corner_at_junction_0():
    # 5 x 5 junctions = 6 x 6 squares: a quarter turn changes the colours, so only the half
    # turn is ambiguous; junction 0's corner square is dark in every labelling returned.
    board = Board(5, 5, 0.05)
    for seed in range(8):
        scene = random_scene(K, board, distance=(0.6, 1.0), rng=500 + seed)
        found = find_board(scene.image, board)
        truth = scene.rendering.junctions
        assert found.orientation_ambiguous
        assert min(label_error(found, truth), label_error(found, truth, half_turn(board))) < 1.5


def test_boards_under_three_by_three_are_refused_up_front():
    with pytest.raises(InputError, match="at least 3 x 3 inner junctions"):
        find_board(np.zeros((100, 100), dtype=np.uint8), Board(4, 2, 0.03))


def test_a_fainter_second_board_is_not_ignored():
    # The second board has a third of the first's contrast: its seeds come late, but it is
    # still seen, and two boards without bounds are refused.
    board = Board(5, 4, 0.03)
    half = K_from_params(K[0, 0], K[1, 1], 160.0, 240.0)
    left = random_scene(half, board, (320, 480), max_roll_deg=20.0, distance=(0.5, 0.7), rng=500).image
    right = random_scene(half, board, (320, 480), max_roll_deg=20.0, distance=(0.5, 0.7), contrast=0.35, rng=601).image
    assert find_board(right, board).seen.all()
    with pytest.raises(BoardNotFoundError, match="two checkerboards"):
        find_board(np.hstack([left, right]), board)


def test_a_blank_image_holds_no_board():
    with pytest.raises(BoardNotFoundError, match="no checkerboard"):
        find_board(np.full((240, 320), 128, dtype=np.uint8), Board())

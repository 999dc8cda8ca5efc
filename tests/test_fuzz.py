"""The project's fuzz on a fixed seed (``benchmarks/fuzz.py`` runs 2,000 inputs): no answer that
says ok may be wrong. And the four kinds of input the filer's fuzz found wrong, each a test."""

import numpy as np
import pytest

from benchmarks.fuzz import run, run_case
from graphpose import Board, BoardNotFoundError, extract_junctions
from graphpose.synth.fuzz import K_FUZZ, fuzz_case
from graphpose.synth.scenes import random_scene


def _case(seed, index, **fixed):
    """The ``index``-th case :func:`benchmarks.fuzz.run` draws from ``seed`` with ``fixed``."""
    rng = np.random.default_rng(seed)
    for _ in range(index):
        fuzz_case(rng, **fixed)
    return fuzz_case(rng, **fixed)


@pytest.mark.slow  # about 30-60 s: 100 rendered inputs through the detector and the pose
def test_no_ok_answer_is_wrong_on_a_fixed_seed():
    result = run(100, seed=2026)
    assert result["wrong"] == [], result["wrong"]
    answered = sum(c["right"] for c in result["counts"].values())
    assert answered >= 40  # the seed answers most inputs: the verdicts above are about real answers


@pytest.mark.slow  # up to 15 s: the seed's cases are drawn in turn (95 renders for index 94)
@pytest.mark.parametrize("index", [4, 7, 22, 94])
def test_a_rolled_outline_of_a_partly_seen_board_gives_no_pose_a_quarter_turn_off(index):
    """Before, each of these gave an ok pose 90 degrees off (the outline rolled by a vertex names
    another corner junction 0, and the visible part fits that labelling too)."""
    case = _case(1, index, polygon="rolled", partial=True)
    assert case.roll % 2 == 1 or case.board.cols == case.board.rows or case.entry == "pose"
    verdict = run_case(case)
    assert verdict["verdict"] in ("refused", "right", "input"), verdict


@pytest.mark.slow  # about 15 s: the seed's cases are drawn in turn (95 renders)
def test_a_rolled_outline_through_estimate_pose_is_refused_or_right():
    for index in (4, 7, 94):
        case = _case(1, index, polygon="rolled", partial=True)
        if case.entry != "pose":
            continue
        assert run_case(case)["verdict"] in ("refused", "right", "input")


@pytest.mark.slow  # renders and searches many hard scenes
def test_low_contrast_noise_and_a_specular_highlight_without_a_polygon_never_mislabel():
    """The filer's fourth: extract_junctions without a polygon, low contrast, noise 6, a specular
    highlight; 14 junctions trusted, all 78-219 px off. Twenty such scenes: none mislabelled."""
    from benchmarks.detect import best_errors, symmetries

    answered = 0
    for seed in range(20):
        rng = np.random.default_rng(seed)
        board = (Board(8, 6, 0.0635), Board(7, 5, 0.04), Board(5, 4, 0.05))[seed % 3]
        square = rng.uniform(14.0, 40.0)
        depth = K_FUZZ[0, 0] * board.square_m / square
        scene = random_scene(K_FUZZ, board, occluders=("reflection",), distance=(depth, depth * 1.05),
                             contrast=float(rng.uniform(0.2, 0.35)), noise_sigma=6.0, rng=rng)
        try:
            J = extract_junctions(scene.image, bounds=None, board=board)
        except BoardNotFoundError:
            continue
        answered += 1
        err = best_errors(J.points, J.trusted, scene.rendering.junctions, symmetries(board))
        assert err.size and err.max() < 1.5, (seed, err.max())
    assert answered >= 5


def _scene_case(entry, board, **scene):
    """A fuzz case without a polygon, rendered from ``random_scene``'s arguments as
    :func:`graphpose.synth.fuzz.fuzz_case` drew them (640 x 480, the fuzz's camera)."""
    from graphpose.synth.fuzz import FuzzCase

    sc = random_scene(K_FUZZ, board, (640, 480), **scene)
    R = sc.rendering
    return FuzzCase(sc.image, K_FUZZ, board, R.T_WC, R.junctions, sc.visible, None, "none", 0, entry,
                    {"occluders": scene["occluders"]})


#: Seed 0's cases 618 and 1000 of the benchmark's fuzz (before: mislabelled by a line, 78 and
#: 46 px): a bar narrower than a square lies along the line of junctions beyond the ones found,
#: hiding it; the board's next squares show beside the bar within the square beyond, so that
#: square is plain on average but not at each of its depths.
BAR_ALONG_A_LINE = {
    618: dict(occluders=("edge", "bar"), clutter=(), distance=(0.47074999999999995, 1.883),
              max_tilt_deg=39.63215730991628, noise_sigma=2.5856295754541545, blur_sigma=1.4175043523622857,
              contrast=0.8315918170895461, vignetting=0.11165394762068544, margin=0.15, rng=88678055),
    1000: dict(occluders=("blob", "bar"), clutter=(), distance=(0.47074999999999995, 1.883),
               max_tilt_deg=30.55190445363487, noise_sigma=2.606784532633237, blur_sigma=2.0814156455667874,
               contrast=0.6574591305023354, vignetting=0.0575423605065283, margin=1.0, rng=591344365),
}


@pytest.mark.parametrize("case", sorted(BAR_ALONG_A_LINE))
def test_a_bar_along_a_line_of_junctions_with_the_board_showing_beside_it_is_no_edge(case):
    board = Board(7, 7, 0.04) if case == 618 else Board(7, 5, 0.04)
    verdict = run_case(_scene_case("junctions", board, **BAR_ALONG_A_LINE[case]))
    assert verdict["verdict"] in ("refused", "right"), verdict


def test_a_small_board_whose_tilt_the_view_cannot_tell_gives_no_ok_pose():
    """Seed 0's case 733 (before: an ok pose 95 sigma off, 67 degrees from the truth): 8 junctions
    of 13 px squares beside a specular highlight, whose pose with the board tilted the other way
    fits them within 6 chi-square of the one found."""
    case = _scene_case("pose", Board(7, 5, 0.04), occluders=("reflection",), clutter=("grid",),
                       distance=(0.47074999999999995, 1.883), max_tilt_deg=28.048378727529467,
                       noise_sigma=6.014931015870369, blur_sigma=2.1408378491447544, contrast=0.6848463265604608,
                       vignetting=0.09221099023459009, margin=1.0, rng=1546405853)
    verdict = run_case(case)
    assert verdict["verdict"] in ("refused", "right"), verdict
    assert verdict["verdict"] == "right" or "tilt is ambiguous" in verdict["message"]


def _bounded_case(board, bounds, polygon, roll, **scene):
    """:func:`_scene_case` with the polygon the fuzz drew for it (``bounds`` (2, 4), rolled by ``roll``)."""
    from dataclasses import replace

    return replace(_scene_case("junctions", board, **scene), bounds=np.array(bounds), polygon=polygon, roll=roll)


#: Seed 0's cases 729 and 953 of the benchmark's fuzz: the board, the polygon the fuzz drew (its
#: kind and roll) and ``random_scene``'s arguments.
BESIDE_A_HIGHLIGHT = {
    729: (Board(5, 4, 0.05), [[459.843456156621, 564.0813906099794, 579.3846829321997, 464.2364674789331],
                              [143.77701066615205, 112.19361782695803, 219.5909675788847, 237.1205578909672]],
          "inset", 0, dict(distance=(0.4576736111111111, 2.3537500000000002), max_tilt_deg=47.093264001586796,
                           noise_sigma=5.7288690886803595, blur_sigma=1.4116146898485624,
                           contrast=0.8485797078456532, vignetting=0.5483860020326429, margin=0.5, rng=110059778)),
    953: (Board(6, 6, 0.04), [[377.8776469856744, 420.6463525421076, 575.0174518877541, 534.7620462497747],
                              [268.6662558731084, 113.51517186607374, 158.57376704045174, 315.4428269911403]],
          "rolled", 1, dict(distance=(0.41844444444444445, 1.883), max_tilt_deg=22.892095723367134,
                            noise_sigma=6.296206009527402, blur_sigma=1.7496994308015181,
                            contrast=0.5642051413704261, vignetting=0.23878682244043886, margin=0.15, rng=1867856688)),
}


@pytest.mark.slow  # about 2 s a case: two renders through the detector
@pytest.mark.parametrize("case", sorted(BESIDE_A_HIGHLIGHT))
def test_a_part_of_a_board_beside_a_highlight_is_refused_or_right(case):
    """Seed 0's cases 729 and 953 of the benchmark's fuzz. 729 (before: a corner junction of an
    11-junction part trusted 1.14 px off, its residual 0.53 px under the gate): judged against
    the grid the other junctions draw. 953 (before: a 3 x 3 part labelled as the board's corner,
    three lines off, the highlight beside it taken for the margin): the rolled bounds put the
    board three squares away, and the part's labels are refused."""
    board, bounds, polygon, roll, scene = BESIDE_A_HIGHLIGHT[case]
    verdict = run_case(_bounded_case(board, bounds, polygon, roll, occluders=("reflection", "bar"),
                                     clutter=("text",), **scene))
    assert verdict["verdict"] in ("refused", "right"), verdict

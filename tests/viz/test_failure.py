"""graphpose.viz.failure: the picture of an image without a pose (what the search saw, and why
it gave up)."""

import numpy as np
import pytest

from graphpose import Board
from graphpose.synth.poses import random_pose
from graphpose.synth.render import render
from graphpose.viz.failure import CANDIDATE, FailureEvidence, _wrap, draw_failure, failure_evidence
from graphpose.viz.overlay import COLOURS
from tests.conftest import PROJECT_K as K


def _rendered(seed=0):
    board = Board()
    T = random_pose(K, board=board, size=(640, 480), rng=seed)
    return render(K, T, board=board, size=(640, 480), noise_sigma=1.0, rng=seed)


def test_the_failure_picture_rings_at_least_the_junctions_its_reason_counts():
    from graphpose import Board, read_image
    from graphpose.detect.junctions import extract_junctions
    from graphpose.errors import BoardNotFoundError
    from graphpose.viz.failure import failure_evidence
    from tests.conftest import opencv_file

    image = read_image(opencv_file("left01.jpg"), as_float=False)
    with pytest.raises(BoardNotFoundError) as refused:
        extract_junctions(image, board=Board(10, 7, 0.025))
    seen = refused.value.junctions_seen
    assert seen == 54  # the 9 x 6 board it names
    assert failure_evidence(image, None, Board(10, 7, 0.025), seen).lattice.shape[1] >= seen


def test_the_evidence_on_a_board_of_another_size_is_its_junctions():
    R = _rendered()
    found = failure_evidence(R.image, board=Board(10, 7, 0.025))
    assert isinstance(found, FailureEvidence)
    assert 0 < found.candidates.shape[1] <= 400 and found.candidates.shape[0] == 2
    # The lattice grown is the rendered 8 x 6 board's: each node within 1 px of a true junction
    # (1 px: the search's candidates are pixel-level, before any refinement).
    assert found.lattice.shape[1] == R.junctions.shape[1]
    gaps = np.min(np.hypot(*(found.lattice[:, :, None] - R.junctions[:, None, :])), axis=1)
    assert gaps.max() < 1.0


def test_a_blank_image_gives_no_lattice():
    found = failure_evidence(np.full((240, 320), 128, dtype=np.uint8))
    assert found.lattice.shape == (2, 0)


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_the_failure_picture_draws_the_evidence_and_the_reason():
    R = _rendered()
    image = R.image.copy()
    found = failure_evidence(image, board=Board(10, 7, 0.025))
    picture = draw_failure(image, "the board is 8 x 6; the spec says 10 x 7", found=found, label="left01")
    np.testing.assert_array_equal(image, R.image)  # the input is left as it was
    assert picture.shape == (480, 640, 3) and picture.dtype == np.uint8
    colours = {tuple(c) for c in picture.reshape(-1, 3)}
    assert CANDIDATE in colours and COLOURS["trusted"] in colours
    # Away from the marks and the box, the image is dimmed into 40..210.
    plain = picture[300:, :150][np.all(picture[300:, :150] == picture[300:, :150, :1], axis=2)]
    assert plain.size and plain.min() >= 40 and plain.max() <= 210


def test_the_failure_picture_finds_its_evidence_when_not_given_it():
    R = _rendered(1)
    given = draw_failure(R.image, "no board", found=failure_evidence(R.image, board=Board(10, 7, 0.025)),
                         board=Board(10, 7, 0.025))
    np.testing.assert_array_equal(draw_failure(R.image, "no board", board=Board(10, 7, 0.025)), given)


@pytest.mark.parametrize("text, width, lines", [
    ("a; b", 20, ["a, b"]),
    ("one two three four", 9, ["one two", "three", "four"]),
    ("   ", 10, [""]),
])
def test_the_reason_is_wrapped_at_spaces_without_semicolons(text, width, lines):
    assert _wrap(text, width) == lines

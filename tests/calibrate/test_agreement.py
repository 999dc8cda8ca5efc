"""A calibration refuses a board spec its images contradict: exit 1, what was found named, no file."""

import subprocess
import sys

import pytest

from graphpose import Board, BoardMismatchError
from graphpose.calibrate.agreement import check_agreement
from tests.conftest import OPENCV_DIR, opencv_file

LABELS = [f"view{k:02d}.png" for k in range(10)]


def _other(size_px=300.0):
    return BoardMismatchError("found a 9 x 6 board", found=(9, 6), size_px=size_px, junctions_seen=54)


def test_views_that_all_agree_pass():
    check_agreement(Board(9, 6, 0.025), LABELS, {k: 300.0 for k in range(10)}, {})


def test_a_board_in_fewer_than_half_the_views_beside_another_board_is_refused():
    with pytest.raises(BoardMismatchError) as exc:
        check_agreement(Board(8, 6, 0.025), LABELS, {0: 300.0, 1: 310.0, 2: 290.0, 3: 300.0},
                        {k: _other() for k in range(4, 7)})
    message = str(exc.value)
    assert "3 of 10 show a 9 x 6 board" in message and "view04.png" in message and "found in 4" in message
    assert exc.value.found == (9, 6)


def test_boards_far_smaller_than_the_other_views_board_are_refused():
    found = {k: 60.0 for k in range(7)}  # seven small pictures of a board ...
    with pytest.raises(BoardMismatchError, match="too small to be the board photographed"):
        check_agreement(Board(8, 6, 0.025), LABELS, found, {7: _other(), 8: _other()})  # ... beside 9 x 6 boards
    check_agreement(Board(8, 6, 0.025), LABELS, {k: 200.0 for k in range(7)}, {7: _other(), 8: _other()})


@pytest.mark.slow  # searches every OpenCV sample through the CLI
def test_the_wrong_spec_on_opencvs_samples_exits_1_and_writes_no_file(tmp_path):
    opencv_file("left01.jpg")
    out = tmp_path / "x.json"
    run = subprocess.run([sys.executable, "-m", "graphpose", "calibrate", *sorted(map(str, OPENCV_DIR.glob("left*.jpg"))),
                          "--board", "8x6x0.025", "--out", str(out)], capture_output=True, text=True)
    assert run.returncode == 1, run.stdout + run.stderr
    assert "13 of 13 show a 9 x 6 board" in run.stderr and "8 x 6" in run.stderr
    assert not out.exists()

"""graphpose.io.corners: junctions out and in (mrcal's corners.vnl, graphpose's JSON)."""

import numpy as np
import pytest

from graphpose import Board, InputError
from graphpose.io.corners import read_corners, write_corners


#: A hand-written corners.vnl of a 3 x 2 board in mrcal's documented layout: one line per
#: junction in the board's order, '-' for a junction not seen, one '- - -' line for an image
#: without a board.
EXAMPLE = """# filename x y level
a.png 10.5 20.25 0
a.png 30.5 20.0 0
a.png 50.0 20.0 0
a.png 10.0 40.0 0
a.png 30.0 40.0 0
a.png 50.0 40.0 0
b.png - - -
c.png 11.0 21.0 0
c.png - - -
c.png 51.0 21.0 0
c.png 11.0 41.0 0
c.png 31.0 41.0 0
c.png 51.0 41.0 0
"""


def test_written_vnl_is_the_hand_written_example(tmp_path):
    board = Board(3, 2, 0.02)
    junctions = [(np.array([[10.5, 30.5, 50.0, 10.0, 30.0, 50.0], [20.25, 20.0, 20.0, 40.0, 40.0, 40.0]]), np.arange(6)),
                 None,
                 (np.array([[11.0, 51.0, 11.0, 31.0, 51.0], [21.0, 21.0, 41.0, 41.0, 41.0]]), np.array([0, 2, 3, 4, 5]))]
    path = tmp_path / "corners.vnl"
    write_corners(path, ["a.png", "b.png", "c.png"], junctions, board)
    assert path.read_text() == EXAMPLE
    back = read_corners(path, board)
    assert back.images == ("a.png", "b.png", "c.png") and back.junctions[1] is None
    for (uv, index), (uv2, index2) in zip([junctions[0], junctions[2]], [back.junctions[0], back.junctions[2]]):
        np.testing.assert_array_equal(uv, uv2)
        np.testing.assert_array_equal(index, index2)
    js = tmp_path / "corners.json"
    write_corners(js, ["a.png", "b.png", "c.png"], junctions, board, size=(64, 48))
    again = read_corners(js, board)
    assert again.size == (64, 48) and again.junctions[1] is None
    np.testing.assert_array_equal(again.junctions[2][1], [0, 2, 3, 4, 5])


def test_bad_corners_files(tmp_path):
    board = Board(3, 2, 0.02)
    bad = tmp_path / "bad.vnl"
    bad.write_text("a.png 1 2 0\n")
    with pytest.raises(InputError, match="header"):
        read_corners(bad, board)
    bad.write_text("# filename x y level\na.png 1 2 0\na.png 3 4 0\n")
    with pytest.raises(InputError, match="2 junction lines"):
        read_corners(bad, board)
    with pytest.raises(InputError, match="board is 3 x 2"):
        write_corners(tmp_path / "c.json", ["a"], [None], board)
        read_corners(tmp_path / "c.json", Board(9, 6, 0.03))
    with pytest.raises(InputError, match=".vnl"):
        write_corners(tmp_path / "c.txt", ["a"], [None], board)
    with pytest.raises(InputError, match="not found"):
        read_corners(tmp_path / "none.vnl", board)

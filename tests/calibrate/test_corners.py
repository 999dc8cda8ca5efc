"""Junctions out and in (graphpose.io.corners: mrcal's corners.vnl, graphpose's JSON),
calibrating from them (graphpose.calibrate.calibrate_corners), and single outliers."""

import numpy as np
import pytest

import graphpose
from graphpose import Board, InputError
from graphpose.calibrate import calibrate_corners
from graphpose.io.corners import read_corners, write_corners
from graphpose.synth.calibration import calibration_set, radtan_camera

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


@pytest.fixture(scope="module")
def calibrated():
    views = calibration_set(radtan_camera(), 10, rng=3)
    return views, graphpose.calibrate(views.images, model="radtan", names=[f"v{i}.png" for i in range(10)])


@pytest.mark.slow  # two whole calibrations of OpenCV's samples
def test_the_same_camera_from_the_written_corners(calibrated, tmp_path):
    views, c = calibrated
    path = tmp_path / "corners.vnl"
    write_corners(path, c.images, c.detections, Board(), size=c.camera.size)
    again = calibrate_corners(read_corners(path, Board()), "radtan", board=Board(), size=c.camera.size)
    assert again.ok and again.status == c.status
    assert all(m.startswith("junctions read from the corners") for m in again.message)
    # The same junctions: the same camera, to a hundredth of its sigmas (the Huber threshold
    # comes from a median of residuals reached by another path: Zhang's start, not the passes').
    assert np.all(np.abs(again.parameters - c.parameters) < 0.01 * c.sigmas)
    np.testing.assert_allclose(again.sigmas, c.sigmas, rtol=0.02)
    with pytest.raises(InputError, match="size"):
        calibrate_corners(read_corners(path, Board()), "radtan", board=Board())


def test_single_outliers_are_left_out_and_named(calibrated):
    views, c = calibrated
    rng = np.random.default_rng(0)
    moved, junctions = [], []
    for k, (uv, index) in enumerate(c.detections):
        uv = uv.copy()
        pick = rng.choice(index.size, size=max(1, round(0.02 * index.size)), replace=False)
        angle = rng.uniform(0, 2 * np.pi, pick.size)
        uv[:, pick] += rng.uniform(2.0, 5.0, pick.size) * np.stack([np.cos(angle), np.sin(angle)])
        moved.append(set(index[pick].tolist()))
        junctions.append((uv, index))
    bad = calibrate_corners(junctions, "radtan", board=Board(), size=c.camera.size)
    assert bad.ok and bad.status.count("used") == 10
    for k in range(10):
        assert set(bad.outliers[k].tolist()) == moved[k]
        assert f"{len(moved[k])} junction" in bad.message[k]
    truth = views.camera
    w, h = truth.size
    u, v = np.meshgrid(np.arange(0, w, 40.0), np.arange(0, h, 40.0))
    q = np.stack([u.ravel(), v.ravel()])
    err = lambda cam: np.sqrt(np.mean(np.sum((cam.project(truth.unproject(q)) - q) ** 2, axis=0)))
    assert err(bad.camera) < 1.2 * err(c.camera) + 0.002
    z = (bad.parameters - truth.parameters) / bad.sigmas
    assert np.all(np.abs(z) < 3.0), z

"""OpenCV's raw calibration samples (9 x 6 junctions, two cameras of a stereo rig), found
without a polygon: every image, every junction, and junction 0 on the same physical
corner of the board in every image.

The last is checked through the rig: the right camera's pose in the left camera's frame,
``inv(T_WC_left) T_WC_right``, is one fixed transform for every pair taken together. A pair
whose board was labelled from another corner in one of its two images would give a
transform turned by a half turn about the board's normal.
"""

import numpy as np
import pytest

from graphpose import Board, estimate_pose, extract_junctions, read_image
from graphpose.io.cameras import read_camera
from graphpose.estimate import pose_difference
from tests.conftest import OPENCV_DIR as FOLDER

BOARD = Board(9, 6, 0.03)
PAIRS = [1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14]


@pytest.fixture(scope="module")
def cameras():
    if not (FOLDER / "left.opencv.yml").is_file():
        pytest.skip(f"{FOLDER} is absent")
    return read_camera(FOLDER / "left.opencv.yml"), read_camera(FOLDER / "right.opencv.xml")


@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("side", ["left", "right"])
def test_every_sample_is_found_whole_without_a_polygon(cameras, side):
    camera = cameras[0] if side == "left" else cameras[1]
    for k in PAIRS:
        J = extract_junctions(read_image(FOLDER / f"{side}{k:02d}.jpg"), bounds=None, board=BOARD, camera=camera)
        assert J.trusted.all() and J.seen.all(), (side, k)
        assert not J.orientation_ambiguous  # 10 x 7 squares: the colours fix junction 0
        # ... by the convention: junction 0's outer corner square is dark. Sampled a fifth of
        # a square beyond junction 0 along both grid directions, reversed (this board's
        # outer squares are cut to about half their width).
        image = read_image(FOLDER / f"{side}{k:02d}.jpg")
        p0, p1, p9 = J.points[:, 0], J.points[:, 1], J.points[:, BOARD.cols]
        corner = p0 - 0.2 * (p1 - p0) - 0.2 * (p9 - p0)
        light = J.points[:, [1, 2, BOARD.cols + 1, BOARD.cols + 2]].mean(axis=1)  # square (1, 0)
        u, v = np.rint(np.column_stack([corner, light])).astype(int)
        assert image[v[0], u[0]] < image[v[1], u[1]] - 0.3, (side, k)


@pytest.mark.slow  # 0.6 s or so on two idle cores: a render, a calibration or a subprocess
def test_junction_0_is_the_same_physical_corner_in_every_image(cameras):
    left, right = cameras
    rig = []
    for k in PAIRS:
        a = estimate_pose(read_image(FOLDER / f"left{k:02d}.jpg"), left, bounds=None, board=BOARD)
        b = estimate_pose(read_image(FOLDER / f"right{k:02d}.jpg"), right, bounds=None, board=BOARD)
        assert a.ok and b.ok, k
        rig.append(np.linalg.inv(a.T_WC) @ b.T_WC)
    # Bouguet's rig: a baseline of about 100 mm. One mislabelled image would turn its
    # pair's transform by 180 degrees; the published calibration's own spread is a few
    # tenths of a degree and a few millimetres.
    median = rig[int(np.argsort([np.linalg.norm(T[:3, 3]) for T in rig])[len(rig) // 2])]
    for k, T in zip(PAIRS, rig):
        metres, degrees = pose_difference(median, T)
        assert metres < 0.005 and degrees < 1.0, (k, metres, degrees)
    assert 0.09 < np.linalg.norm(median[:3, 3]) < 0.11

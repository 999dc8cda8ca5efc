"""DegenerateGeometryError: valid input whose geometry has no answer is a failed result (exit 1),
raised where the homography gives no pose and caught as that type where a view may fail."""

import numpy as np
import pytest

from graphpose import DegenerateGeometryError, GraphposeError, InputError, T_from_params
from graphpose.camera_models import RadTanCamera
from graphpose.cli import EXIT_FAILED, exit_code, main
from graphpose.geometry import homography_dlt, project
from graphpose.estimate import estimate_pose_from_points
from graphpose.pose.homography import pose_from_homography
from tests.conftest import BOARD_WPTS as W
from tests.conftest import PROJECT_K as K
from tests.conftest import REPO

T = T_from_params([0.2, 0.1, -0.9, 0.1, -0.1, 0.2])


def test_it_is_a_failed_result_not_bad_input():
    exc = DegenerateGeometryError("no pose")
    assert isinstance(exc, GraphposeError) and not isinstance(exc, InputError)
    assert exit_code(exc) == EXIT_FAILED == 1


def test_points_that_fix_no_homography():
    row = W[:2, :8]  # one row of the board: collinear
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        homography_dlt(row, row + 1.0)
    with pytest.raises(DegenerateGeometryError, match="coincide"):
        homography_dlt(np.ones((2, 6)), W[:2, :6])
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        pose_from_homography(project(K, T, W[:, :8]), W[:, :8], K)


def test_no_pose_in_front_of_the_camera():
    # The board cut by the camera's plane z = 0: the nearer half in front, the rest behind,
    # imaged through the centre (a finite pixel for every point), so no sign of the
    # homography's pose puts every point in front.
    T_cut = T_from_params([0.2, 0.1, -0.05, 0.0, np.radians(80.0), 0.0])
    P = (T_cut[:3, :3].T @ (W - T_cut[:3, 3:]))
    assert np.any(P[2] > 0) and np.any(P[2] < 0)
    uv = (K @ (P / P[2]))[:2]
    with pytest.raises(DegenerateGeometryError, match="in front of the camera"):
        pose_from_homography(uv, W, K)
    # The same through the public pose estimate (no guess, so the homography start).
    with pytest.raises(DegenerateGeometryError, match="in front of the camera"):
        estimate_pose_from_points(uv, W, K)


def test_a_pixel_where_the_lens_has_no_ray():
    camera = RadTanCamera(K, [-0.9, 0.0, 0.0, 0.0])  # folds back about r = 0.6
    uv = camera.project(T[:3, :3].T @ (W - T[:3, 3:]))
    uv[:, 0] = [K[0, 2] + 3.0 * K[0, 0], K[1, 2]]  # beyond the fold: no ray reaches it
    assert np.isnan(camera.undistort_pixels(uv[:, :1])).all()
    with pytest.raises(DegenerateGeometryError, match="no ray in front"):
        pose_from_homography(uv, W, camera)


def test_the_command_line_exits_1_on_it(monkeypatch, capsys):
    def degenerate(*args, **kwargs):
        raise DegenerateGeometryError("no pose from the homography puts every target point in front of the camera")

    monkeypatch.setattr("graphpose.cli.estimate.estimate_pose", degenerate)
    assert main(["estimate", "--cases", str(REPO / "graphpose" / "data" / "cases.json")]) == 1
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines and all(line.startswith("graphpose") and "in front of the camera" in line for line in lines), lines


def test_the_tracker_loses_the_frame_not_the_sequence(track_clip, monkeypatch):
    from graphpose import track_sequence
    from graphpose.track.results import LOST

    def degenerate(*args, **kwargs):
        raise DegenerateGeometryError("degenerate")

    # The homography start of every single-image fit (detection has its own homography).
    monkeypatch.setattr("graphpose.pose.homography.homography_dlt", degenerate)
    track = track_sequence(track_clip.images[:2], K, bounds=track_clip.bounds)
    assert list(track.status) == [LOST, LOST]
    assert all("pose fit failed: degenerate" in f.message for f in track.frames)

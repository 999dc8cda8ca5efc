"""calibrate_rig on a rendered rig with truth, and its bad-input errors (the matching of frames:
tests/calibrate/test_frames.py)."""

import numpy as np
import pytest

from graphpose import Board, InputError
from graphpose.geometry import T_from_params, params_from_T
from graphpose.rig import Rig
from graphpose.synth.calibration import radtan_camera

BOARD = Board(9, 6, 0.06)


def _rig():
    from graphpose import RadTanCamera

    second = RadTanCamera([[545.0, 0.0, 318.0], [0.0, 543.5, 244.0], [0.0, 0.0, 1.0]],
                          [-0.28, 0.09, -0.0004, 0.0007, -0.01], size=(640, 480))
    return Rig([radtan_camera(), second], [np.eye(4), T_from_params([0.12, 0.002, -0.003, 0.01, -0.03, 0.005])])


@pytest.fixture(scope="module")
def rendered():
    from graphpose.synth.rig import rig_views

    return rig_views(_rig(), 10, rng=29, board=BOARD)


@pytest.fixture(scope="module")
def calibrated(rendered):
    # About 5 s: ten views of two cameras rendered, then each camera calibrated and the rig.
    from graphpose import calibrate_rig

    return calibrate_rig(frames=rendered.images, board=BOARD)


@pytest.mark.slow  # whole rig calibrations of rendered views
def test_extrinsics_within_three_sigmas_of_the_truth(calibrated, rendered):
    assert calibrated.ok, calibrated.summary
    s = calibrated.parameter_names.index("cam1.x")
    e = params_from_T(calibrated.T_C0_C[1]) - params_from_T(rendered.rig.T_C0_C[1])
    sigma = np.sqrt(np.diag(calibrated.cov)[s: s + 6])
    assert np.all(np.abs(e) <= 3 * sigma), (e, sigma)
    assert np.allclose(calibrated.T_C0_C[0], np.eye(4))
    assert calibrated.parameter_names[-6:] == ("cam1.x", "cam1.y", "cam1.z", "cam1.roll", "cam1.pitch", "cam1.yaw")


@pytest.mark.slow  # 2.3 s or so on two idle cores: a render, a calibration or a subprocess
def test_the_two_solvers_land_on_the_same_parameters(calibrated):
    check = calibrated.cross_check
    assert check.max_difference <= check.tolerance == 1e-6
    assert np.allclose(check.gtsam, check.lm, rtol=1e-6, atol=1e-9)


@pytest.mark.slow  # 1.9 s or so on two idle cores: a render, a calibration or a subprocess
def test_views_one_camera_sees_count_and_blanks_are_named(calibrated, rendered):
    status = np.array(calibrated.status)
    for v, row in enumerate(rendered.seen):
        for c, seen in enumerate(row):
            assert (status[v, c] == "used") == seen, (v, c, status[v, c])
    solo = [v for v, row in enumerate(rendered.seen) if row.sum() == 1]
    assert solo and all(calibrated.poses[v] is not None for v in solo)
    assert calibrated.message[solo[0]][1 - int(np.argmax(rendered.seen[solo[0]]))]  # why no board
    assert np.all(np.isnan(calibrated.view_rms_px[~rendered.seen]))
    assert np.all(calibrated.camera_rms_px < 0.1)


def test_each_camera_carries_its_block_of_the_joint_covariance(calibrated):
    n = len(calibrated.cameras[0].parameter_names)
    assert np.allclose(calibrated.cameras[0].covariance, calibrated.cov[:n, :n])
    assert np.allclose(calibrated.rig.cov, calibrated.cov)
    (e,) = calibrated.extrinsics()
    assert e["baseline_m"] == pytest.approx(np.linalg.norm(calibrated.T_C0_C[1][:3, 3]))
    assert 0 < e["baseline_sigma_m"] < 1e-3 and 0 < e["rotation_sigma_deg"] < 0.1


@pytest.mark.slow  # a rig calibration of rendered views
def test_no_view_seen_by_two_cameras_together_is_an_error(rendered):
    from graphpose import calibrate_rig

    blank = np.full((480, 640), 128, np.uint8)
    frames = [(im[0], blank) for im in rendered.images[:4]] + [(blank, im[1]) for im in rendered.images[:8]
                                                               if im is not None]
    with pytest.raises(InputError, match="the extrinsics are unconstrained"):
        calibrate_rig(frames=frames, board=BOARD)


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_images_of_different_sizes_within_a_camera_are_an_error(rendered):
    from graphpose import calibrate_rig

    frames = [tuple(v) for v in rendered.images]
    frames[2] = (frames[2][0], frames[2][1][:400])
    with pytest.raises(InputError, match=r"camera 1: the images differ in size"):
        calibrate_rig(frames=frames, board=BOARD)


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
def test_a_camera_with_fewer_than_three_views_is_an_error(rendered):
    from graphpose import calibrate_rig

    frames = [(v[0], v[1] if k < 2 else None) for k, v in enumerate(rendered.images)]
    with pytest.raises(InputError, match="camera 1 has 2 images; a camera of a rig needs at least 3"):
        calibrate_rig(frames=frames, board=BOARD)


def test_sources_by_glob_match_opencv_pairs(tmp_path):
    from graphpose.calibrate.rig import _views
    from tests.conftest import OPENCV_DIR, opencv_file

    opencv_file("left01.jpg")
    views, names = _views([str(OPENCV_DIR / "left*.jpg"), OPENCV_DIR / "right01.jpg"], None)
    assert names[0] == "01" and views[0][1][1] == "right01.jpg" and views[1][1] is None
    with pytest.raises(InputError, match="one source per camera"):
        _views([str(OPENCV_DIR / "left*.jpg")], None)

"""graphpose.pipeline_rig: estimate_rig_pose on rendered rig frames: against the truth, GN
against GTSAM, a blank camera, bad input."""

import numpy as np
import pytest

from graphpose import Board, BoardNotFoundError, InputError
from graphpose.geometry import T_from_params, pose_difference
from graphpose.pipeline_rig import estimate_rig_pose
from graphpose.rig import Rig
from graphpose.synth.calibration import radtan_camera

BOARD = Board(9, 6, 0.06)


@pytest.fixture(scope="module")
def frames():
    from graphpose.synth.rig import rig_views

    rig = Rig([radtan_camera(), radtan_camera()], [np.eye(4), T_from_params([0.1, 0.0, 0.0, 0.0, -0.02, 0.0])])
    views = rig_views(rig, 6, rng=7, board=BOARD, solo_every=0)
    both = [k for k in range(6) if views.seen[k].all()]
    assert len(both) >= 2
    return rig, views, both


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_the_rig_pose_is_near_the_truth_and_the_solvers_agree(frames):
    rig, views, both = frames
    for k in both[:2]:
        est = estimate_rig_pose(views.images[k], rig, board=BOARD)
        assert est.ok, est.message
        dt, dr = pose_difference(est.T_WC, views.poses[k])
        assert dt < 1e-3 and dr < 0.05
        assert est.cross_check.translation_m < 1e-6 and est.status == ("used", "used")
        # The error is within what the covariance allows (a loose chi-square bound, 6 dof).
        from graphpose.geometry import params_from_T

        e = est.params - params_from_T(views.poses[k])
        assert e @ np.linalg.solve(est.cov, e) < 30.0


def test_a_blank_camera_still_gives_a_pose(frames):
    rig, views, both = frames
    k = both[0]
    blank = np.full_like(views.images[k][0], 128)
    est = estimate_rig_pose([blank, views.images[k][1]], rig, board=BOARD)
    assert est.ok and est.status == ("no board", "used") and est.messages[0]
    assert pose_difference(est.T_WC, views.poses[k])[0] < 2e-3
    est = estimate_rig_pose([views.images[k][0], None], rig, board=BOARD, robust=True)
    assert est.ok and est.status == ("used", "no board")
    with pytest.raises(BoardNotFoundError, match="no camera of the rig sees the board"):
        estimate_rig_pose([blank, None], rig, board=BOARD)


def test_bad_input(frames):
    rig, views, _ = frames
    with pytest.raises(InputError, match="one image per camera of the rig: 2 cameras, 1 images"):
        estimate_rig_pose(views.images[0][:1], rig, board=BOARD)
    with pytest.raises(InputError, match="rig must be a graphpose Rig"):
        estimate_rig_pose(views.images[0], rig.cameras[0], board=BOARD)
    with pytest.raises(InputError, match="calibrated for 640 x 480"):
        estimate_rig_pose([views.images[0][0][:400], views.images[0][1]], rig, board=BOARD)

"""graphpose.track.isam: the online back ends' iSAM2 settings and the extra updates of a new pose."""

import re

import gtsam
import numpy as np
import pytest
from gtsam.symbol_shorthand import L, X

from graphpose.board import Board
from graphpose.geometry import T_from_params
from graphpose.track.isam import (
    RELINEARIZE_STEPS,
    RELINEARIZE_THRESHOLD,
    default_isam_params,
    fixed_lag_isam_params,
    refine_pose,
)


def _printed(params) -> dict:
    """GTSAM's own printout of ISAM2Params (its threshold has no getter), as {name: value}."""
    return dict(re.findall(r"^(\w+):\s+(\S+)$", str(params), flags=re.M))


def test_the_whole_sequence_and_fixed_lag_settings():
    whole, lag = _printed(default_isam_params()), _printed(fixed_lag_isam_params())
    assert float(whole["relinearizeThreshold"]) == RELINEARIZE_THRESHOLD
    assert (whole["relinearizeSkip"], whole["enablePartialRelinearizationCheck"], whole["findUnusedFactorSlots"]) \
        == ("1", "1", "0")
    # The fixed lag: the same, but marginalised factors' slots reused and every clique checked.
    assert (lag["enablePartialRelinearizationCheck"], lag["findUnusedFactorSlots"]) == ("0", "1")
    differ = {k for k in whole if whole[k] != lag[k]}
    assert differ == {"enablePartialRelinearizationCheck", "findUnusedFactorSlots"}


class _Steps:
    """A stand-in iSAM2: each update moves the pose to the next of ``poses``."""

    def __init__(self, poses):
        self.poses, self.updates = [gtsam.Pose3(P) for P in poses], 0

    def update(self):
        self.updates += 1

    def pose(self):
        return self.poses[min(self.updates, len(self.poses) - 1)]


@pytest.mark.parametrize("moves, updates", [
    ([0.0], 0),                      # the first update left the pose at its start: done
    ([0.1, 0.1 + 1e-6], 1),          # one more update, then it moves by less than the threshold
    ([0.1, 0.2, 0.2 + 5e-5], 2),
    ([3e-4], 0),                     # a move below REFINE_THRESHOLD (iSAM2's own threshold is lower): done
    ([7e-4, 7e-4 + 1e-6], 1),        # above it: one more update
    ([0.1, 0.2, 0.3, 0.4, 0.5], RELINEARIZE_STEPS),  # never settles: at most RELINEARIZE_STEPS
])
def test_refine_pose_updates_while_the_pose_moves_by_more_than_the_threshold(moves, updates):
    start = T_from_params([0.0, 0.0, -1.0, 0.0, 0.0, 0.0])
    steps = _Steps([T_from_params([x, 0.0, -1.0, 0.0, 0.0, 0.0]) for x in moves])
    pose = refine_pose(steps.update, steps.pose, start)
    assert steps.updates == updates
    np.testing.assert_allclose(pose.matrix(), steps.pose().matrix(), atol=0)


def test_refine_pose_brings_a_poor_start_onto_a_real_isam2_optimum():
    # A resection (the board's junctions seen by a camera, the landmarks pinned), started 0.25 rad
    # and 0.2 m off: one iSAM2 update is one Gauss-Newton step, which leaves the pose visibly off;
    # refine_pose's extra updates finish the job.
    truth = T_from_params([0.1, -0.05, -1.0, 0.05, -0.1, 0.2])
    start = T_from_params([0.3, 0.05, -1.1, 0.2, 0.05, 0.0])
    K = gtsam.Cal3_S2(565.0, 565.0, 0.0, 320.0, 240.0)
    W = Board().world_points()
    camera = gtsam.PinholeCameraCal3_S2(gtsam.Pose3(truth), K)
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    pixel, pin = gtsam.noiseModel.Isotropic.Sigma(2, 0.5), gtsam.noiseModel.Isotropic.Sigma(3, 1e-6)
    for j, P in enumerate(W.T):
        graph.add(gtsam.GenericProjectionFactorCal3_S2(camera.project(P), pixel, X(0), L(j), K))
        graph.add(gtsam.PriorFactorPoint3(L(j), P, pin))
        values.insert(L(j), P)
    values.insert(X(0), gtsam.Pose3(start))
    isam = gtsam.ISAM2(default_isam_params())
    isam.update(graph, values)
    once = isam.calculateEstimate().atPose3(X(0))
    assert np.abs(gtsam.Pose3.Logmap(once.between(gtsam.Pose3(truth)))).max() > 1e-3
    pose = refine_pose(isam.update, lambda: isam.calculateEstimate().atPose3(X(0)), start)
    np.testing.assert_allclose(pose.matrix(), truth, atol=1e-6)

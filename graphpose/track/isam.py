"""How the online back ends (:mod:`graphpose.track.backend`) drive iSAM2: its settings for the
whole sequence and for the fixed lag, and the extra updates a new pose may need
(:func:`refine_pose`)."""

from __future__ import annotations

import gtsam
import numpy as np

#: iSAM2 relinearises a variable whose step exceeds this (rad, m): the estimate's error is
#: of the order of its square.
RELINEARIZE_THRESHOLD = 1e-4
#: Extra iSAM2 updates allowed when a new pose's step is still large (a poor start).
RELINEARIZE_STEPS = 3
#: A new pose that moved more than this from its start (the front end's fit) in its first
#: update gets another (rad, m). The update's one Gauss-Newton step from that start leaves an
#: error of the order of the move's square times the projection's curvature: at 5e-4 (about
#: 0.1 px at the board), far below the pixel noise; the poses of the tracking benchmark's
#: sequences are those of 1e-4 within their noise, and a median frame takes one update
#: instead of two (at 1e-4, most frames took the second).
REFINE_THRESHOLD = 5e-4


def default_isam_params() -> gtsam.ISAM2Params:
    """The whole-sequence back end's iSAM2 settings: relinearise above
    :data:`RELINEARIZE_THRESHOLD` at every update, checking only the cliques near the newest
    frames."""
    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(RELINEARIZE_THRESHOLD)
    params.relinearizeSkip = 1
    params.enablePartialRelinearizationCheck = True
    return params


def fixed_lag_isam_params() -> gtsam.ISAM2Params:
    """The fixed-lag smoother's iSAM2 settings: those of :func:`default_isam_params`, the
    slots of marginalised factors reused (else iSAM2's factor list keeps growing with empty
    slots), and every clique checked for relinearisation.

    The smoother orders each update itself (the keys to marginalise first, then the rest in
    COLAMD's order), so the new pose need not be at the root of the Bayes tree. The partial
    check walks down from the root and stops at a clique whose step is small: it then left
    new poses up to 80 um off the filtered optimum (a 240-frame test), where the full check
    leaves 0.5 um. Over a window of a couple of seconds the full check is cheap.
    """
    params = default_isam_params()
    params.findUnusedFactorSlots = True
    params.enablePartialRelinearizationCheck = False
    return params


def refine_pose(update, pose_of, T_WC_init) -> gtsam.Pose3:
    """A few more iSAM2 updates while the new pose still moves by more than
    :data:`REFINE_THRESHOLD`: one update is one Gauss-Newton step, and a poor start
    needs more. (Poses are compared: the delta of every variable would cost more.)"""
    linear, pose = gtsam.Pose3(np.asarray(T_WC_init, dtype=float)), pose_of()
    for _ in range(RELINEARIZE_STEPS):
        if np.max(np.abs(gtsam.Pose3.Logmap(linear.between(pose)))) < REFINE_THRESHOLD:
            break
        update()
        linear, pose = pose, pose_of()
    return pose

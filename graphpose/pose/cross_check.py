"""Gauss-Newton held against the GTSAM graph: their difference, and the bound they must meet.

Both solvers minimise the same cost, so started at Gauss-Newton's answer GTSAM must stay there:
their poses must agree to :data:`AGREE_TRANSLATION_M` and :data:`AGREE_ROTATION_DEG`. One
camera's estimate (:func:`graphpose.estimate.estimate_pose_from_points`) and a rig's
(:mod:`graphpose.pose.rig`) report the difference as a :class:`CrossCheck`.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..geometry import pose_difference
from .gauss_newton import GNResult
from .graph import GraphResult

#: GN and the graph must agree this closely (metres, degrees): the same cost, two solvers.
AGREE_TRANSLATION_M = 1e-6
AGREE_ROTATION_DEG = 1e-5


@dataclass(frozen=True)
class CrossCheck:
    """Difference between the Gauss-Newton and the GTSAM poses.

    Attributes
    ----------
    translation_m : float
        Distance between the two camera positions, metres.
    rotation_deg : float
        Angle of the relative rotation, degrees.
    agree : bool
        Both solvers converged and the differences are within :data:`AGREE_TRANSLATION_M`
        and :data:`AGREE_ROTATION_DEG`.
    """

    translation_m: float
    rotation_deg: float
    agree: bool


def cross_check(gn: GNResult, graph: GraphResult) -> CrossCheck:
    """Compare the Gauss-Newton and GTSAM poses.

    Parameters
    ----------
    gn : GNResult
        The Gauss-Newton solution.
    graph : GraphResult
        The GTSAM solution (started at Gauss-Newton's answer in :func:`estimate_pose`).

    Returns
    -------
    CrossCheck
        Their difference; ``agree`` needs both converged and the difference within
        :data:`AGREE_TRANSLATION_M` and :data:`AGREE_ROTATION_DEG`.
    """
    dt, dr = pose_difference(gn.T_WC, graph.T_WC)
    agree = gn.converged and graph.converged and dt <= AGREE_TRANSLATION_M and dr <= AGREE_ROTATION_DEG
    return CrossCheck(translation_m=dt, rotation_deg=dr, agree=bool(agree))

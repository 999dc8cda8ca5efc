"""graphpose.pose.cross_check: Gauss-Newton held against the GTSAM graph, their difference in
metres and degrees, and the bound both must meet (both converged, within AGREE_*)."""

import dataclasses

import numpy as np
import pytest

from graphpose.estimate import estimate_pose_from_points
from graphpose.geometry import C_from_rpy, T_from_params, project
from graphpose.pose.cross_check import AGREE_ROTATION_DEG, AGREE_TRANSLATION_M, CrossCheck, cross_check
from tests.conftest import BOARD_WPTS as WPTS
from tests.conftest import PROJECT_K as K


@pytest.fixture(scope="module")
def exact():
    """The estimate of exact correspondences: its two solvers agree to far inside the bounds."""
    T = T_from_params([0.2, 0.15, -1.0, 0.1, -0.2, 0.3])
    return estimate_pose_from_points(project(K, T, WPTS), WPTS, K)


def turned(T, yaw_deg):
    """T turned by yaw_deg about its own camera z axis (a relative rotation of exactly that angle)."""
    out = np.array(T, dtype=float)
    out[:3, :3] = out[:3, :3] @ C_from_rpy(0.0, 0.0, np.radians(yaw_deg))
    return out


def test_cross_check_disagreement_is_a_failure():
    T = T_from_params([0.2, 0.15, -1.0, 0.1, -0.2, 0.3])
    est = estimate_pose_from_points(project(K, T, WPTS), WPTS, K)
    moved = type(est.graph)(**{**est.graph.__dict__, "T_WC": T_from_params(est.params + [2e-6, 0, 0, 0, 0, 0])})
    check = cross_check(est.gn, moved)
    assert isinstance(check, CrossCheck) and not check.agree
    assert check.translation_m == pytest.approx(2e-6, rel=1e-6)


def test_solvers_at_one_pose_agree_with_zero_difference(exact):
    same = dataclasses.replace(exact.graph, T_WC=exact.gn.T_WC.copy())
    check = cross_check(exact.gn, same)
    assert check == CrossCheck(translation_m=0.0, rotation_deg=0.0, agree=True)
    assert type(check.agree) is bool


@pytest.mark.parametrize("which", ["gn", "graph"])
def test_agreement_needs_both_solvers_converged(exact, which):
    same = dataclasses.replace(exact.graph, T_WC=exact.gn.T_WC.copy())
    gn, graph = exact.gn, same
    if which == "gn":
        gn = dataclasses.replace(gn, converged=False)
    else:
        graph = dataclasses.replace(graph, converged=False)
    check = cross_check(gn, graph)
    assert check.translation_m == 0.0 and check.rotation_deg == 0.0 and not check.agree


@pytest.mark.parametrize("factor, agree", [(0.9, True), (1.1, False)])
def test_rotation_bound_is_the_relative_angle_in_degrees(exact, factor, agree):
    # A turn of 0.9 and 1.1 times AGREE_ROTATION_DEG about the camera axis, no translation.
    angle = factor * AGREE_ROTATION_DEG
    moved = dataclasses.replace(exact.graph, T_WC=turned(exact.gn.T_WC, angle))
    check = cross_check(exact.gn, moved)
    assert check.rotation_deg == pytest.approx(angle, rel=1e-6)
    assert check.translation_m == 0.0 and check.agree is agree


@pytest.mark.parametrize("factor, agree", [(0.9, True), (1.1, False)])
def test_translation_bound_is_the_distance_in_metres(exact, factor, agree):
    T = exact.gn.T_WC.copy()
    step = factor * AGREE_TRANSLATION_M * np.array([0.6, 0.0, 0.8])  # a unit direction
    T[:3, 3] += step
    check = cross_check(exact.gn, dataclasses.replace(exact.graph, T_WC=T))
    assert check.translation_m == pytest.approx(factor * AGREE_TRANSLATION_M, rel=1e-6)
    assert check.rotation_deg == 0.0 and check.agree is agree

"""graphpose.calibrate.rig_lm: solve_rig_lm, the hand-written Levenberg-Marquardt of a rig, on
exact projections of a known rig (the problem of tests/calibrate/test_rig_graph.py): it returns
the truth, its covariance is the graph's at unit pixel noise, and its Huber weights mark an
outlier."""

import numpy as np
import pytest

from graphpose.calibrate.rig_graph import RigGraph, solve_rig_graph
from graphpose.calibrate.rig_lm import RigLM, solve_rig_lm
from tests.calibrate.test_rig_graph import assert_truth, rig_problem


@pytest.fixture(scope="module")
def problem():
    return rig_problem(1)


def test_exact_junctions_give_back_the_rig_with_zero_residuals(problem):
    start, poses = problem
    fit = solve_rig_lm(*start)
    assert isinstance(fit, RigLM) and isinstance(fit, RigGraph) and fit.converged, fit.message
    assert_truth(fit, poses)
    assert len(fit.residuals) == len(fit.weights) == len(start[3])
    for r, w, (_, _, uv, _) in zip(fit.residuals, fit.weights, start[3]):
        assert r.shape == uv.shape and np.abs(r).max() < 1e-6
        np.testing.assert_array_equal(w, 1.0)  # no kernel: every weight one


def test_its_covariance_is_the_graphs_at_unit_pixel_noise(problem):
    # The same marginal (intrinsics and extrinsics, the views' poses marginalised) from the
    # hand-written normal equations and from GTSAM: (J^T J)^-1 at sigma 1 px.
    start, _ = problem
    fit = solve_rig_lm(*start)
    graph = solve_rig_graph(*start, sigma=1.0)
    np.testing.assert_allclose(fit.cov, graph.cov, rtol=1e-4, atol=1e-9 * np.abs(graph.cov).max())


def test_the_huber_weights_mark_an_outlier(problem):
    start, poses = problem
    cameras, T_C0_C, moved, observations = start
    bad = [list(o) for o in observations]
    uv = bad[3][2].copy()
    uv[:, 17] += [6.0, -8.0]  # one junction 10 px off
    bad[3][2] = uv
    fit = solve_rig_lm(cameras, T_C0_C, moved, [tuple(o) for o in bad], huber_px=1.0)
    assert fit.converged, fit.message
    w = fit.weights[3]
    assert w[17] == pytest.approx(1.0 / np.hypot(*fit.residuals[3][:, 17]), rel=1e-6)  # k / |r|
    assert w[17] < 0.2 and np.all(np.delete(w, 17) == 1.0)
    assert np.hypot(*fit.residuals[3][:, 17]) == pytest.approx(10.0, abs=0.5)  # the fit is not pulled to it

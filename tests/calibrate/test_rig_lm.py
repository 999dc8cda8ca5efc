"""graphpose.calibrate.rig_lm: solve_rig_lm, the hand-written Levenberg-Marquardt of a rig, on
exact projections of a known rig (the problem of tests/calibrate/test_rig_graph.py): it returns
the truth, its covariance is the graph's at unit pixel noise, and its Huber weights mark an
outlier."""

import numpy as np
import pytest

from graphpose.calibrate.rig_graph import RigGraph, solve_rig_graph
from graphpose.calibrate.rig_lm import RigLM, solve_rig_lm
from graphpose.geometry import params_from_T
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


def test_the_huber_curvature_lands_where_reweighting_does_in_fewer_steps(problem):
    # Noisy junctions under a tight kernel (most beyond it): the steps by the Huber cost's own
    # Hessian and those by the weighted normal matrix reach the same minimum, with the same
    # covariance (the weighted normal matrix's at the solution), the first in fewer steps.
    start, _ = problem
    cameras, T_C0_C, moved, observations = start
    rng = np.random.default_rng(5)
    noisy = [(v, c, uv + rng.normal(0.0, 0.3, uv.shape), W) for v, c, uv, W in observations]
    plain = solve_rig_lm(cameras, T_C0_C, moved, noisy)  # the robust solves start from a plain fit
    exact = solve_rig_lm(plain.cameras, plain.T_C0_C, plain.poses, noisy, huber_px=0.2)
    reweighted = solve_rig_lm(plain.cameras, plain.T_C0_C, plain.poses, noisy, huber_px=0.2, exact_curvature=False,
                              max_iterations=500)
    assert exact.converged and reweighted.converged, (exact.message, reweighted.message)
    assert np.mean(np.concatenate(exact.weights) < 1.0) > 0.5  # most junctions beyond the kernel
    sd = np.sqrt(np.diag(exact.cov))
    p = [np.concatenate([c.parameters for c in f.cameras] + [params_from_T(f.T_C0_C[1])]) for f in (exact, reweighted)]
    assert np.max(np.abs(p[0] - p[1]) / sd) < 1e-6  # the same minimum, to a millionth of a sigma
    np.testing.assert_allclose(exact.cov, reweighted.cov, rtol=1e-6)
    assert 2 * exact.iterations < reweighted.iterations  # 9 and 31 here

import gtsam
import numpy as np
import pytest
from gtsam.symbol_shorthand import L, X

from graphpose import InputError
from graphpose.camera_models import as_camera
from graphpose.geometry import T_from_params, params_from_T, project, to_camera
from graphpose.io.cases import bundled_cases
from graphpose.estimate import (
    AGREE_ROTATION_DEG,
    AGREE_TRANSLATION_M,
    estimate_pose_from_points,
    pose_difference,
)
from graphpose.pose.gauss_newton import gauss_newton
from graphpose.pose.graph import (
    GraphResult,
    graph_pose,
    params_cov_from_tangent,
    params_from_tangent_jacobian,
    projection_factor,
)
from graphpose.synth.poses import perturb_pose
from tests.conftest import BOARD_WPTS as WPTS
from tests.conftest import LENS_CAMERAS
from tests.conftest import PROJECT_K as K
from tests.helpers import random_pose


def guess_near(T, rng):
    """A start up to 8 degrees and 0.1 m off T."""
    return perturb_pose(T, angle_deg=(0.0, 8.0), offset_m=(0.0, 0.1), rng=rng)


def test_exact_correspondences_give_the_exact_pose():
    rng = np.random.default_rng(0)
    T = random_pose(rng=rng)
    res = graph_pose(project(K, T, WPTS), WPTS, K, guess=guess_near(T, rng), pixel_sigma=0.5)
    assert isinstance(res, GraphResult) and res.converged
    np.testing.assert_allclose(res.T_WC, T, atol=1e-8)
    np.testing.assert_allclose(res.params, params_from_T(T), atol=1e-8)


@pytest.mark.parametrize("seed", range(5))
def test_graph_and_gauss_newton_agree_on_pose_and_covariance(seed):
    rng = np.random.default_rng(seed)
    T = random_pose(rng=rng)
    I = project(K, T, WPTS) + rng.normal(0, 0.3, (2, 48))
    guess = guess_near(T, rng)
    g = gauss_newton(I, WPTS, K, guess=guess)
    r = graph_pose(I, WPTS, K, guess=guess)
    assert g.converged and r.converged
    dt, dr = pose_difference(g.T_WC, r.T_WC)
    assert dt < 1e-6 and dr < 1e-5
    assert r.sigma_px == pytest.approx(g.sigma_px, rel=1e-6)
    np.testing.assert_allclose(r.residuals, g.residuals, atol=1e-5)
    np.testing.assert_allclose(r.cov, g.cov, rtol=1e-4, atol=1e-6 * np.max(np.abs(g.cov)))


def test_agreement_with_a_mask_and_a_huber_kernel():
    rng = np.random.default_rng(10)
    T = random_pose(rng=rng)
    I = project(K, T, WPTS) + rng.normal(0, 0.3, (2, 48))
    I[:, 5] += [20.0, -10.0]
    I[:, 30] += [3.0, 2.0]
    mask = np.arange(48) != 5
    r = graph_pose(I, WPTS, K, guess=T, mask=mask, robust=True)
    g = gauss_newton(I, WPTS, K, guess=T, mask=mask, huber_px=1.345 * r.sigma_px, pixel_sigma=r.sigma_px)
    assert r.converged and g.converged
    assert np.all(np.isnan(r.residuals[:, 5])) and np.all(np.isfinite(r.residuals[:, mask]))
    assert 0.2 < r.sigma_px < 0.45  # robust scale, not inflated by the 3.6 px outlier
    dt, dr = pose_difference(g.T_WC, r.T_WC)
    assert dt < 1e-6 and dr < 1e-5
    np.testing.assert_allclose(r.cov, g.cov, rtol=1e-4, atol=1e-6 * np.max(np.abs(g.cov)))


def test_given_pixel_sigma_scales_the_covariance():
    rng = np.random.default_rng(11)
    T = random_pose(rng=rng)
    I = project(K, T, WPTS) + rng.normal(0, 0.3, (2, 48))
    one = graph_pose(I, WPTS, K, guess=T, pixel_sigma=1.0)
    two = graph_pose(I, WPTS, K, guess=T, pixel_sigma=2.0)
    assert one.sigma_px == 1.0 and two.sigma_px == 2.0
    np.testing.assert_allclose(two.cov, 4 * one.cov, rtol=1e-6)
    np.testing.assert_allclose(two.T_WC, one.T_WC, atol=1e-9)


def test_tangent_to_parameter_jacobian_matches_differences_of_gtsam_retract():
    rng = np.random.default_rng(12)
    for _ in range(20):
        T = random_pose(rng=rng)
        A = params_from_tangent_jacobian(T)
        pose, h = gtsam.Pose3(T), 1e-6
        for k in range(6):
            xi = np.zeros(6)
            xi[k] = h
            fd = (params_from_T(pose.retract(xi).matrix()) - params_from_T(pose.retract(-xi).matrix())) / (2 * h)
            np.testing.assert_allclose(A[:, k], fd, atol=1e-7)


def test_params_cov_from_tangent_rotates_position_and_maps_angles():
    rng = np.random.default_rng(14)
    T = random_pose(rng=rng)
    B = rng.normal(size=(6, 6))
    cov_tangent = B @ B.T
    cov = params_cov_from_tangent(T, cov_tangent)
    C = T[:3, :3]
    # dt = C v, and position does not depend on omega.
    np.testing.assert_allclose(cov[:3, :3], C @ cov_tangent[3:, 3:] @ C.T, rtol=1e-12, atol=1e-12)
    M_inv = params_from_tangent_jacobian(T)[3:, :3]
    np.testing.assert_allclose(cov[3:, 3:], M_inv @ cov_tangent[:3, :3] @ M_inv.T, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(cov[:3, 3:], C @ cov_tangent[3:, :3] @ M_inv.T, rtol=1e-12, atol=1e-12)
    res = graph_pose(project(K, T, WPTS) + rng.normal(0, 0.3, (2, 48)), WPTS, K, guess=T)
    np.testing.assert_array_equal(res.cov, params_cov_from_tangent(res.T_WC, res.cov_tangent))


def test_sigmas_in_reporting_units():
    rng = np.random.default_rng(13)
    T = random_pose(rng=rng)
    res = graph_pose(project(K, T, WPTS) + rng.normal(0, 0.3, (2, 48)), WPTS, K, guess=T)
    np.testing.assert_allclose(res.sigma_xyz_m, np.sqrt(np.diag(res.cov)[:3]))
    np.testing.assert_allclose(res.sigma_rpy_rad, np.sqrt(np.diag(res.cov)[3:]))
    np.testing.assert_allclose(res.sigma_translation_m, np.sqrt(np.diag(res.cov_tangent)[3:]))
    np.testing.assert_allclose(res.sigma_rotation_rad, np.sqrt(np.diag(res.cov_tangent)[:3]))
    # dt = C v: the body-frame and target-frame covariances of the position are related by
    # a rotation, so their traces agree.
    assert np.trace(res.cov[:3, :3]) == pytest.approx(np.trace(res.cov_tangent[3:, 3:]), rel=1e-9)
    assert 0.05e-3 < res.sigma_translation_m.max() < 10e-3 and np.degrees(res.sigma_rotation_rad).max() < 1


def test_behind_the_camera_message_names_the_callers_index():
    T = T_from_params([0.2, 0.15, -1.0, 0.0, 0.0, 0.0])
    W = WPTS.copy()
    W[2, [5, 20, 30]] = -2.0  # behind a camera at z = -1 looking along +z; 5 is masked out
    with pytest.raises(InputError, match=r"2 target point\(s\) .* \(first index 20, depth -1 m\)"):
        graph_pose(project(K, T, WPTS), W, K, guess=T, mask=np.arange(48) >= 10)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(pixel_sigma=0.0), "pixel_sigma"),
        (dict(huber_k=-1.0, robust=True), "huber_k"),
        (dict(mask=np.arange(48) < 2), "at least 4"),
        (dict(guess=T_from_params([0.2, 0.15, 1.0, 0, 0, 0])), "behind the camera"),
        (dict(Ipts=np.zeros((2, 47))), "same number"),
        (dict(camera=np.eye(3) * [0, 1, 1]), "focal"),
    ],
)
def test_bad_input_is_refused(kwargs, match):
    T = T_from_params([0.2, 0.15, -1.0, 0.0, 0.0, 0.0])
    args = dict(camera=K, guess=T, Ipts=project(K, T, WPTS), Wpts=WPTS)
    args.update(kwargs)
    with pytest.raises(InputError, match=match):
        graph_pose(**args)


def test_indeterminate_system_from_a_wild_guess_is_reported_not_raised():
    # A guess found by hand (CLI issue) that drives GTSAM into an indeterminate linear system.


    cases = bundled_cases()
    case = cases.cases[0]
    guess = T_from_params([0.8988, -0.2123, -0.9709, 1.4218, -1.2728, 3.0092])
    result = graph_pose(case.true_junctions, cases.board.world_points(), cases.K, guess=guess)
    assert not result.converged
    assert "Indeterminate" in result.message
    assert np.all(np.isnan(result.cov))


# ------------------------------------------------------------------ cameras with lens distortion

#: GTSAM's own factor for the first three, a custom factor on graphpose's projection for k3
#: and the rational model.
CAMERAS = LENS_CAMERAS
GTSAM_FACTOR = {"pinhole": "GenericProjectionFactorCal3_S2", "radtan": "GenericProjectionFactorCal3DS2",
                "radtan_k3": "CustomFactor", "rational": "CustomFactor",
                "fisheye": "GenericProjectionFactorCal3Fisheye"}


def _values(T, p_W):
    values = gtsam.Values()
    values.insert(X(0), gtsam.Pose3(T))
    values.insert(L(0), p_W)
    return values


@pytest.mark.parametrize("model", CAMERAS)
def test_the_graphs_projection_is_ours_for_each_model(model):
    camera = CAMERAS[model]
    rng = np.random.default_rng(30)
    noise = gtsam.noiseModel.Unit.Create(2)
    for _ in range(5):
        T = random_pose(rng=rng)
        uv = camera.project(to_camera(T, WPTS))
        for j in range(0, 48, 5):
            factor = projection_factor(camera, uv[:, j], noise, X(0), L(0))
            assert type(factor).__name__ == GTSAM_FACTOR[model]
            # GTSAM's error is its projection minus the measurement: ours, to 1e-9 px.
            assert np.max(np.abs(factor.unwhitenedError(_values(T, WPTS[:, j])))) < 1e-9
            moved = projection_factor(camera, uv[:, j] + [0.5, -0.25], noise, X(0), L(0))
            np.testing.assert_allclose(moved.unwhitenedError(_values(T, WPTS[:, j])), [-0.5, 0.25], atol=1e-9)


@pytest.mark.parametrize("model", ["radtan_k3", "rational"])
def test_custom_projection_factor_jacobians_match_differences_of_gtsam_retract(model):
    camera = CAMERAS[model]
    rng = np.random.default_rng(31)
    noise = gtsam.noiseModel.Unit.Create(2)
    T = random_pose(rng=rng)
    for j in (0, 13, 47):
        values = _values(T, WPTS[:, j])
        factor = projection_factor(camera, np.array([300.0, 200.0]), noise, X(0), L(0))
        A, b = factor.linearize(values).jacobian()
        np.testing.assert_allclose(-b, factor.unwhitenedError(values), atol=1e-12)
        h = 1e-6
        for k in range(9):
            step = np.zeros(9)
            step[k] = h
            deltas = []
            for sign in (1.0, -1.0):
                delta = gtsam.VectorValues()
                delta.insert(X(0), sign * step[:6])
                delta.insert(L(0), sign * step[6:])
                deltas.append(factor.unwhitenedError(values.retract(delta)))
            np.testing.assert_allclose(A[:, k], (deltas[0] - deltas[1]) / (2 * h), rtol=1e-6,
                                       atol=1e-6 * np.max(np.abs(A)))


@pytest.mark.slow  # 1.0 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("model", CAMERAS)
def test_graph_and_gauss_newton_agree_on_distorted_correspondences(model):
    camera = CAMERAS[model]
    rng = np.random.default_rng(32)
    for _ in range(3):
        T = random_pose(rng=rng)
        I = camera.project(to_camera(T, WPTS)) + rng.normal(0, 0.3, (2, 48))
        guess = guess_near(T, rng)
        g = gauss_newton(I, WPTS, camera, guess=guess)
        r = graph_pose(I, WPTS, camera, guess=guess)
        assert g.converged and r.converged
        dt, dr = pose_difference(g.T_WC, r.T_WC)
        assert dt < AGREE_TRANSLATION_M and dr < AGREE_ROTATION_DEG  # the pipeline's thresholds
        assert 0.2 < r.sigma_px < 0.4 and r.sigma_px == pytest.approx(g.sigma_px, rel=1e-6)
        np.testing.assert_allclose(r.residuals, g.residuals, atol=1e-5)
        np.testing.assert_allclose(r.cov, g.cov, rtol=1e-4, atol=1e-6 * np.max(np.abs(g.cov)))
        # The pipeline on the same points: homography start, both solvers, the cross-check.
        est = estimate_pose_from_points(I, WPTS, camera)
        assert est.ok, est.message
        assert est.orientation_ambiguous is False
        assert pose_difference(est.T_WC, g.T_WC)[0] < 1e-6


def test_unchecked_cores_give_the_checked_solve():
    # estimate_pose_from_points calls both solvers with check=False on inputs it checked: the
    # result must be the checked call's, and the checked call must still refuse bad input.
    rng = np.random.default_rng(7)
    T = random_pose(rng)
    I = project(K, T, WPTS) + rng.normal(0, 0.3, (2, 48))
    mask = np.ones(48, dtype=bool)
    mask[[3, 17]] = False
    I[:, 3] = np.nan
    guess = guess_near(T, rng)
    camera = as_camera(K)
    for solve in (gauss_newton, graph_pose):
        a = solve(I, WPTS, K, guess=guess, mask=mask)
        b = solve(I, WPTS, camera, guess=guess, mask=mask, check=False)
        np.testing.assert_array_equal(a.T_WC, b.T_WC)
        np.testing.assert_array_equal(a.cov, b.cov)
        with pytest.raises(InputError, match="NaN"):
            solve(I, WPTS, K, guess=guess, mask=np.ones(48, dtype=bool))


# ------------------------------------------------------------------ from Gauss-Newton's minimum


@pytest.mark.parametrize("model", ["pinhole", "radtan", "rational"])
@pytest.mark.parametrize("robust", [False, True], ids=["plain", "robust"])
def test_from_a_minimum_the_undamped_steps_alone_give_the_descents_answer(model, robust):
    camera = LENS_CAMERAS[model]
    rng = np.random.default_rng(40)
    T = random_pose(rng)
    I = camera.project(to_camera(T, WPTS)) + rng.normal(0, 0.3, (2, 48))
    I[:, 5] += 4.0  # an outlier for the Huber kernel
    g = gauss_newton(I, WPTS, camera, guess=guess_near(T, rng), huber_px=1.345 * 0.3 if robust else None)
    assert g.converged
    sigma = 0.3 if robust else None
    descent = graph_pose(I, WPTS, camera, guess=g.T_WC, pixel_sigma=sigma, robust=robust)
    confirmed = graph_pose(I, WPTS, camera, guess=g.T_WC, pixel_sigma=sigma, robust=robust, from_minimum=True)
    assert descent.converged and descent.iterations >= 1
    assert confirmed.converged and confirmed.iterations == 0  # no Levenberg-Marquardt
    assert max(pose_difference(confirmed.T_WC, descent.T_WC)) < 1e-9
    np.testing.assert_allclose(confirmed.cov, descent.cov, rtol=1e-7)
    np.testing.assert_allclose(confirmed.residuals, descent.residuals, atol=1e-9)


def test_a_start_the_undamped_steps_do_not_confirm_gets_the_descent(monkeypatch):
    # One undamped step cannot reach 1e-10 from 1 mm off the minimum: the solve then runs
    # Levenberg-Marquardt from that start, as without from_minimum (the same arithmetic).
    monkeypatch.setattr("graphpose.pose.graph._POLISH_ITERATIONS", 1)
    rng = np.random.default_rng(41)
    T = random_pose(rng)
    I = project(K, T, WPTS) + rng.normal(0, 0.3, (2, 48))
    g = gauss_newton(I, WPTS, K, guess=T)
    off = T_from_params(g.params + [1e-3, 0, 0, 0, 0, 0])
    flagged = graph_pose(I, WPTS, K, guess=off, from_minimum=True)
    plain = graph_pose(I, WPTS, K, guess=off)
    assert flagged.iterations == plain.iterations >= 1
    assert flagged.converged == plain.converged
    np.testing.assert_array_equal(flagged.T_WC, plain.T_WC)
    np.testing.assert_array_equal(flagged.cov, plain.cov)


def test_an_indeterminate_system_from_a_flagged_start_is_reported_as_without_the_flag():
    cases = bundled_cases()
    case = cases.cases[0]
    guess = T_from_params([0.8988, -0.2123, -0.9709, 1.4218, -1.2728, 3.0092])
    args = (case.true_junctions, cases.board.world_points(), cases.K)
    flagged, plain = graph_pose(*args, guess=guess, from_minimum=True), graph_pose(*args, guess=guess)
    assert not flagged.converged and "Indeterminate" in flagged.message
    assert flagged.message == plain.message and flagged.iterations == plain.iterations


# ------------------------------------------------------------------ the graph's construction


@pytest.mark.parametrize("planar", [True, False], ids=["board", "off the plane"])
def test_the_values_hold_the_target_points_exactly(planar):
    # A board's points go in through one backprojection call, the others one at a time:
    # either way the values are the target points bit for bit.
    from graphpose.pose.graph import POSE_KEY, _build

    rng = np.random.default_rng(5)
    W = WPTS * rng.choice([1e-3, 1.0, 7.3, 1e3], WPTS.shape)
    if planar:
        W[2] = 0.0
    else:
        W[2] = rng.uniform(-0.2, 0.2, 48)
    keys = np.arange(3, 51)
    T = T_from_params([0.2, 0.15, -1.0, 0.1, -0.2, 0.3])
    _, values, _ = _build(as_camera(K), T, np.zeros((2, 48)), W, keys, 1.0, None)
    points = np.array([values.atPoint3(int(k)) for k in keys]).T
    np.testing.assert_array_equal(points, W)
    np.testing.assert_allclose(values.atPose3(POSE_KEY).matrix(), T, atol=1e-15)


@pytest.mark.parametrize("robust", [False, True], ids=["plain", "robust"])
def test_the_covariance_is_gtsams_marginal_of_the_pinned_graph(robust):
    # The polish eliminates the pose's block with the target points held exact; gtsam.Marginals
    # on the graph with the points pinned by their 1e-8 m priors gives the same covariance.
    from graphpose.pose.graph import POSE_KEY, _build, _pinned

    rng = np.random.default_rng(6)
    T = random_pose(rng=rng)
    I = project(K, T, WPTS) + rng.normal(0, 0.3, (2, 48))
    I[:, 7] += 3.0
    res = graph_pose(I, WPTS, K, guess=guess_near(T, rng), pixel_sigma=0.3, robust=robust)
    assert res.converged
    keys = np.arange(48)
    factors, values, _ = _build(as_camera(K), res.T_WC, I, WPTS, keys, 0.3, 1.345 if robust else None)
    marginal = gtsam.Marginals(_pinned(factors, keys, WPTS), values).marginalCovariance(POSE_KEY)
    np.testing.assert_allclose(res.cov_tangent, marginal, rtol=1e-6)


def test_points_off_the_plane_agree_with_gauss_newton():
    rng = np.random.default_rng(7)
    W = WPTS.copy()
    W[2] = rng.uniform(-0.1, 0.1, 48)
    T = random_pose(rng=rng)
    I = project(K, T, W) + rng.normal(0, 0.3, (2, 48))
    g = gauss_newton(I, W, K, guess=guess_near(T, rng))
    res = graph_pose(I, W, K, guess=g.T_WC, from_minimum=True)
    assert res.converged and res.iterations == 0
    assert max(pose_difference(res.T_WC, g.T_WC)) < 1e-8
    np.testing.assert_allclose(res.cov, g.cov, rtol=1e-4)

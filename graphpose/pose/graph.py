"""Camera pose and its covariance from a GTSAM factor graph: the independent second solver.

The graph has one ``Pose3`` variable ``X(0)`` (the camera pose T_WC, GTSAM's own convention:
the camera looks along its +z with x right and y down, as in :mod:`graphpose.geometry`), one
``Point3`` variable per trusted junction (key ``j``, the junction's index, valued at its exact
target position) and one projection factor per trusted junction (:func:`projection_factor`).
The target points are known, so the solve moves the pose alone: undamped Gauss-Newton steps,
each GTSAM's linearisation of the factors and GTSAM's elimination of the pose's block of its
Hessian (the points held exact), run until the pose step is below :data:`POLISH_STEP`; the pose's
conditional, without parents, is its marginal, so the covariance comes from the last step (no
second linearisation and elimination for ``gtsam.Marginals``), and only where it is reported.
Started at Gauss-Newton's converged answer (``from_minimum``, as the pipeline starts it), these
steps alone confirm that minimum. Where they do not, or without the flag, Levenberg-Marquardt
first minimises the same reprojection cost as :mod:`graphpose.pose.gauss_newton` on the graph
with one very tight ``PriorFactorPoint3`` per point that pins it to its target position (a tight
prior rather than ``NonlinearEquality`` keeps the linearised system non-singular; the points held
exact are its limit), eliminated in the star ordering without fill-in (every point, then the
pose); the undamped steps polish its answer. The pipeline holds the two solvers against each
other.

The projection factor follows the camera (:mod:`graphpose.camera_models`): GTSAM's own
``GenericProjectionFactorCal3_S2``, ``...Cal3DS2`` or ``...Cal3Fisheye`` with the
calibration of :meth:`graphpose.camera_models.Camera.gtsam_calibration`, and, for a camera GTSAM
has no calibration for (the rational radial-tangential model), a ``CustomFactor`` around
graphpose's own projection and its analytic Jacobian. GTSAM's calibrations were checked
against graphpose's projection (``tests/camera_models/``), so the second solver keeps its
independent projection code wherever GTSAM has one.

Covariance conventions
----------------------
GTSAM's Pose3 tangent vector is ``xi = (omega, v)``: a body-frame rotation increment (rad)
then a body-frame translation increment (m), with ``T (+) xi = T Exp(xi)``. To first order
``dC = C [omega]x`` and ``dt = C v``. With ``C = Cz(yaw) Cy(pitch) Cx(roll)``,

    C^T dC = [ e_x droll + Cx^T e_y dpitch + (Cy Cx)^T e_z dyaw ]x,

so ``omega = M d(rpy)`` with ``M = [e_x, Cx^T e_y, (Cy Cx)^T e_z]`` (det M = cos pitch, the
gimbal lock). The parameter covariance in (x, y, z, roll, pitch, yaw) is ``A Sigma_xi A^T``
with ``A = [[0, C], [M^-1, 0]]`` (:func:`params_from_tangent_jacobian`,
:func:`params_cov_from_tangent`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, X

from .._checks import check_in_front, check_number, check_transform
from ..observations import check_observations
from ..geometry import hat, params_from_T, to_camera
from ..robust import HUBER_K, mad_sigma
from .gauss_newton import reprojection_rms
from .._deprecated import renamed

#: Standard deviation (metres) of the prior that pins each target point: far below anything
#: the pixels can resolve (about 1e-6 px at 1 m), yet finite so the marginals exist.
LANDMARK_SIGMA_M = 1e-8
#: Levenberg-Marquardt stopping tolerances on the cost change. LM brings the pose near the
#: minimum from afar; the undamped steps after it (cheaper than LM iterations) finish.
_RELATIVE_TOL = 1e-6
_ABSOLUTE_TOL = 1e-12
_MAX_ITERATIONS = 100
#: Undamped Gauss-Newton steps after Levenberg-Marquardt (see step 6 of the graph's solve):
#: at most this many, until the pose step (rad, m) is below POLISH_STEP (public: the
#: pipeline's Gauss-Newton stops at the same step, so that one step of GTSAM's confirms its
#: answer). The steps converge
#: linearly: at a rate of 0.01-0.2 on plain least squares, but 0.35-0.6 with the Huber
#: kernel, whose steps GTSAM computes by iterative reweighting (the weights are frozen in
#: each linearisation, so the step overshoots along the down-weighted residuals). From where
#: Levenberg-Marquardt stops (~1e-6) the six real images need 9-18 robust steps; 50 allows a
#: rate up to about 0.75.
_POLISH_ITERATIONS = 50
POLISH_STEP = 1e-10


@dataclass(frozen=True)
class GraphResult:
    """The outcome of :func:`graph_pose`.

    Attributes
    ----------
    T_WC : (4, 4) ndarray
        Camera pose in the target frame (the optimised ``Pose3``).
    params : (6,) ndarray
        ``(x, y, z, roll, pitch, yaw)``, metres and radians.
    cov : (6, 6) ndarray
        Covariance of ``params`` (m, rad), mapped from the tangent covariance.
    cov_tangent : (6, 6) ndarray
        GTSAM's marginal covariance of ``X(0)``: body-frame rotation (rad) then body-frame
        translation (m), scaled by ``sigma_px^2`` when the pixel sigma was estimated.
    sigma_px : float
        Pixel noise used for the covariance: given, or estimated from the residuals as
        ``sqrt(chi2 / (2m - 6))`` (robustly, from the median, when ``robust``).
    converged : bool
        True when Levenberg-Marquardt stopped on its tolerances before the iteration cap,
        the Gauss-Newton steps after it shrank below 1e-10, and every used point is in
        front of the camera.
    iterations : int
        Levenberg-Marquardt iterations: 0 when the guess was taken as a minimum
        (``from_minimum``) and the undamped steps confirmed it.
    residuals : (2, n) ndarray
        Measured minus predicted pixels at the solution, NaN for masked points.
    rms_px : float
        ``sqrt(mean(du^2 + dv^2))`` over the used points, pixels
        (:func:`graphpose.pose.gauss_newton.reprojection_rms`).
    mask : (n,) ndarray of bool
        The junctions with a projection factor.
    message : str
        Empty, or why GTSAM failed (then ``converged`` is False and ``cov`` is NaN).
    """

    T_WC: np.ndarray
    params: np.ndarray
    cov: np.ndarray
    cov_tangent: np.ndarray
    sigma_px: float
    converged: bool
    iterations: int
    residuals: np.ndarray
    rms_px: float
    mask: np.ndarray
    message: str = ""

    @property
    def sigma_xyz_m(self) -> np.ndarray:
        """1-sigma of x, y, z in metres, shape (3,)."""
        return np.sqrt(np.diag(self.cov)[:3])

    @property
    def sigma_rpy_rad(self) -> np.ndarray:
        """1-sigma of roll, pitch, yaw in radians, shape (3,)."""
        return np.sqrt(np.diag(self.cov)[3:])

    @property
    def sigma_translation_m(self) -> np.ndarray:
        """1-sigma of the camera position along the body axes in metres, shape (3,)."""
        return np.sqrt(np.diag(self.cov_tangent)[3:])

    @property
    def sigma_rotation_rad(self) -> np.ndarray:
        """1-sigma of the rotation about the body axes in radians, shape (3,)."""
        return np.sqrt(np.diag(self.cov_tangent)[:3])

    residual_rms_px = renamed("residual_rms_px", "rms_px")
    sigma_translation_mm = renamed("sigma_translation_mm", "sigma_translation_m", lambda m: 1e3 * m)
    sigma_rotation_deg = renamed("sigma_rotation_deg", "sigma_rotation_rad", np.degrees)


def graph_pose(Ipts, Wpts, camera, *, guess, mask=None, pixel_sigma=None, robust=False,
               huber_k: float = HUBER_K, from_minimum: bool = False, check: bool = True) -> GraphResult:
    """Solve the camera pose with a GTSAM factor graph and return its marginal covariance.

    Parameters
    ----------
    Ipts : (2, n) array_like
        Observed junctions (u, v), pixels; NaN allowed where ``mask`` is False.
    Wpts : (3, n) array_like
        Matching target points, metres.
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`; raw, distorted pixels), or pinhole
        intrinsics ``K``, pixels (fx, fy, skew, cx, cy go into ``Cal3_S2``).
    guess : (4, 4) array_like
        Starting pose T_WC.
    mask : (n,) array_like of bool, optional
        Junctions to use (at least 4); all by default.
    pixel_sigma : float, optional
        Isotropic pixel noise (px). If None it is estimated from the residuals of a solve with
        unit sigma and the covariance is scaled by its square.
    robust : bool
        Wrap the pixel noise in a Huber kernel with threshold ``huber_k * pixel_sigma``; with
        no ``pixel_sigma``, a plain solve first estimates it robustly (1.4826 x the median
        absolute residual).
    huber_k : float
        Huber threshold in sigmas.
    from_minimum : bool
        ``guess`` is a converged minimum of the same cost (Gauss-Newton's answer, as
        :func:`graphpose.estimate.estimate_pose_from_points` passes it): the undamped
        steps alone confirm it, without Levenberg-Marquardt (``iterations`` is then 0); where
        they do not converge from it, Levenberg-Marquardt runs from it as without the flag.
        The answer is GTSAM's either way.

    check : bool
        False skips the input checks, for a caller that checked the inputs at its own edge
        (a camera object, float arrays of the right shapes, a boolean mask, a checked guess,
        positive ``pixel_sigma`` or None and ``huber_k``; the guess's depths are still checked): pytransform3d's
        ``check=False``.

    Returns
    -------
    GraphResult

    Raises
    ------
    InputError
        On malformed input (see :func:`graphpose.observations.check_observations`), a
        non-positive ``pixel_sigma`` or ``huber_k``, or a used point behind the camera at the
        guess.
    """
    if check:
        camera, Ipts, Wpts, mask = check_observations(camera, Ipts, Wpts, mask)
        guess = check_transform(guess, "guess")
        pixel_sigma = None if pixel_sigma is None else check_number("pixel_sigma", pixel_sigma, 0.0, strict=True)
        huber_k = check_number("huber_k", huber_k, 0.0, strict=True)
    return _graph_pose(camera, guess, Ipts, Wpts, mask, pixel_sigma, robust, huber_k, from_minimum=bool(from_minimum))


def _graph_pose(camera, T_WC_guess, Ipts, Wpts, mask, pixel_sigma=None, robust=False,
                huber_k: float = HUBER_K, *, from_minimum: bool = False) -> GraphResult:
    """The solve of :func:`graph_pose`, its inputs checked (``check``)."""
    keys = np.flatnonzero(mask)
    I, W = Ipts[:, keys], Wpts[:, keys]  # the used points, once
    check_in_front(to_camera(T_WC_guess, W)[2], "the guess", keys)
    if robust and pixel_sigma is None:
        # Only its pose is used: no marginals. A minimum of the robust cost is none of the
        # plain one, so this solve descends.
        plain = _solve(camera, T_WC_guess, I, W, keys, 1.0, None, marginals=False)
        r = I - camera.project(to_camera(plain[0], W))
        pixel_sigma = mad_sigma(r, floor=1e-12)
    sigma = 1.0 if pixel_sigma is None else float(pixel_sigma)
    T, cov_tangent, converged, iterations, message = _solve(
        camera, T_WC_guess, I, W, keys, sigma, huber_k if robust else None, from_minimum=from_minimum)
    used = I - camera.project(to_camera(T, W))
    residuals = np.full((2, mask.size), np.nan)
    residuals[:, keys] = used
    if pixel_sigma is None:
        m = used.shape[1]
        sigma = math.sqrt(float(np.sum(used**2)) / (2 * m - 6))
        cov_tangent = sigma**2 * cov_tangent
    params = params_from_T(T)
    return GraphResult(
        T_WC=T,
        params=params,
        cov=_params_cov(T, params, cov_tangent),
        cov_tangent=cov_tangent,
        sigma_px=sigma,
        converged=converged,
        iterations=iterations,
        residuals=residuals,
        rms_px=reprojection_rms(used),
        mask=mask.copy(),
        message=message,
    )


def _solve(camera, T_WC_guess, I, W, keys, sigma, huber_k, marginals=True, from_minimum=False):
    """Build and optimise the graph on the used points ``I`` (2, m), ``W`` (3, m) of the
    junctions ``keys`` (m,).

    Returns (T_WC, tangent covariance (NaN unless ``marginals``), converged, iterations,
    failure message or "").
    """
    factors, initial, ordering = _build(camera, T_WC_guess, I, W, keys, sigma, huber_k)
    if from_minimum:
        # 5a. The guess is a converged minimum of the same cost (Gauss-Newton's answer): the
        #     undamped steps of step 6 alone confirm it, without Levenberg-Marquardt's own
        #     iteration (an error, a linearisation and a damped elimination, then the error
        #     again). Where they do not converge from it (or the system is indeterminate), the
        #     solve below runs from the same guess, as if the guess had not been taken as one.
        try:
            solved = _polish(factors, initial, ordering)
        except RuntimeError:
            solved = None
        if solved is not None and solved[2]:
            return _answer(solved, W, marginals, 0, np.isfinite(factors.error(solved[0])))
    # 5. Optimise with Levenberg-Marquardt from the guess, on the whole graph: the projection
    #    factors and a tight prior pinning each target point (step 4b).
    graph = _pinned(factors, keys, W)
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(_RELATIVE_TOL)
    params.setAbsoluteErrorTol(_ABSOLUTE_TOL)
    params.setMaxIterations(_MAX_ITERATIONS)
    params.setOrdering(gtsam.Ordering([*keys.tolist(), POSE_KEY]))
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    try:
        return _optimise(factors, optimizer, ordering, W, marginals)
    except RuntimeError as exc:
        # From a far-off guess the linearised system can become indeterminate (GTSAM's
        # IndeterminateSystemException): that is a failed solve, reported, not a crash.
        nan = np.full((6, 6), np.nan)
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        return np.asarray(T_WC_guess, dtype=float), nan, False, int(optimizer.iterations()), (
            lines[0] if lines else type(exc).__name__)


#: GTSAM key of the pose ``X(0)``; junction j's target point has the key j (small integers:
#: GTSAM's vectorised ``utilities.insertProjectionFactors`` takes them as floats, exact below
#: 2^53, which a ``Symbol`` such as ``L(j)`` is not).
POSE_KEY = X(0)
#: The ordering of the pose alone, for the elimination of its block (step 6).
_POSE_ORDERING = gtsam.Ordering([POSE_KEY])


def _build(camera, T_WC_guess, I, W, keys, sigma, huber_k):
    """Steps 1-4 of the solve: the projection factors, the initial values and the ordering of
    their linearisation's Hessian (the pose, then every target point)."""
    # 1. Create the factor graph and the camera calibration (pixels; None where GTSAM has
    #    no calibration for the model: then a custom factor on graphpose's projection).
    graph = gtsam.NonlinearFactorGraph()
    calibration = camera.gtsam_calibration()
    # 2. Noise models. Pixel measurement noise: isotropic over (u, v), pixels, optionally
    #    with a Huber kernel whose threshold is in sigmas.
    pixel_noise = gtsam.noiseModel.Isotropic.Sigma(2, sigma)
    if huber_k is not None:
        pixel_noise = gtsam.noiseModel.Robust.Create(
            gtsam.noiseModel.mEstimator.Huber.Create(huber_k), pixel_noise)
    # 3. One projection factor per trusted junction. A pinhole's factors are GTSAM's
    #    GenericProjectionFactorCal3_S2, added in one call (utilities.insertProjectionFactors);
    #    the other models' one at a time.
    initial = gtsam.Values()
    initial.insert(POSE_KEY, gtsam.Pose3(T_WC_guess))
    key_list = keys.tolist()
    if type(calibration).__name__ == "Cal3_S2":
        gtsam.utilities.insertProjectionFactors(graph, POSE_KEY, keys.astype(float), I, pixel_noise, calibration)
    else:
        add = graph.add
        for key, uv in zip(key_list, I.T.copy()):
            add(projection_factor(camera, uv, pixel_noise, POSE_KEY, key, calibration))
    # 4. The initial values: the guessed pose and the exact target points (held there: see
    #    step 6; Levenberg-Marquardt's graph pins them with priors, step 4b).
    if not np.any(W[2]):
        # A target on the plane z = 0 (every board): all its points in one call, each
        # (x, y) backprojected at depth 1 by _PLANE_CAMERA, which gives (x, y, 0) exactly.
        gtsam.utilities.insertBackprojections(initial, _PLANE_CAMERA, keys.astype(float), np.ascontiguousarray(W[:2]),
                                              1.0)
    else:
        insert = initial.insertPoint3
        for key, point in zip(key_list, W.T.copy()):
            insert(key, point)
    return graph, initial, gtsam.Ordering([POSE_KEY, *key_list])


#: A camera 1 m behind the plane z = 0 looking along +z, with fx = fy = 1 and no offset or skew:
#: GTSAM's backprojection of the pixel (x, y) at depth 1 is (1 x + 0, 1 y + 0, 1 - 1) = (x, y, 0),
#: exact in floating point (no rounding in a product by 1 or a sum with 0).
_PLANE_CAMERA = gtsam.PinholeCameraCal3_S2(gtsam.Pose3(gtsam.Rot3(), np.array([0.0, 0.0, -1.0])),
                                           gtsam.Cal3_S2(1.0, 1.0, 0.0, 0.0, 0.0))


def _pinned(factors, keys, W):
    """Step 4b: the projection ``factors`` and one tight ``PriorFactorPoint3`` per target point
    (isotropic over its x, y, z, metres: :data:`LANDMARK_SIGMA_M`), the graph
    Levenberg-Marquardt descends on. A tight prior rather than ``NonlinearEquality`` keeps the
    linearised system non-singular."""
    graph = gtsam.NonlinearFactorGraph(factors)
    landmark_noise = gtsam.noiseModel.Isotropic.Sigma(3, LANDMARK_SIGMA_M)
    add_prior = graph.addPriorPoint3
    for key, point in zip(keys.tolist(), W.T.copy()):
        add_prior(key, point, landmark_noise)
    return graph


#: GTSAM's projection factor for each calibration :meth:`graphpose.camera_models.Camera.gtsam_calibration` gives.
PROJECTION_FACTORS = {
    "Cal3_S2": gtsam.GenericProjectionFactorCal3_S2,
    "Cal3DS2": gtsam.GenericProjectionFactorCal3DS2,
    "Cal3Fisheye": gtsam.GenericProjectionFactorCal3Fisheye,
}


def projection_factor(camera, uv, noise, pose_key, point_key, calibration=None):
    """One image point's projection factor on a ``Pose3`` (``T_WC``) and a ``Point3``.

    Parameters
    ----------
    camera : Camera
        The camera model (trusted: a :mod:`graphpose.camera_models` object).
    uv : (2,) ndarray
        The measured pixel.
    noise : gtsam.noiseModel.Base
        Two-dimensional pixel noise.
    pose_key, point_key : int
        GTSAM keys of the camera pose and of the target point.
    calibration : gtsam calibration, optional
        ``camera.gtsam_calibration()``, passed in to build it once for many factors; made
        here when None.

    Returns
    -------
    gtsam.NonlinearFactor
        GTSAM's ``GenericProjectionFactor`` for the camera's calibration
        (:data:`PROJECTION_FACTORS`); where GTSAM has none, a ``CustomFactor`` with
        graphpose's projection and its analytic Jacobians (error: predicted minus
        measured, as GTSAM's; a point at or behind the camera gives GTSAM's constant
        ``2 fx`` error with zero Jacobians).
    """
    calibration = camera.gtsam_calibration() if calibration is None else calibration
    if calibration is not None:
        return PROJECTION_FACTORS[type(calibration).__name__](uv, noise, pose_key, point_key, calibration)
    measured = np.array(uv, dtype=float).reshape(2)

    def error(factor, values, jacobians):
        T = values.atPose3(factor.keys()[0])
        R = T.rotation().matrix()
        P = R.T @ (values.atPoint3(factor.keys()[1]) - T.translation())
        if P[2] <= 0:
            if jacobians is not None:
                jacobians[0], jacobians[1] = np.zeros((2, 6)), np.zeros((2, 3))
            return np.full(2, 2.0 * camera.fx)
        uv_hat, G = camera.project_jacobian(P[:, None])
        if jacobians is not None:
            # Right perturbation T Exp(omega, v): dP = [P]x omega - v; dP / dp_W = R^T.
            jacobians[0] = G[0] @ np.hstack([hat(P), -np.eye(3)])
            jacobians[1] = G[0] @ R.T
        return uv_hat[:, 0] - measured

    return gtsam.CustomFactor(noise, [pose_key, point_key], error)


def _optimise(factors, optimizer, ordering, W, marginals=True):
    """Steps 5-7 of :func:`_solve`; GTSAM may raise RuntimeError on an indeterminate system."""
    result = optimizer.optimize()
    converged = optimizer.iterations() < _MAX_ITERATIONS and np.isfinite(optimizer.error())
    return _answer(_polish(factors, result, ordering), W, marginals, int(optimizer.iterations()),
                   converged)


def _polish(factors, values, ordering):
    """Step 6: undamped Gauss-Newton steps from ``values``; (values, last elimination, polished).

    Each step is GTSAM's: the projection ``factors`` linearised at ``values``, their Hessian
    (``GaussianFactorGraph.augmentedHessian``, in ``ordering``: the pose first) and the pose's block of
    it, with the target points held at their exact positions (what the tight priors of
    Levenberg-Marquardt's graph approximate to 1e-8 m), eliminated by GTSAM as a
    ``HessianFactor`` on the pose alone; its conditional, without parents, is the pose's
    marginal (step 7). The step retracts the pose; the points stay put.

    Levenberg-Marquardt stops when the cost stops falling visibly, which along weakly
    observed directions (tilt against sideways translation) can leave 1e-7 m; the steps,
    computed from the gradient, stay accurate below the cost's rounding noise. They converge
    linearly (rate 0.01-0.2 with 1 px noise on plain least squares, 0.35-0.6 with the Huber
    kernel's reweighted steps), so they run until the pose step is below POLISH_STEP; if
    they never get there within _POLISH_ITERATIONS, ``polished`` is False.
    """
    values = gtsam.Values(values)
    for _ in range(_POLISH_ITERATIONS):
        # [A b]^T [A b] of the whitened linearisation, the pose's six columns first
        augmented = factors.linearize(values).augmentedHessian(ordering)
        pose_block = gtsam.GaussianFactorGraph()
        pose_block.add(gtsam.HessianFactor(POSE_KEY, augmented[:6, :6], augmented[:6, -1], augmented[-1, -1]))
        bayes_net = pose_block.eliminateSequential(_POSE_ORDERING)
        delta = bayes_net.optimize().at(POSE_KEY)
        values.update(POSE_KEY, values.atPose3(POSE_KEY).retract(delta))
        if np.abs(delta).max() < POLISH_STEP:
            return values, bayes_net, True
    return values, bayes_net, False


def _answer(polished, W, marginals, iterations, converged):
    """Step 7: the pose, its marginal covariance and the convergence report (``converged``:
    the descent's own, before the polish and the cheirality)."""
    result, bayes_net, done = polished
    # 7. Marginal covariance of the pose: tangent order (rotation rad, translation m), body
    #    frame. It is the last step's elimination's (what gtsam.Marginals would eliminate
    #    again), linearised less than POLISH_STEP from the result: the same to rounding. The
    #    pose's conditional, the only one, is its marginal: the inverse of its information
    #    (as GaussianBayesTree.marginalCovariance inverts its root clique's).
    cov = np.linalg.inv(bayes_net.back().information()) if marginals else np.full((6, 6), np.nan)
    T = result.atPose3(POSE_KEY).matrix()
    # The projection factors do not enforce cheirality: a solution with a point behind the
    # camera is a failure, not a pose.
    in_front = np.all(to_camera(T, W)[2] > 0)
    converged = converged and done and in_front
    return T, np.asarray(cov), bool(converged), iterations, ""


def params_from_tangent_jacobian(T_WC) -> np.ndarray:
    """Jacobian of the pose parameters by GTSAM's Pose3 tangent vector at T_WC.

    Parameters
    ----------
    T_WC : (4, 4) ndarray
        The pose at which to linearise (trusted).

    Returns
    -------
    A : (6, 6) ndarray
        ``d(x, y, z, roll, pitch, yaw) / d(omega, v)``: ``dt = C v``, ``d(rpy) = M^-1 omega``
        with ``M = [e_x, Cx^T e_y, (Cy Cx)^T e_z]`` (see the module docstring). Singular at
        pitch = +-90 degrees.
    """
    return _tangent_jacobian(T_WC, params_from_T(T_WC))


def _tangent_jacobian(T_WC, params):
    """:func:`params_from_tangent_jacobian` with the pose's ``params`` at hand."""
    C = T_WC[:3, :3]
    roll, pitch = float(params[3]), float(params[4])
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    M = np.array([[1.0, 0.0, -sp], [0.0, cr, sr * cp], [0.0, -sr, cr * cp]])
    A = np.zeros((6, 6))
    A[:3, 3:] = C
    A[3:, :3] = np.linalg.inv(M)
    return A


def params_cov_from_tangent(T_WC, cov_tangent) -> np.ndarray:
    """Covariance of the pose parameters from a covariance on GTSAM's Pose3 tangent space.

    Parameters
    ----------
    T_WC : (4, 4) ndarray
        The pose the tangent covariance belongs to (trusted).
    cov_tangent : (6, 6) ndarray
        Covariance of ``(omega, v)``: body-frame rotation (rad) then body-frame translation
        (m), as GTSAM's ``Marginals`` give it for a ``Pose3``.

    Returns
    -------
    cov : (6, 6) ndarray
        Covariance of ``(x, y, z, roll, pitch, yaw)`` in m and rad, ``A cov_tangent A^T``
        with ``A`` from :func:`params_from_tangent_jacobian`; infinite or NaN at gimbal lock.
    """
    return _params_cov(T_WC, params_from_T(T_WC), cov_tangent)


def _params_cov(T_WC, params, cov_tangent):
    """:func:`params_cov_from_tangent` with the pose's ``params`` at hand."""
    A = _tangent_jacobian(T_WC, params)
    return A @ cov_tangent @ A.T

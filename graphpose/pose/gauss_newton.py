"""Camera pose from 2-D/3-D correspondences by Gauss-Newton over the six Euler parameters.

The cost is the sum of squared reprojection errors (pixels) over the trusted junctions,

    E(theta) = 1/2 sum_j || u_j - pi(T_WC(theta), p_j) ||^2,

with ``theta = (x, y, z, roll, pitch, yaw)`` as in :mod:`graphpose.geometry` and ``pi`` the
camera's projection (:mod:`graphpose.camera_models`: a pinhole ``K``, or a model with lens
distortion, so that raw image points are fitted as they are). Each step solves the 6 x 6
normal equations with the exact analytic Jacobian (:func:`graphpose.course.find_jacobian`,
:func:`projection_jacobians`): the pose's derivative of the camera-frame point, chained
with the camera's ``d uv / d p_C`` (:meth:`graphpose.camera_models.Camera.project_jacobian`). Step control is Levenberg-Marquardt damping: the plain
Gauss-Newton step is tried first and, when it raises the cost or puts a point behind the
camera, it is damped (``(J^T J + lambda diag(J^T J)) delta = J^T r`` with ``r`` measured
minus predicted) until the cost falls, so a poor start cannot make it diverge.

Gimbal lock: the Euler parameterisation is singular at pitch = +-90 degrees (roll and yaw turn
about the same axis and the normal equations lose rank). A camera that faces the board looks
along the target's +z, so its pitch is small (roll is near 0, or near 180 degrees for a
target frame with z out of the board), far from the singularity. Near it the roll and yaw
variances blow up; exactly at it the solve stops and reports not converged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import (
    MIN_DEPTH,
    as_points,
    check_in_front,
    check_number,
    check_transform,
)
from ..observations import check_observations
from ..geometry import T_from_params, params_from_T
from ..camera_models import PinholeCamera, RadTanCamera, as_camera
from ..errors import ConvergenceError, InputError
# The compiled kernels (pose's own, private module): camera_points (target points into each
# camera's frame) and chain_jacobians (the projection's chain rule) are shared with the
# calibration's solvers, which import them from here, the module that documents them.
from ._gauss_newton import (PINHOLE, RADTAN, camera_points, chain_jacobians, gauss_newton_loop, normal_equations,
                            pinhole_residuals)
from .._deprecated import renamed

#: Default iteration cap (damped and undamped steps both count).
MAX_ITERATIONS = 100
#: Convergence: the undamped Gauss-Newton step is below this (metres and radians, inf-norm).
STEP_TOL = 1e-9
#: A step promising a decrease below this fraction of the cost is within the cost's rounding.
_COST_RTOL = 1e-12
#: Undamped steps taken below the cost's rounding noise before stopping anyway.
_MAX_POLISH_STEPS = 5
#: The damping factor above which a stuck search gives up.
_LAMBDA_MAX = 1e10


@dataclass(frozen=True)
class GNResult:
    """The outcome of :func:`gauss_newton`.

    Attributes
    ----------
    T_WC : (4, 4) ndarray
        Camera pose in the target frame at the last accepted iterate.
    params : (6,) ndarray
        The same pose as ``(x, y, z, roll, pitch, yaw)``, metres and radians.
    converged : bool
        True when, before the iteration cap, the undamped step fell below the tolerance (or
        stayed above it for several steps whose promised decrease was below the cost's
        rounding noise).
    iterations : int
        Steps tried (accepted or rejected).
    residuals : (2, n) ndarray
        Measured minus predicted pixels at the solution, NaN for points left out by the mask.
    rms_px : float
        ``sqrt(mean(du^2 + dv^2))`` over the used points, pixels (:func:`reprojection_rms`:
        OpenCV's definition, the RMS length of the residual vectors).
    sigma_px : float
        Pixel noise behind ``cov``: ``pixel_sigma`` if given, else estimated from the residuals
        as ``sqrt(sum r^2 / (2m - 6))`` over the m used points (with a Huber kernel, the
        weighted sum).
    cov : (6, 6) ndarray
        ``sigma_px^2 (J^T W J)^-1`` at the solution, in (x, y, z, roll, pitch, yaw) units
        m and rad; NaN when the normal matrix is singular.
    mask : (n,) ndarray of bool
        The points used.
    message : str
        Why the iterations stopped.
    """

    T_WC: np.ndarray
    params: np.ndarray
    converged: bool
    iterations: int
    residuals: np.ndarray
    rms_px: float
    sigma_px: float
    cov: np.ndarray
    mask: np.ndarray
    message: str

    residual_rms_px = renamed("residual_rms_px", "rms_px")


def projection_jacobians(camera, T_WC, Wpts) -> np.ndarray:
    """Stacked Jacobians of the projections of many target points, vectorised.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`), or pinhole intrinsics, pixels.
    T_WC : (4, 4) array_like
        Camera pose in the target frame.
    Wpts : (3, n) array_like
        Target points, metres.

    Returns
    -------
    J : (2n, 6) ndarray
        Rows ``2j`` and ``2j + 1`` are ``du_j`` and ``dv_j`` with respect to
        (x, y, z, roll, pitch, yaw); pixels per metre and per radian.

    Raises
    ------
    InputError
        If an argument is malformed or a point is not in front of the camera.
    """
    camera = as_camera(camera)
    T = check_transform(T_WC)
    W = as_points(Wpts, 3, "Wpts")
    p = params_from_T(T)
    _, depth, J = _project(camera, p, W, jacobian=True)
    check_in_front(depth, "T_WC")
    return J


def _project(camera, p, W, jacobian):
    """Projections (2, n), depths (n,) and, if asked, the stacked Jacobian (2n, 6).

    The chain rule: ``p_C = C^T (p_W - t)``, so ``dp_C/dt = -C^T`` and
    ``dp_C/d(angle) = (dC/d(angle))^T (p_W - t)``; then ``d uv / d p_C``: for the pinhole
    ``u = (K p_C)_0 / z_C`` gives ``du/dp_C = (fx, s, cx - u) / z_C`` and
    ``dv/dp_C = (0, fy, cy - v) / z_C`` (written out in the compiled
    :func:`graphpose.pose._gauss_newton.pinhole_residuals`); for a distorting camera it is
    :meth:`graphpose.camera_models.Camera.project_jacobian` (the perspective division, the lens
    model and ``K`` chained), chained by :func:`graphpose.pose._gauss_newton.chain_jacobians`.
    Points at or behind ``z = 0`` give NaN or meaningless pixels: callers check the depths.
    """
    r, z, J = _residual(camera, p, np.zeros((2, W.shape[1])), W, jacobian)
    return -r.reshape(-1, 2).T, z, J


def _residual(camera, p, I, W, jacobian):
    """Measured minus predicted pixels (2n,) stacked ``(u0, v0, u1, ...)``, depths (n,) and,
    if asked, the stacked Jacobian (2n, 6), by the compiled kernels (one call each)."""
    n = W.shape[1]
    p = np.ascontiguousarray(p, dtype=float)
    W = np.ascontiguousarray(W, dtype=float)
    R, A, z = np.empty((4, 3, 3)), np.empty((12, n)), np.empty(n)
    J = np.empty((2 * n, 6)) if jacobian else None
    if isinstance(camera, PinholeCamera):
        r = np.empty(2 * n)
        pinhole_residuals(camera.K, p, np.ascontiguousarray(I, dtype=float), W, R, A, r, z,
                          J if jacobian else _NO_JACOBIAN, jacobian)
        return r, z, J
    camera_points(p, W, R, A)
    z[:] = A[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        uv, G = camera.project_jacobian(A[:3]) if jacobian else (camera.project(A[:3]), None)
    if jacobian:
        chain_jacobians(np.ascontiguousarray(G, dtype=float), R, A, J)
    return (I - uv).T.ravel(), z, J


#: Stands in for the Jacobian when none is asked for.
_NO_JACOBIAN = np.empty((0, 6))


def gauss_newton(Ipts, Wpts, camera, *, guess, mask=None, huber_px=None, pixel_sigma=None,
                 max_iterations: int = MAX_ITERATIONS, tol: float = STEP_TOL, check: bool = True) -> GNResult:
    """Refine a camera pose by damped Gauss-Newton on the reprojection error.

    Parameters
    ----------
    Ipts : (2, n) array_like
        Observed junctions (u, v), pixels; NaN allowed where ``mask`` is False.
    Wpts : (3, n) array_like
        Matching target points, metres.
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`; the points are then raw, distorted
        pixels), or pinhole intrinsics ``K``, pixels.
    guess : (4, 4) array_like
        Starting pose T_WC.
    mask : (n,) array_like of bool, optional
        Points to use (e.g. ``Junctions.trusted``); all by default. At least 4.
    huber_px : float, optional
        If given, a Huber kernel on each point's 2-D reprojection error with this threshold
        in pixels (iteratively reweighted); plain least squares otherwise.
    pixel_sigma : float, optional
        Known pixel noise for the covariance; estimated from the residuals when None.
    max_iterations : int
        Iteration cap.
    tol : float
        Convergence when the undamped step's largest entry is below ``tol`` (m, rad).
    check : bool
        False skips the input checks, for a caller that checked the inputs at its own edge
        (a camera object, float arrays of the right shapes, a boolean mask, a checked guess,
        positive ``huber_px`` and ``pixel_sigma`` or None; the guess's depths are still checked): pytransform3d's
        ``check=False``.

    Returns
    -------
    GNResult
        ``converged`` is False (with ``message``) when the cap was hit or the damped search
        could not lower the cost; the pose is then the best iterate found.

    Raises
    ------
    InputError
        On malformed input (see :func:`graphpose.observations.check_observations`), a malformed guess, a
        non-positive ``huber_px`` or ``pixel_sigma``, or a used point behind the camera at
        the guess.
    """
    if check:
        camera, Ipts, Wpts, mask = check_observations(camera, Ipts, Wpts, mask)
        guess = check_transform(guess, "guess")
        huber_px = None if huber_px is None else check_number("huber_px", huber_px, 0.0, strict=True)
        pixel_sigma = None if pixel_sigma is None else check_number("pixel_sigma", pixel_sigma, 0.0, strict=True)
    return _solve(camera, params_from_T(guess), Ipts, Wpts, mask, huber_px, pixel_sigma, max_iterations, tol)


def stacked_huber_weights(r, huber_px):
    """:func:`huber_weights` of residuals already stacked, as the solvers hold them.

    Shared by this module's Gauss-Newton, the rig's pose fit and the calibration's
    Levenberg-Marquardt solvers (:mod:`graphpose.calibrate.lm`, :mod:`graphpose.calibrate.rig_lm`).

    Parameters
    ----------
    r : (2m,) ndarray
        Residuals in the stacked order ``(u0, v0, u1, v1, ...)``, pixels.
    huber_px : float or None
        Huber threshold on each point's 2-D error norm, pixels; None for no kernel.

    Returns
    -------
    w : (2m,) ndarray or None
        1 up to the threshold, ``huber_px / e`` beyond, each point's weight twice; None
        without a kernel.
    """
    if huber_px is None:
        return None
    e = np.hypot(r[0::2], r[1::2])
    w = np.where(e <= huber_px, 1.0, huber_px / np.maximum(e, 1e-300))
    return np.repeat(w, 2)


def huber_weights(residuals, huber_px) -> np.ndarray:
    """The weight Gauss-Newton gives each residual at a solution, with the Huber kernel.

    Parameters
    ----------
    residuals : (2, m) ndarray
        Measured minus predicted pixels of the used points (trusted: no NaN).
    huber_px : float
        Huber threshold on each point's 2-D error norm, pixels.

    Returns
    -------
    w : (2m,) ndarray
        In the stacked order ``(u0, v0, u1, v1, ...)`` of :func:`projection_jacobians`' rows:
        1 up to the threshold, ``huber_px / e`` beyond.
    """
    return stacked_huber_weights(np.asarray(residuals).T.ravel(), huber_px)


def reprojection_cost(residuals, huber_px=None) -> float:
    """The cost Gauss-Newton minimises, from reprojection residuals.

    Parameters
    ----------
    residuals : (2, m) ndarray
        Measured minus predicted pixels of the used points (trusted: no NaN).
    huber_px : float, optional
        Huber threshold on each point's 2-D error norm, pixels; plain least squares if None.

    Returns
    -------
    float
        ``1/2 sum e_j^2`` (plain), or ``sum rho(e_j)`` with the Huber ``rho``
        (``e^2 / 2`` up to the threshold ``k``, ``k (e - k / 2)`` beyond), pixels squared.
    """
    if huber_px is None:
        return 0.5 * float(np.sum(residuals * residuals))
    e = np.hypot(residuals[0], residuals[1])
    return float(np.sum(np.where(e <= huber_px, 0.5 * e * e, huber_px * (e - 0.5 * huber_px))))


def reprojection_rms(residuals, *, by_junction: bool = False) -> float:
    """The RMS reprojection error, OpenCV's definition: ``sqrt(mean(du^2 + dv^2))``.

    One definition for every RMS graphpose reports (the pose's, the tracker's frames', the
    calibration's): the RMS length of the residual vectors, as ``calibrateCamera`` returns
    it (not the RMS over both coordinates taken apart, which is 1/sqrt(2) of this), so that
    graphpose's figures compare with OpenCV's.

    Parameters
    ----------
    residuals : (2, m) ndarray
        Measured minus predicted pixels of the used points (trusted: no NaN).
    by_junction : bool
        Sum each junction's squared length first, then their mean: the same figure, rounded
        differently in the last bit (the order the calibration's reports have always used, so
        that a report's figures stay reproducible); False sums every coordinate at once.

    Returns
    -------
    float
        Pixels; NaN for no point.
    """
    r = np.asarray(residuals, dtype=float)
    if r.size == 0:
        return float("nan")
    if by_junction:
        return float(np.sqrt(np.mean(np.sum(r * r, axis=0))))
    return float(np.sqrt(np.sum(r * r) / r.shape[1]))


def _cost(r, huber_px):
    """:func:`reprojection_cost` of the stacked residual vector (2m,) ``(u0, v0, u1, ...)``."""
    return reprojection_cost(r.reshape(-1, 2).T, huber_px)


def _compiled_model(camera):
    """(model, coefficients (8,)) of a camera the compiled kernels project
    (:func:`graphpose.pose._gauss_newton.normal_equations`: the pinhole and OpenCV's
    radial-tangential lens, rational model included), or None."""
    if isinstance(camera, PinholeCamera):
        return PINHOLE, _NO_COEFFICIENTS
    if isinstance(camera, RadTanCamera):
        return RADTAN, np.ascontiguousarray(camera.coefficients, dtype=float)
    return None


#: The pinhole's (absent) lens coefficients for the compiled kernels.
_NO_COEFFICIENTS = np.zeros(8)


def _normal(camera, p, I, W, huber_px, compiled=None):
    """At the pose parameters ``p``: the residuals (2m,) stacked ``(u0, v0, u1, ...)``, the depths
    (m,), the cost (:func:`reprojection_cost`), ``chi2 = sum w r^2`` and the weighted normal
    equations ``H = J^T W J`` (6, 6), ``g = J^T W r`` (6,) of a step (``W`` the Huber kernel's
    weights, :func:`huber_weights`; all 1 without it). For a camera the compiled kernels project
    (``compiled``, :func:`_compiled_model`: the pinhole and the radial-tangential lens) one
    compiled call (:func:`graphpose.pose._gauss_newton.normal_equations`) sums them without
    forming the stacked Jacobian; for another lens model, from :func:`_residual`'s."""
    compiled = _compiled_model(camera) if compiled is None else compiled
    if compiled:
        n = W.shape[1]
        r, z, H, g = np.empty(2 * n), np.empty(n), np.empty((6, 6)), np.empty(6)
        cost, chi2 = normal_equations(compiled[0], compiled[1], camera.K, np.ascontiguousarray(p, dtype=float), I, W,
                                      0.0 if huber_px is None else float(huber_px), np.empty((4, 3, 3)),
                                      np.empty((12, n)), r, z, H, g)
        return r, z, cost, chi2, H, g
    r, z, J = _residual(camera, p, I, W, True)
    w = stacked_huber_weights(r, huber_px)
    Jw = J if w is None else J * w[:, None]
    chi2 = float(r @ r) if w is None else float(r @ (w * r))
    return r, z, _cost(r, huber_px), chi2, Jw.T @ J, Jw.T @ r


def _solve(camera, p, Ipts, Wpts, mask, huber_px, pixel_sigma, max_iterations, tol) -> GNResult:
    I, W = np.ascontiguousarray(Ipts[:, mask]), np.ascontiguousarray(Wpts[:, mask])
    compiled = _compiled_model(camera)
    r, depth, cost, chi2, H, g = _normal(camera, p, I, W, huber_px, compiled)
    check_in_front(depth, "the guess", np.flatnonzero(mask))
    if compiled:
        return _compiled_solve(camera, compiled, p, I, W, mask, huber_px, pixel_sigma, max_iterations, tol,
                               (r, depth, cost, chi2, H, g))
    lam, converged, message, it, polish_steps = 0.0, False, "iteration cap reached", 0, 0
    while it < max_iterations:
        it += 1
        # r = measured - predicted, so the step solves H delta = +J^T r = g
        try:
            delta_gn = np.linalg.solve(H, g)
        except np.linalg.LinAlgError:
            message = "normal equations singular (gimbal lock or degenerate points)"
            break
        if np.abs(delta_gn).max() < tol:
            converged, message = True, "converged"
            break
        # When the decrease a step promises (1/2 g^T delta) is below the cost's rounding
        # noise, comparing costs can no longer judge it; the step itself, computed from the
        # gradient, is still accurate (it matters along weakly observed directions), so it
        # is taken undamped as long as the cost does not visibly rise.
        polishing = 0.5 * (g @ delta_gn) <= _COST_RTOL * cost
        if polishing:
            polish_steps += 1
            if polish_steps > _MAX_POLISH_STEPS:
                converged, message = True, "converged (step at the rounding limit)"
                break
        delta = delta_gn if lam == 0.0 or polishing else np.linalg.solve(H + lam * np.diag(np.diag(H)), g)
        p_new = p + delta
        new = _normal(camera, p_new, I, W, huber_px)
        cost_new = new[2] if new[1].min() > MIN_DEPTH else np.inf  # (NaN depths fail too)
        if not np.isfinite(cost_new):
            cost_new = np.inf  # a point the lens model cannot image
        if cost_new < cost or (polishing and cost_new <= cost * (1.0 + 100 * _COST_RTOL)):
            p, (r, _, cost, chi2, H, g) = p_new, new
            lam = 0.0 if lam < 1e-6 else lam / 10.0
        else:
            lam = 1e-4 if lam == 0.0 else lam * 10.0
            if lam > _LAMBDA_MAX:
                message = "damped steps cannot lower the cost"
                break
    return _result(camera, p, I, W, mask, huber_px, pixel_sigma, H, r, chi2, converged, it, message)


#: What the compiled loop's status (:func:`graphpose.pose._gauss_newton.gauss_newton_loop`) means:
#: (converged, message).
_STATUS = {0: (False, "iteration cap reached"), 1: (True, "converged"),
           2: (True, "converged (step at the rounding limit)"),
           3: (False, "normal equations singular (gimbal lock or degenerate points)"),
           4: (False, "damped steps cannot lower the cost")}


def _compiled_solve(camera, compiled, p, I, W, mask, huber_px, pixel_sigma, max_iterations, tol, start) -> GNResult:
    """:func:`_solve`'s loop for a camera the compiled kernels project (``compiled``,
    :func:`_compiled_model`), in one compiled call with the same rules
    (:func:`graphpose.pose._gauss_newton.gauss_newton_loop`): ``start`` is the normal
    equations at ``p``."""
    r, z, cost, chi2, H, g = start
    n = W.shape[1]
    p = np.array(p, dtype=float)
    status, it, cost, chi2 = gauss_newton_loop(
        compiled[0], compiled[1], camera.K, p, I, W, 0.0 if huber_px is None else float(huber_px), cost, chi2, np.empty((4, 3, 3)),
        np.empty((12, n)), r, z, H, g, np.empty(2 * n), np.empty(n), np.empty((6, 6)), np.empty(6), float(tol),
        int(max_iterations), MIN_DEPTH, _COST_RTOL, _MAX_POLISH_STEPS, _LAMBDA_MAX)
    if status == 5:
        raise np.linalg.LinAlgError("Singular matrix")  # as numpy.linalg.solve on the damped system
    converged, message = _STATUS[status]
    return _result(camera, p, I, W, mask, huber_px, pixel_sigma, H, r, chi2, converged, it, message)


def _result(camera, p, I, W, mask, huber_px, pixel_sigma, H, r, chi2, converged, it, message) -> GNResult:
    """The result at ``p`` from its residuals, ``chi2`` and normal matrix (of the used points
    ``I``, ``W``)."""
    T = T_from_params(p)
    params = params_from_T(T)  # angles back into their principal ranges
    if np.max(np.abs(params - p)) > 1e-9:
        # Same pose, but the covariance belongs to the parameters it is reported in.
        r, _, _, chi2, H, _ = _normal(camera, params, I, W, huber_px)
    m = W.shape[1]
    residuals = np.full((2, mask.size), np.nan)
    residuals[:, mask] = r.reshape(m, 2).T
    sigma = np.sqrt(chi2 / (2 * m - 6)) if pixel_sigma is None else float(pixel_sigma)
    try:
        cov = sigma**2 * np.linalg.inv(H)
    except np.linalg.LinAlgError:
        cov = np.full((6, 6), np.nan)
    return GNResult(
        T_WC=T,
        params=params,
        converged=bool(converged),
        iterations=it,
        residuals=residuals,
        rms_px=reprojection_rms(residuals[:, mask]),
        sigma_px=float(sigma),
        cov=cov,
        mask=mask.copy(),
        message=message,
    )

"""The calibration's cross-check: a hand-written Levenberg-Marquardt over the same cost.

Unknowns: the intrinsic parameters ``p`` (the camera's ``parameter_names``) and
each view's pose as ``(x, y, z, roll, pitch, yaw)`` (:mod:`graphpose.geometry`). The cost is
the one of :mod:`.graph`: ``sum_j rho(||r_j||)`` over the junctions, ``r_j`` the raw pixel
residual, ``rho`` the Huber function of threshold ``huber_px`` (``e^2 / 2`` without one).
Each step solves the dense normal equations with the exact analytic Jacobian: in ``p`` from
the camera's ``parameter_jacobian``, in the pose from
:mod:`graphpose.pose.gauss_newton` (the chain of the Euler angles' partials with the camera's
``d uv / d p_C``). Huber weights are reweighted at every step (iteratively reweighted least
squares, which lowers the Huber cost at each accepted step). The plain Gauss-Newton step is
tried first; a step that raises the cost is damped (``H + lambda diag(H)``) until it falls.

It stops when every unknown's Gauss-Newton step is below 1e-10 of its own standard deviation
(``sqrt(diag(H^-1))`` at unit pixel noise): a rule in the parameters' own scale, which does
not depend on the cost's last bits. Near the minimum the decrease a step promises
(``g . delta / 2``) falls below the cost's rounding (:func:`_rounding`: each residual is a
difference of pixels of a few hundred, so its last bits move the cost by about
``eps sum_j |rho'(r_j)| |uv_j|``), and comparing costs can no longer judge a step; the step
itself, from the gradient, is still accurate, so it is taken undamped as long as the cost
does not rise beyond that rounding. Where even so the step stays above 1e-10 of a sigma after
60 such steps, or no damped step lowers the cost, it has converged if the step is below 1e-6
of every sigma, and failed otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import T_from_params, params_from_T
from ..errors import InputError
from ..pose.gauss_newton import camera_points, chain_jacobians, reprojection_cost, stacked_huber_weights

MAX_ITERATIONS = 200
#: Weak priors (mrcal's regularisation) per model: the parameters' indices and the prior's
#: sigma (unitless), mean 0. The rational model's numerator and denominator nearly cancel
#: along one direction (k1..k3 against k4..k6 with the same sign): without it the normal
#: equations are near-singular on 13 real views and on 20 rendered ones (sigma of k1 about
#: 50). The sigma is 0.1: on OpenCV's 13 left samples with the board warp, a sigma of 1 lowers
#: the RMS only from 0.1512 to 0.1511 px while k1..k6 swing to +-0.5 along that direction.
PRIORS = {"rational": (np.array([4, 5, 8, 9, 10, 11]), 0.1)}
#: Convergence: the step below this many of each parameter's standard deviations.
STEP_SIGMAS = 1e-10
#: ... or, where the steps at the cost's rounding do not get there, below this many.
ROUNDING_SIGMAS = 1e-6
#: Roundings per residual in the cost's rounding (:func:`_rounding`): the prediction's few
#: operations on pixels of the image's size.
_ROUNDINGS = 4.0
_MAX_POLISH_STEPS = 60
_LAMBDA_MAX = 1e12


@dataclass(frozen=True)
class LMCalibration:
    """The hand-written solver's solution.

    Attributes
    ----------
    camera : Camera
        The calibrated camera.
    poses : list of (4, 4) ndarray
        ``T_WC`` per view.
    information : (P, P) ndarray
        The intrinsics' information at unit pixel noise: the Schur complement of the poses
        in ``J^T W J`` (``W`` the Huber weights); its inverse is the intrinsics' block of
        ``(J^T W J)^-1``.
    residuals : list of (2, m) ndarray
        Measured minus predicted pixels per view.
    weights : list of (m,) ndarray
        The Huber weight of each junction (1 without a kernel).
    converged : bool
    iterations : int
    message : str
    warp : (2,) ndarray or None
        The board warp ``(w_x, w_y)``, metres, where it was estimated.
    """

    camera: object
    poses: list
    information: np.ndarray
    residuals: list
    weights: list
    converged: bool
    iterations: int
    message: str
    warp: np.ndarray | None = None


def _evaluate(camera, x, observations, P, bases=None):
    """Per view: residuals (2m,), the Jacobians in the intrinsics (2m, P) and the pose
    (2m, 6); and the smallest depth.

    The chain of :func:`graphpose.pose.gauss_newton._project` (its compiled kernels), with every view's points
    projected in one call of the camera and of the intrinsics' Jacobian (per view, the
    calls' overhead was most of a calibration's solve time with 40 views).

    With ``bases`` (per view the board warp's shapes (2, m) at its junctions,
    :meth:`graphpose.board.Board.warp_basis`) the two entries after the camera's ``P`` in
    ``x`` are the board warp ``(w_x, w_y)`` (metres): each junction's target point moves by
    ``w . b`` along the target's z, and the "intrinsics" Jacobian (2m, P + 2) gains the
    warp's columns, ``d uv / d p_C  C^T e_z  b`` (``p_C = C^T (W - t)``).
    """
    nw = 0 if bases is None else 2
    warp = x[P: P + nw]
    G0 = P + nw
    rotations, chains = [], []
    for i, (_, W, _) in enumerate(observations):
        W = np.array(W, dtype=float)
        if nw:
            W[2] += warp @ bases[i]
        # R (4, 3, 3): C and its partials by the angles; rows 0-2 of A (12, m): p_C, rows
        # 3k+3 .. 3k+5: its derivative by angle k (the pose's compiled kernel).
        R, Ai = np.empty((4, 3, 3)), np.empty((12, W.shape[1]))
        camera_points(np.ascontiguousarray(x[G0 + 6 * i: G0 + 6 * i + 6]), np.ascontiguousarray(W), R, Ai)
        rotations.append(R)
        chains.append(Ai)
    A = np.hstack(chains)
    with np.errstate(divide="ignore", invalid="ignore"):
        pred, G = camera.project_jacobian(A[:3])
        Jp = camera.parameter_jacobian(A[:3])
    G = np.ascontiguousarray(G, dtype=float)
    out, at = [], 0
    for i, ((uv, _, _), R, Ai) in enumerate(zip(observations, rotations, chains)):
        m = Ai.shape[1]
        Je = np.empty((2 * m, 6))
        chain_jacobians(G[at: at + m], R, Ai, Je)
        Ji = Jp[at: at + m]
        if nw:
            dz = G[at: at + m] @ R[0][2]  # (m, 2): d uv / d W_z, W_z moving p_C by C^T e_z
            Ji = np.concatenate([Ji, dz[:, :, None] * bases[i].T[:, None, :]], axis=2)
        out.append(((uv - pred[:, at: at + m]).T.ravel(), Ji.reshape(2 * m, G0), Je))
        at += m
    return out, float(np.min(A[2]))


def _cost(views, huber_px):
    return reprojection_cost(np.concatenate([r for r, _, _ in views]).reshape(-1, 2).T, huber_px)


def _rounding(views, scale, huber_px) -> float:
    """The cost's rounding: how far the last bits of the residuals can move it.

    Each residual ``r = uv - predicted`` is the difference of two pixels of about ``scale``
    (2M,) (the measured ones' magnitudes), so its rounding is a few ``eps |uv|``, and the cost
    moves by ``rho'`` times that: ``_ROUNDINGS eps sum |w r| |uv|`` (``w r = rho'(r)``, the
    Huber weights ``w``). A bound, not an estimate: the roundings do not all add up.
    """
    r = np.concatenate([r for r, _, _ in views])
    w = stacked_huber_weights(r, huber_px)
    return float(_ROUNDINGS * np.finfo(float).eps * np.sum(np.abs(r if w is None else w * r) * scale))


def _normal(views, huber_px, P):
    """The normal equations by blocks: U (P, P), V (n, 6, 6), Wb (n, P, 6), gp (P,), ge (n, 6)."""
    n = len(views)
    U, gp = np.zeros((P, P)), np.zeros(P)
    V, Wb, ge = np.empty((n, 6, 6)), np.empty((n, P, 6)), np.empty((n, 6))
    for i, (r, Jp, Je) in enumerate(views):
        w = stacked_huber_weights(r, huber_px)
        wr = r if w is None else w * r
        Jpw = Jp if w is None else Jp * w[:, None]
        U += Jpw.T @ Jp
        gp += Jp.T @ wr
        V[i] = (Je if w is None else Je * w[:, None]).T @ Je
        Wb[i] = Jpw.T @ Je
        ge[i] = Je.T @ wr
    return U, V, Wb, gp, ge


def _step(U, V, Wb, gp, ge, lam):
    """The (damped) step by the Schur complement of the poses; the complement S; and the
    standard deviations of every unknown at unit pixel noise (undamped only)."""
    if lam:
        U = U + lam * np.diag(np.diag(U))
        V = V + lam * np.einsum("ij,nj->nij", np.eye(6), np.diagonal(V, axis1=1, axis2=2))
    Vi = np.linalg.inv(V)
    WVi = Wb @ Vi  # (n, P, 6)
    S = U - np.einsum("nij,nkj->ik", WVi, Wb)
    b = gp - np.einsum("nij,nj->i", WVi, ge)
    dp = np.linalg.solve(S, b)
    de = np.einsum("nij,nj->ni", Vi, ge - np.einsum("nij,i->nj", Wb, dp))
    Si = np.linalg.inv(S)
    # Pose block of the inverse: Vi + Vi W^T S^-1 W Vi.
    pose_var = np.diagonal(Vi, axis1=1, axis2=2) + np.einsum("nij,ik,nkj->nj", WVi, Si, WVi)
    sd = np.sqrt(np.abs(np.concatenate([np.diag(Si), pose_var.ravel()])))
    return np.concatenate([dp, de.ravel()]), S, sd


def _hold(blocks, held):
    """The normal equations ``blocks`` (:func:`_normal`) with the ``held`` parameters (a (P,)
    bool mask, or None) out of them: their rows and columns zero but a unit diagonal, their
    gradient zero, so that every step leaves them where they are."""
    if held is None or not np.any(held):
        return blocks
    U, V, Wb, gp, ge = blocks
    U, Wb, gp = U.copy(), Wb.copy(), gp.copy()
    U[held, :], U[:, held], gp[held], Wb[:, held, :] = 0.0, 0.0, 0.0, 0.0
    U[held, held] = 1.0
    return U, V, Wb, gp, ge


def prior_terms(camera, p, prior_px):
    """The model's weak prior (:data:`PRIORS`) at parameters ``p``: its cost, and its
    information and gradient to add to ``U`` and ``gp`` (zeros without one); the prior's
    residual ``-p_i / sigma`` is in units of the pixel noise ``prior_px``, so that it weighs
    alike in the pixel-unit cost here and in GTSAM's whitened one."""
    P = p.size
    info, grad = np.zeros((P, P)), np.zeros(P)
    if prior_px is None or camera.model not in PRIORS:
        return 0.0, info, grad
    index, sigma = PRIORS[camera.model]
    w = (prior_px / sigma) ** 2
    info[index, index] = w
    grad[index] = -w * p[index]
    return float(0.5 * w * np.sum(p[index] ** 2)), info, grad


def solve_lm(camera, poses, observations, huber_px=None, max_iterations: int = MAX_ITERATIONS,
             prior_px=None, *, held=None, bases=None, warp=None) -> LMCalibration:
    """Calibrate by the hand-written Levenberg-Marquardt from a start.

    Parameters
    ----------
    camera : Camera
        The starting camera (model, size and what is not a parameter are kept).
    poses : list of (4, 4) ndarray
        Starting ``T_WC`` per view.
    observations : list of (uv (2, m), W (3, m), index (m,))
        Each view's used junctions.
    huber_px : float, optional
        Huber threshold on each junction's 2-D error, pixels.
    max_iterations : int
        Steps tried (accepted or not).
    prior_px : float, optional
        The pixel noise the model's weak prior (:func:`prior_terms`) is scaled by; None: no
        prior.
    held : (P,) array_like of bool, optional
        Parameters held at the start's value, not estimated (``radtan4``'s k3 at 0,
        :func:`graphpose.camera_models.calibration_model`); their information rows are zero.
    bases : list of (2, m) ndarray, optional
        Per view the board warp's shapes at its junctions
        (:meth:`graphpose.board.Board.warp_basis` of ``W``): the board warp ``(w_x, w_y)``
        is estimated with the intrinsics (:func:`_evaluate`); None: a flat board.
    warp : (2,) array_like, optional
        The warp's start, metres (zeros by default); only with ``bases``.

    Returns
    -------
    LMCalibration
        With ``bases``, ``information`` is over the intrinsics and the warp (P + 2).
    """
    P = camera.parameters.size
    nw = 0 if bases is None else 2
    G0 = P + nw
    held = None if held is None else np.r_[np.asarray(held, dtype=bool), np.zeros(nw, bool)]
    w0 = np.zeros(nw) if warp is None or not nw else np.asarray(warp, float)
    x = np.concatenate([camera.parameters, w0] + [params_from_T(T) for T in poses])
    views, _ = _evaluate(camera, x, observations, P, bases)

    def prior(camera, x):
        c, info, grad = prior_terms(camera, x[:P], prior_px)
        if not nw:
            return c, info, grad
        info2, grad2 = np.zeros((G0, G0)), np.zeros(G0)
        info2[:P, :P], grad2[:P] = info, grad
        return c, info2, grad2

    cost = _cost(views, huber_px) + prior(camera, x)[0]

    def normal(views, camera, x):
        blocks = _normal(views, huber_px, G0)
        _, info, grad = prior(camera, x)
        return _hold((blocks[0] + info, blocks[1], blocks[2], blocks[3] + grad, blocks[4]), held)

    def trial(camera, x_new):
        moved = camera.with_parameters(x_new[:P])  # InputError: a focal length <= 0
        views_new, z_new = _evaluate(moved, x_new, observations, P, bases)
        cost_new = (_cost(views_new, huber_px) + prior(moved, x_new)[0]
                    if z_new > 0 else np.inf)
        return moved, views_new, cost_new

    x, camera, views, S, converged, it, message = levenberg_marquardt(
        x, camera, views, cost, normal, trial, observed_scale(uv for uv, _, _ in observations), huber_px,
        max_iterations, np.full((G0, G0), np.nan), "the views do not constrain the calibration")
    residuals, weights = residuals_and_weights(views, huber_px)
    poses = [T_from_params(x[G0 + 6 * i: G0 + 6 * i + 6]) for i in range(len(observations))]
    if held is not None and np.any(held):
        S = S.copy()
        S[held, :], S[:, held] = 0.0, 0.0  # no information: a held parameter is not estimated
    return LMCalibration(camera, poses, S, residuals, weights, converged, it, message,
                         x[P:G0].copy() if nw else None)


def observed_scale(uvs) -> np.ndarray:
    """The measured pixels' magnitudes (2M,), interleaved per junction as the residuals are:
    the scale of :func:`_rounding`'s bound, from each observation's ``uv`` (2, m)."""
    return np.concatenate([np.abs(uv).T.ravel() for uv in uvs])


def residuals_and_weights(views, huber_px):
    """Each view's residuals (2, m) and its junctions' Huber weights (m,) (ones without a
    kernel), from the stacked residuals (2m,) that start each entry of ``views``."""
    residuals, weights = [], []
    for r, *_ in views:
        m = r.size // 2
        w = stacked_huber_weights(r, huber_px)
        residuals.append(r.reshape(m, 2).T)
        weights.append(np.ones(m) if w is None else w[0::2].copy())
    return residuals, weights


def levenberg_marquardt(x, state, views, cost, normal, trial, scale, huber_px, max_iterations, S, singular):
    """The Levenberg-Marquardt loop of both hand-written calibrations (one camera,
    :func:`solve_lm`; a rig, :func:`graphpose.calibrate.rig_lm.solve_rig_lm`): undamped
    Gauss-Newton steps while they lower the cost, damped ones (lambda x 10 each failure, / 10
    each success) when not, the pose blocks eliminated by :func:`_step`.

    It stops when the undamped step is below :data:`STEP_SIGMAS` of every unknown's sigma
    (converged), or, where the cost's rounding (:func:`_rounding`) hides any further descent,
    when the steps at the rounding stay below :data:`ROUNDING_SIGMAS` (converged) or do not.

    Parameters
    ----------
    x : (N,) ndarray
        The start: the problem's parameters, then every view's pose (6 each).
    state : object
        The camera (or cameras) at ``x``, handed to ``normal`` and ``trial``.
    views : list
        Each observation's ``(r (2m,), ...)`` at ``x`` (its residuals first), for ``normal``.
    cost : float
        The cost at ``x``.
    normal : callable
        ``normal(views, state, x) -> (U, V, Wb, gp, ge)``: the normal equations by blocks.
    trial : callable
        ``trial(state, x_new) -> (state_new, views_new, cost_new)``; ``cost_new`` inf, or an
        InputError raised, where ``x_new`` is no camera or puts a junction behind one.
    scale : (2M,) ndarray
        :func:`observed_scale` of the observations.
    huber_px : float or None
        The Huber threshold, pixels.
    max_iterations : int
        Steps tried (accepted or not).
    S : ndarray
        The Schur complement returned when no step is solved (NaN of its shape).
    singular : str
        What a singular system means, for the message.

    Returns
    -------
    x, state, views
        Where it ended.
    S : ndarray
        The last undamped system's Schur complement (the parameters' information).
    converged : bool
    iterations : int
    message : str
    """
    lam, converged, message, it, polish = 0.0, False, "iteration cap reached", 0, 0
    while it < max_iterations:
        it += 1
        blocks = normal(views, state, x)
        try:
            delta_gn, S, sd = _step(*blocks, 0.0)
        except np.linalg.LinAlgError:
            message = f"normal equations singular ({singular})"
            break
        if np.all(np.abs(delta_gn) <= STEP_SIGMAS * sd):
            converged, message = True, "converged"
            break
        g = np.concatenate([blocks[3], blocks[4].ravel()])
        rounding = _rounding(views, scale, huber_px)
        polishing = 0.5 * (g @ delta_gn) <= rounding
        if polishing:
            polish += 1
            if polish > _MAX_POLISH_STEPS:
                converged, message = _at_rounding(delta_gn, sd, "converged (step at the rounding limit)",
                                                  "the steps at the cost's rounding do not converge")
                break
        try:
            delta = delta_gn if lam == 0.0 or polishing else _step(*blocks, lam)[0]
        except np.linalg.LinAlgError:
            message = "damped normal equations singular"
            break
        x_new = x + delta
        try:
            state_new, views_new, cost_new = trial(state, x_new)
        except InputError:
            cost_new = np.inf
        if not np.isfinite(cost_new):
            cost_new = np.inf
        if cost_new < cost or (polishing and cost_new <= cost + rounding):
            x, views, cost, state = x_new, views_new, cost_new, state_new
            lam = 0.0 if lam < 1e-6 else lam / 10.0
        else:
            lam = 1e-4 if lam == 0.0 else lam * 10.0
            if lam > _LAMBDA_MAX:
                # At the cost's rounding no step can lower it.
                converged, message = _at_rounding(delta_gn, sd, "converged (at the cost's rounding)",
                                                  "damped steps cannot lower the cost")
                break
    return x, state, views, S, converged, it, message


def _at_rounding(delta_gn, sd, yes: str, no: str):
    """Where the cost's rounding stops the descent: converged (and ``yes``) if the undamped
    step is already far below every unknown's sigma (:data:`ROUNDING_SIGMAS`), else ``no``."""
    converged = bool(np.all(np.abs(delta_gn) <= ROUNDING_SIGMAS * sd))
    return converged, yes if converged else no

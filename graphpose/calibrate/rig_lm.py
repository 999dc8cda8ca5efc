"""The rig calibration's cross-check: a hand-written Levenberg-Marquardt over the rig's cost.

Unknowns, in this order: every camera's intrinsic parameters ``p_c``
(the camera's ``parameter_names``), every further camera's extrinsics ``e_c``
(``T_C0_C[c]`` as ``(x, y, z, roll, pitch, yaw)``, :mod:`graphpose.geometry`) and every view's
rig pose ``q_v`` (``T_WC0``, the same six). A junction seen by camera c in view v is predicted
at ``project_c(T_C0_C[c]^-1 T_WC0^-1 P_W)``; the cost is the one of :mod:`.rig_graph`,
``sum_j rho(||r_j||)`` over every (view, camera, junction), ``rho`` Huber's of threshold
``huber_px`` (``e^2 / 2`` without one). The Jacobian is analytic (the camera's ``d uv / d P``,
the camera's ``parameter_jacobian``, and the Euler angles'
partials, :func:`graphpose.pose.rig.rig_points`'s chain, taken for every view of a camera
at once) and
the normal equations solved by the Schur complement of the views' poses (:func:`.lm._step`). Stopping and damping are
those of :mod:`.lm`: the step below 1e-10 of every unknown's sigma, the cost's rounding
judged as there. The steps take the Huber cost's own Gauss-Newton Hessian (no curvature
along a far junction's residual, :func:`_huber_rows`), which converges in a few steps where
the weighted normal matrix crawls; the covariance is the weighted normal matrix's, as before.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import T_from_params, hat, params_from_T
from ..pose.gauss_newton import stacked_huber_weights
from .rig_graph import RigGraph
from .lm import MAX_ITERATIONS, _cost, _step, levenberg_marquardt, observed_scale, residuals_and_weights



@dataclass(frozen=True)
class RigLM(RigGraph):
    """The hand-written solver's solution: the graph's fields (:class:`.rig_graph.RigGraph`;
    ``cov`` here ``(J^T W J)^-1`` of the intrinsics and extrinsics, the views' poses
    marginalised, at unit pixel noise) and the residuals.

    Attributes
    ----------
    residuals : list of (2, m) ndarray
        Measured minus predicted pixels per observation.
    weights : list of (m,) ndarray
        Huber weight of each junction.
    """

    residuals: list
    weights: list


def _layout(cameras, n_views):
    """Offsets: each camera's intrinsics, each further camera's extrinsics, each view's pose."""
    sizes = [c.parameters.size for c in cameras]
    starts = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
    P = int(starts[-1])
    ext = {c: P + 6 * (c - 1) for c in range(1, len(cameras))}
    view0 = P + 6 * (len(cameras) - 1)
    return starts, ext, view0, view0 + 6 * n_views


def _rotations(rpy):
    """``C = Cz(yaw) Cy(pitch) Cx(roll)`` of n angle triples (n, 3) and its partials by the
    three angles: (n, 3, 3) and (n, 3, 3, 3) (:func:`graphpose.pose.rig.rotation_and_partials`,
    all at once)."""
    n = rpy.shape[0]
    c, s = np.cos(rpy), np.sin(rpy)
    one, zero = np.ones(n), np.zeros(n)
    Cx = np.stack([one, zero, zero, zero, c[:, 0], -s[:, 0], zero, s[:, 0], c[:, 0]], axis=1).reshape(n, 3, 3)
    Cy = np.stack([c[:, 1], zero, s[:, 1], zero, one, zero, -s[:, 1], zero, c[:, 1]], axis=1).reshape(n, 3, 3)
    Cz = np.stack([c[:, 2], -s[:, 2], zero, s[:, 2], c[:, 2], zero, zero, zero, one], axis=1).reshape(n, 3, 3)
    CzCy = Cz @ Cy
    C = CzCy @ Cx
    E = np.eye(3)
    dC = np.stack([C @ hat(E[0]), CzCy @ hat(E[1]) @ Cx, hat(E[2]) @ C], axis=1)
    return C, dC


def _plan(obs):
    """Per camera: its observations' indices, their board points side by side (3, M_c), each
    junction's view, and each observation's columns among them."""
    plan = {}
    for c in sorted({o[1] for o in obs}):
        mine = [k for k, o in enumerate(obs) if o[1] == c]
        W = np.hstack([np.asarray(obs[k][3], dtype=float) for k in mine])
        views = np.concatenate([np.full(obs[k][3].shape[1], obs[k][0]) for k in mine])
        at = np.concatenate([[0], np.cumsum([obs[k][3].shape[1] for k in mine])]).astype(int)
        plan[c] = (mine, W, views, at)
    return plan


def _camera_points(x, c, W, views, ext, view0):
    """Camera c's points (3, M) over all its views, their derivatives (M, 3, 6) by each
    junction's view pose and (M, 3, 6) by camera c's extrinsics (None for camera 0): the
    chain of :func:`graphpose.pose.rig.rig_points`, for every view at once."""
    Q = x[view0:].reshape(-1, 6)
    C, dC = _rotations(Q[:, 3:])
    Cj = C[views]
    D = W - Q[views, :3].T
    p0 = np.einsum("mki,km->im", Cj, D)
    m = W.shape[1]
    Jq = np.empty((m, 3, 6))
    Jq[:, :, :3] = -Cj.transpose(0, 2, 1)
    Jq[:, :, 3:] = np.einsum("mkji,jm->mik", dC[views], D)
    if not c:
        return p0, Jq, None
    e = x[ext[c]: ext[c] + 6]
    Ce, dCe = _rotations(e[None, 3:])
    Ce, dCe = Ce[0], dCe[0]
    De = p0 - e[:3, None]
    Je = np.empty((m, 3, 6))
    Je[:, :, :3] = -Ce.T
    Je[:, :, 3:] = np.einsum("kji,jm->mik", dCe, De)
    return Ce.T @ De, np.einsum("ji,mjk->mik", Ce, Jq), Je


def _evaluate(cameras, x, obs, layout, plan):
    """Per observation: residuals (2m,) interleaved per junction, the prediction's Jacobian
    in the rig's columns ``cols`` (2m, len(cols)) and in its view's pose (2m, 6); and the
    smallest depth. Each camera's points, projection and Jacobians over all its views at
    once (per view, the calls' overhead was most of the time)."""
    starts, ext, view0, N = layout
    out = [None] * len(obs)
    depth = np.inf
    for c, (mine, W, views, at) in plan.items():
        camera = cameras[c]
        P, Jq, Je = _camera_points(x, c, W, views, ext, view0)
        depth = min(depth, float(np.min(P[2])))
        with np.errstate(divide="ignore", invalid="ignore"):
            pred, G = camera.project_jacobian(P)
            Jp = camera.parameter_jacobian(P)
        GJq = G @ Jq
        Jr = Jp if Je is None else np.concatenate([Jp, G @ Je], axis=2)
        for i, k in enumerate(mine):
            a, b = at[i], at[i + 1]
            m = b - a
            out[k] = ((obs[k][2] - pred[:, a:b]).T.ravel(), Jr[a:b].reshape(2 * m, -1), GJq[a:b].reshape(2 * m, 6))
    return out, depth


def _columns(layout, obs):
    """Each observation's columns among the rig's parameters: its camera's intrinsics, then
    its extrinsics (cameras >= 1)."""
    starts, ext, _, _ = layout
    return [np.r_[starts[c]: starts[c + 1], ext[c]: ext[c] + 6] if c else np.arange(starts[0], starts[1])
            for _, c, _, _ in obs]


def _huber_rows(r, huber_px):
    """The rows that give a Huber cost's Gauss-Newton Hessian: each junction's ``sqrt(w) (I -
    u u^T)`` beyond the threshold (``u`` its residual's direction, ``w = huber_px / |r|``),
    the identity within; as (m,) factors along ``u`` and across it, None without a kernel or
    a junction beyond.

    ``rho(|r|)`` has the curvature ``w`` across the residual and none along it beyond the
    threshold, so that ``J^T diag(w) J`` (the weighted normal matrix, iteratively reweighted
    least squares) overstates the curvature along every far junction's residual by ``w``: its
    steps fall short, and the solve converges linearly (a step of ~0.6 of the last near the
    end: 34 steps on OpenCV's pair, 6 with the exact curvature). The gradient is ``J^T w r``
    either way, so that both land on the same minimum.
    """
    if huber_px is None:
        return None
    m = r.size // 2
    R = r.reshape(m, 2)
    a = np.hypot(R[:, 0], R[:, 1])
    far = a > huber_px
    if not far.any():
        return None
    safe = np.where(far, a, 1.0)
    return R / safe[:, None], far, np.sqrt(np.where(far, huber_px / safe, 1.0))


def _curvature_rows(J, rows):
    """``J`` (2m, n) with each far junction's two rows taken to ``sqrt(w) (I - u u^T) J``."""
    if rows is None:
        return J
    u, far, root = rows
    Jm = J.reshape(u.shape[0], 2, -1)
    along = np.einsum("mi,min->mn", u, Jm)
    out = Jm - np.where(far[:, None, None], u[:, :, None] * along[:, None, :], 0.0)
    return (out * root[:, None, None]).reshape(J.shape)


def _normal(views, obs, cols, n_rig, n_views, huber_px, exact=True):
    """The normal equations by blocks (:func:`.lm._step`'s form): U (n_rig, n_rig),
    V (n, 6, 6), Wb (n, n_rig, 6), gp (n_rig,), ge (n, 6). ``exact``: the Huber cost's own
    Gauss-Newton Hessian (:func:`_huber_rows`), for the steps; else the weighted normal
    matrix ``J^T diag(w) J``, for the covariance (as :mod:`.lm`'s and GTSAM's marginal)."""
    U, gp = np.zeros((n_rig, n_rig)), np.zeros(n_rig)
    V, Wb, ge = np.zeros((n_views, 6, 6)), np.zeros((n_views, n_rig, 6)), np.zeros((n_views, 6))
    for (r, Jr, Jq), (v, _, _, _), k in zip(views, obs, cols):
        w = stacked_huber_weights(r, huber_px)
        wr = r if w is None else w * r
        gp[k] += Jr.T @ wr
        ge[v] += Jq.T @ wr
        if w is not None and exact:
            rows = _huber_rows(r, huber_px)
            Jr_h, Jq_h = _curvature_rows(Jr, rows), _curvature_rows(Jq, rows)
            Jr_w, Jq_w = Jr_h, Jq_h
        else:
            Jr_h, Jq_h = Jr, Jq
            Jr_w, Jq_w = (Jr, Jq) if w is None else (Jr * w[:, None], Jq * w[:, None])
        U[np.ix_(k, k)] += Jr_w.T @ Jr_h
        V[v] += Jq_w.T @ Jq_h
        Wb[v][k] += Jr_w.T @ Jq_h
    return U, V, Wb, gp, ge


def _cameras(templates, x, starts):
    return [t.with_parameters(x[starts[c]: starts[c + 1]]) for c, t in enumerate(templates)]


def solve_rig_lm(cameras, T_C0_C, poses, observations, huber_px=None,
                 max_iterations: int = MAX_ITERATIONS, exact_curvature: bool = True) -> RigLM:
    """Calibrate the rig by the hand-written Levenberg-Marquardt from a start.

    Parameters
    ----------
    cameras, T_C0_C, poses, observations
        The start and the junctions, as :func:`graphpose.calibrate.rig_graph.solve_rig_graph`
        takes them.
    huber_px : float, optional
        Huber threshold on each junction's 2-D error, pixels.
    max_iterations : int
    exact_curvature : bool
        Steps by the Huber cost's own Gauss-Newton Hessian (:func:`_huber_rows`; a few steps
        to converge), or by the weighted normal matrix (iteratively reweighted least squares,
        which converges linearly: what a screening solve of a few steps is defined by).

    Returns
    -------
    RigLM
    """
    layout = _layout(cameras, len(poses))
    starts, ext, view0, N = layout
    cols = _columns(layout, observations)
    x = np.concatenate([c.parameters for c in cameras]
                       + [params_from_T(T) for T in T_C0_C[1:]] + [params_from_T(T) for T in poses])
    plan = _plan(observations)
    views, _ = _evaluate(cameras, x, observations, layout, plan)

    def normal(views, cameras, x):
        return _normal(views, observations, cols, view0, len(poses), huber_px, exact=exact_curvature)

    def trial(cameras, x_new):
        moved = _cameras(cameras, x_new, starts)
        views_new, z = _evaluate(moved, x_new, observations, layout, plan)
        return moved, views_new, _cost(views_new, huber_px) if z > 0 else np.inf

    x, cameras, views, S, converged, it, message = levenberg_marquardt(
        x, cameras, views, _cost(views, huber_px), normal, trial, observed_scale(uv for _, _, uv, _ in observations),
        huber_px, max_iterations, np.full((view0, view0), np.nan), "the views do not constrain the rig")
    residuals, weights = residuals_and_weights(views, huber_px)
    if exact_curvature and huber_px is not None and np.all(np.isfinite(S)):
        # The covariance from the weighted normal matrix at the solution (the steps' exact
        # Huber curvature is not what the calibration's covariance is built on).
        try:
            S = _step(*_normal(views, observations, cols, view0, len(poses), huber_px, exact=False), 0.0)[1]
        except np.linalg.LinAlgError:
            S = np.full_like(S, np.nan)
    try:
        cov = np.linalg.inv(S)
    except np.linalg.LinAlgError:
        cov = np.full_like(S, np.nan)
    T_out = [np.eye(4)] + [T_from_params(x[ext[c]: ext[c] + 6]) for c in range(1, len(cameras))]
    poses = [T_from_params(x[view0 + 6 * v: view0 + 6 * v + 6]) for v in range(len(poses))]
    return RigLM(list(cameras), T_out, poses, cov, converged, it, message, residuals=residuals, weights=weights)

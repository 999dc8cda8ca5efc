"""The rig calibration's cross-check: a hand-written Levenberg-Marquardt over the rig's cost.

Unknowns, in this order: every camera's intrinsic parameters ``p_c``
(the camera's ``parameter_names``), every further camera's extrinsics ``e_c``
(``T_C0_C[c]`` as ``(x, y, z, roll, pitch, yaw)``, :mod:`graphpose.geometry`) and every view's
rig pose ``q_v`` (``T_WC0``, the same six). A junction seen by camera c in view v is predicted
at ``project_c(T_C0_C[c]^-1 T_WC0^-1 P_W)``; the cost is the one of :mod:`.rig_graph`,
``sum_j rho(||r_j||)`` over every (view, camera, junction), ``rho`` Huber's of threshold
``huber_px`` (``e^2 / 2`` without one). The Jacobian is analytic (the camera's ``d uv / d P``,
the camera's ``parameter_jacobian``, and the Euler angles'
partials, :func:`graphpose.pose.rig.rig_points`) and
the normal equations solved by the Schur complement of the views' poses (:func:`.lm._step`). Stopping and damping are
those of :mod:`.lm`: the step below 1e-10 of every unknown's sigma, the cost's rounding
judged as there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import T_from_params, params_from_T
from ..pose.rig import rig_points
from ..pose.gauss_newton import stacked_huber_weights
from .rig_graph import RigGraph
from .lm import MAX_ITERATIONS, _cost, levenberg_marquardt, observed_scale, residuals_and_weights



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


def _points_in_camera(x, v, c, W, ext, view0):
    """Camera c's points (3, m) in view v and their derivatives (m, 3, 6) by the view's pose
    and (m, 3, 6) by camera c's extrinsics (None for camera 0)."""
    q = x[view0 + 6 * v: view0 + 6 * v + 6]
    return rig_points(q, W, e=x[ext[c]: ext[c] + 6] if c else None)


def _evaluate(cameras, x, obs, layout):
    """Per observation: residuals (2m,) interleaved per junction, the prediction's Jacobian
    in the rig's columns ``cols`` (2m, len(cols)) and in its view's pose (2m, 6); and the
    smallest depth."""
    starts, ext, view0, N = layout
    parts = [_points_in_camera(x, v, c, W, ext, view0) for v, c, _, W in obs]
    depth = min(float(np.min(p[2])) for p, _, _ in parts)
    out = [None] * len(obs)
    # One call of each camera's projection over all its views (per view, the calls'
    # overhead was most of the time).
    for c, camera in enumerate(cameras):
        mine = [k for k, o in enumerate(obs) if o[1] == c]
        if not mine:
            continue
        P = np.hstack([parts[k][0] for k in mine])
        with np.errstate(divide="ignore", invalid="ignore"):
            pred, G = camera.project_jacobian(P)
            Jp = camera.parameter_jacobian(P)
        at = 0
        for k in mine:
            _, Jq, Je = parts[k]
            uv = obs[k][2]
            m = uv.shape[1]
            Gk, Jk = G[at: at + m], Jp[at: at + m]
            Jr = Jk if Je is None else np.concatenate([Jk, Gk @ Je], axis=2)
            out[k] = ((uv - pred[:, at: at + m]).T.ravel(), Jr.reshape(2 * m, -1), (Gk @ Jq).reshape(2 * m, 6))
            at += m
    return out, depth


def _columns(layout, obs):
    """Each observation's columns among the rig's parameters: its camera's intrinsics, then
    its extrinsics (cameras >= 1)."""
    starts, ext, _, _ = layout
    return [np.r_[starts[c]: starts[c + 1], ext[c]: ext[c] + 6] if c else np.arange(starts[0], starts[1])
            for _, c, _, _ in obs]


def _normal(views, obs, cols, n_rig, n_views, huber_px):
    """The normal equations by blocks (:func:`.lm._step`'s form): U (n_rig, n_rig),
    V (n, 6, 6), Wb (n, n_rig, 6), gp (n_rig,), ge (n, 6)."""
    U, gp = np.zeros((n_rig, n_rig)), np.zeros(n_rig)
    V, Wb, ge = np.zeros((n_views, 6, 6)), np.zeros((n_views, n_rig, 6)), np.zeros((n_views, 6))
    for (r, Jr, Jq), (v, _, _, _), k in zip(views, obs, cols):
        w = stacked_huber_weights(r, huber_px)
        wr = r if w is None else w * r
        Jrw = Jr if w is None else Jr * w[:, None]
        U[np.ix_(k, k)] += Jrw.T @ Jr
        gp[k] += Jr.T @ wr
        V[v] += (Jq if w is None else Jq * w[:, None]).T @ Jq
        Wb[v][k] += Jrw.T @ Jq
        ge[v] += Jq.T @ wr
    return U, V, Wb, gp, ge


def _cameras(templates, x, starts):
    return [t.with_parameters(x[starts[c]: starts[c + 1]]) for c, t in enumerate(templates)]


def solve_rig_lm(cameras, T_C0_C, poses, observations, huber_px=None,
                 max_iterations: int = MAX_ITERATIONS) -> RigLM:
    """Calibrate the rig by the hand-written Levenberg-Marquardt from a start.

    Parameters
    ----------
    cameras, T_C0_C, poses, observations
        The start and the junctions, as :func:`graphpose.calibrate.rig_graph.solve_rig_graph`
        takes them.
    huber_px : float, optional
        Huber threshold on each junction's 2-D error, pixels.
    max_iterations : int

    Returns
    -------
    RigLM
    """
    layout = _layout(cameras, len(poses))
    starts, ext, view0, N = layout
    cols = _columns(layout, observations)
    x = np.concatenate([c.parameters for c in cameras]
                       + [params_from_T(T) for T in T_C0_C[1:]] + [params_from_T(T) for T in poses])
    views, _ = _evaluate(cameras, x, observations, layout)

    def normal(views, cameras, x):
        return _normal(views, observations, cols, view0, len(poses), huber_px)

    def trial(cameras, x_new):
        moved = _cameras(cameras, x_new, starts)
        views_new, z = _evaluate(moved, x_new, observations, layout)
        return moved, views_new, _cost(views_new, huber_px) if z > 0 else np.inf

    x, cameras, views, S, converged, it, message = levenberg_marquardt(
        x, cameras, views, _cost(views, huber_px), normal, trial, observed_scale(uv for _, _, uv, _ in observations),
        huber_px, max_iterations, np.full((view0, view0), np.nan), "the views do not constrain the rig")
    residuals, weights = residuals_and_weights(views, huber_px)
    try:
        cov = np.linalg.inv(S)
    except np.linalg.LinAlgError:
        cov = np.full_like(S, np.nan)
    T_out = [np.eye(4)] + [T_from_params(x[ext[c]: ext[c] + 6]) for c in range(1, len(cameras))]
    poses = [T_from_params(x[view0 + 6 * v: view0 + 6 * v + 6]) for v in range(len(poses))]
    return RigLM(list(cameras), T_out, poses, cov, converged, it, message, residuals=residuals, weights=weights)

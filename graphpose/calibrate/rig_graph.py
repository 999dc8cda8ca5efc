"""The rig calibration as a GTSAM factor graph.

Variables (GTSAM's keys):

- ``K(c)``: camera c's intrinsic parameters, a vector in
  the camera's ``parameter_names`` order (any model);
- ``X(v)``: the rig's pose in view v, camera 0's ``T_WC0`` (``Pose3``);
- ``E(c)``: camera c's pose in camera 0's frame, ``T_C0_C[c]`` (``Pose3``), for c >= 1.

Factors: one projection factor per junction per camera, gathered into one
``gtsam.CustomFactor`` per camera on ``(K(c)[, E(c)], X(v) for each view it saw)`` and
vectorised over its junctions (one Python call per camera and linearisation rather than per
junction; the factor's cost is the sum of the junctions'): each junction's 2-D error
``(project_c(T_C0_C^-1 T_WC0^-1 P_W) - uv) / sigma``, under a Huber kernel of ``huber_k``
sigmas applied per junction inside the factor (the same cost as one robust factor per
junction). Its Jacobians: the camera's own ``d uv / d P`` and ``d uv / d p``
(:mod:`graphpose.camera_models`: ``project_jacobian``, ``parameter_jacobian``) chained with GTSAM's right
perturbations ``T Exp(omega, v)``: ``dP = P x omega - v`` for each pose. A view that only some
cameras saw gives factors for those alone. No prior: the board's frame and camera 0's fix the
gauge. After Levenberg-Marquardt, undamped Gauss-Newton steps polish as in :mod:`.graph`, until the
step is below 1e-11 of the parameters' scale, or has stayed below :data:`ROUNDING_STEP` for five
steps (the linearisation's rounding; a rig's extrinsics stall at a few 1e-11).
The covariance is GTSAM's joint marginal of every ``K(c)`` and ``E(c)``, at ``sigma``, with the
``E`` blocks carried from GTSAM's tangent ``(omega, v)`` to ``(x, y, z, roll, pitch, yaw)``
(:func:`graphpose.pose.graph.params_from_tangent_jacobian`).
"""

from __future__ import annotations

from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import E, K, X

from ..errors import InputError

from ..pose.graph import params_from_tangent_jacobian
from ..geometry import hats
from ..pose.rig import huber
from .graph import _ABSOLUTE_TOL, _MAX_ITERATIONS, _POLISH_ITERATIONS, _POLISH_STEP, _RELATIVE_TOL


#: Polishing steps (relative for the intrinsics, metres and radians for the extrinsics) below
#: this for :data:`_STALLED_STEPS` steps in a row count as converged at the rounding.
ROUNDING_STEP = 1e-9
_STALLED_STEPS = 5


@dataclass(frozen=True)
class RigGraph:
    """The graph's solution.

    Attributes
    ----------
    cameras : list of Camera
    T_C0_C : list of (4, 4) ndarray
        Camera c's pose in camera 0's frame (the first the identity).
    poses : list of (4, 4) ndarray
        ``T_WC0`` per view.
    cov : (N, N) ndarray
        Joint marginal covariance of the intrinsics and the extrinsics' parameters at the
        factors' ``sigma``; NaN if GTSAM could not compute it.
    converged : bool
    iterations : int
    message : str
    """

    cameras: list
    T_C0_C: list
    poses: list
    cov: np.ndarray
    converged: bool
    iterations: int
    message: str


def _factor(template, views, c, sigma, huber_k):
    """The custom factor of camera c over all its views ``[(v, uv, W)]``: keys ``(K(c)[, E(c)],
    X(v) for each view)``; one Python call per camera and linearisation, its projection in one
    call of the camera."""
    sizes = [uv.shape[1] for _, uv, _ in views]
    at = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
    m = int(at[-1])
    uv_all = np.hstack([uv for _, uv, _ in views])
    first = 2 if c > 0 else 1  # the index of X(v0) among the keys
    keys = [K(c)] + ([E(c)] if c > 0 else []) + [X(v) for v, _, _ in views]

    def error(factor, values, jacobians):
        ks = factor.keys()
        camera = template.with_parameters(values.atVector(ks[0]))
        p0 = []
        for k, (_, _, W) in enumerate(views):
            T = values.atPose3(ks[first + k])
            R, t = T.rotation().matrix(), T.translation()
            p0.append(R.T @ (W - t[:, None]))
        p = p0 = np.hstack(p0)
        if c > 0:
            Te = values.atPose3(ks[1])
            Re, te = Te.rotation().matrix(), Te.translation()
            p = Re.T @ (p0 - te[:, None])
        if jacobians is None:
            # The cost alone (GTSAM's trial steps): no derivatives.
            with np.errstate(divide="ignore", invalid="ignore"):
                pred = camera.project(p)
            if not np.all(np.isfinite(pred)):
                return np.full(2 * m, 2.0 * camera.fx / sigma)
            r = (pred - uv_all) / sigma
            if huber_k is not None:
                r, _ = huber(r, [], huber_k)
            return r.T.ravel()
        with np.errstate(divide="ignore", invalid="ignore"):
            pred, G = camera.project_jacobian(p)
        if not np.all(np.isfinite(pred)):
            jacobians[0] = np.zeros((2 * m, len(camera.parameter_names)))
            for i in range(1, len(ks)):
                jacobians[i] = np.zeros((2 * m, 6))
            return np.full(2 * m, 2.0 * camera.fx / sigma)
        # GTSAM's right perturbations T Exp(omega, v): dP = P x omega - v, for every pose.
        dX = np.concatenate([hats(p0), np.broadcast_to(-np.eye(3), (m, 3, 3))], axis=2)
        dE = None
        if c > 0:
            dX = Re.T @ dX
            dE = np.concatenate([hats(p), np.broadcast_to(-np.eye(3), (m, 3, 3))], axis=2)
        r = (pred - uv_all) / sigma
        Js = [camera.parameter_jacobian(p) / sigma, G @ dX / sigma]
        if dE is not None:
            Js.append(G @ dE / sigma)
        if huber_k is not None:
            r, Js = huber(r, Js, huber_k)
        jacobians[0] = np.ascontiguousarray(Js[0].reshape(2 * m, -1))
        if dE is not None:
            jacobians[1] = np.ascontiguousarray(Js[2].reshape(2 * m, 6))
        JX = Js[1]
        for k in range(len(views)):
            block = np.zeros((m, 2, 6))
            block[at[k]: at[k + 1]] = JX[at[k]: at[k + 1]]
            jacobians[first + k] = block.reshape(2 * m, 6)
        return r.T.ravel()

    return gtsam.CustomFactor(gtsam.noiseModel.Unit.Create(2 * m), keys, error)


def solve_rig_graph(cameras, T_C0_C, poses, observations, sigma: float, huber_k=None) -> RigGraph:
    """Calibrate the rig with a GTSAM graph from a start.

    Parameters
    ----------
    cameras : list of Camera
        Starting cameras (models and sizes kept).
    T_C0_C : list of (4, 4) ndarray
        Starting extrinsics, the first the identity.
    poses : list of (4, 4) ndarray
        Starting ``T_WC0`` per view.
    observations : list of (view, camera, uv (2, m), W (3, m))
        Every (view, camera) with the board: its junctions' pixels and board points.
    sigma : float
        Pixel noise of every junction, pixels.
    huber_k : float, optional
        Huber threshold in sigmas; plain least squares when None.

    Returns
    -------
    RigGraph
    """
    # 1. The graph: one factor per (view, camera) that saw the board.
    graph = gtsam.NonlinearFactorGraph()
    for c, camera in enumerate(cameras):
        views = [(v, uv, W) for v, cc, uv, W in observations if cc == c]
        if views:
            graph.add(_factor(camera, views, c, sigma, huber_k))
    # 2. The start: intrinsics as vectors, the rig's and the cameras' poses.
    initial = gtsam.Values()
    for c, camera in enumerate(cameras):
        initial.insert(K(c), camera.parameters)
        if c > 0:
            initial.insert(E(c), gtsam.Pose3(np.asarray(T_C0_C[c])))
    for v, T in enumerate(poses):
        initial.insert(X(v), gtsam.Pose3(np.asarray(T)))
    # 3. Levenberg-Marquardt, then undamped steps until the parameters' step is negligible.
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(_RELATIVE_TOL)
    params.setAbsoluteErrorTol(_ABSOLUTE_TOL)
    params.setMaxIterations(_MAX_ITERATIONS)
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    n = sum(c.parameters.size for c in cameras) + 6 * (len(cameras) - 1)
    nan = np.full((n, n), np.nan)
    try:
        result = optimizer.optimize()
        polished, stalled = False, 0
        for _ in range(_POLISH_ITERATIONS):
            delta = graph.linearize(result).optimize()
            result = result.retract(delta)
            worst = 0.0
            for c in range(len(cameras)):
                p = np.asarray(result.atVector(K(c)))
                worst = max(worst, float(np.max(np.abs(delta.at(K(c))) / np.maximum(np.abs(p), 1e-3))))
                if c > 0:
                    worst = max(worst, float(np.max(np.abs(delta.at(E(c))))))
            if worst < _POLISH_STEP:
                polished = True
                break
            # At the linearisation's rounding the steps stop shrinking (a few 1e-11 of the
            # parameters here): converged once they stay below ROUNDING_STEP.
            stalled = stalled + 1 if worst < ROUNDING_STEP else 0
            if stalled >= _STALLED_STEPS:
                polished = True
                break
        # 4. The joint marginal of the rig's parameters.
        keys = [K(c) for c in range(len(cameras))] + [E(c) for c in range(1, len(cameras))]
        cov = _joint(graph, result, keys, len(cameras))
    except RuntimeError as exc:
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        return RigGraph(list(cameras), list(T_C0_C), list(poses), nan, False, int(optimizer.iterations()),
                        lines[0] if lines else type(exc).__name__)
    try:
        solved = [t.with_parameters(result.atVector(K(c))) for c, t in enumerate(cameras)]
    except InputError as exc:
        return RigGraph(list(cameras), list(T_C0_C), list(poses), nan, False, int(optimizer.iterations()), str(exc))
    T_out = [np.eye(4)] + [result.atPose3(E(c)).matrix() for c in range(1, len(cameras))]
    out = [result.atPose3(X(v)).matrix() for v in range(len(poses))]
    converged = bool(optimizer.iterations() < _MAX_ITERATIONS and polished and np.isfinite(optimizer.error()))
    return RigGraph(solved, T_out, out, cov, converged, int(optimizer.iterations()),
                    "" if converged else "GTSAM did not converge")


def _joint(graph, result, keys, n_cameras):
    """The joint marginal of ``keys`` in the parameters' units: the ``E`` blocks from GTSAM's
    tangent to ``(x, y, z, roll, pitch, yaw)``."""
    joint = gtsam.Marginals(graph, result).jointMarginalCovariance(gtsam.KeyVector(keys))
    dims = [result.atVector(k).size for k in keys[:n_cameras]] + [6] * (n_cameras - 1)
    starts = np.concatenate([[0], np.cumsum(dims)]).astype(int)
    cov = np.empty((starts[-1], starts[-1]))
    for i, ki in enumerate(keys):
        for j, kj in enumerate(keys):
            cov[starts[i]: starts[i + 1], starts[j]: starts[j + 1]] = joint.at(ki, kj)
    A = np.eye(starts[-1])
    for c in range(1, n_cameras):
        s = starts[n_cameras + c - 1]
        A[s: s + 6, s: s + 6] = params_from_tangent_jacobian(result.atPose3(keys[n_cameras + c - 1]).matrix())
    cov = A @ cov @ A.T
    return 0.5 * (cov + cov.T)

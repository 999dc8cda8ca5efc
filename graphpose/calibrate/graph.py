"""The calibration as a GTSAM factor graph: one calibration variable, one ``Pose3`` per view,
one factor per junction, a Huber kernel, Levenberg-Marquardt, and GTSAM's marginals.

Variables: the calibration ``K(0)``; the camera pose ``X(i)`` (``T_WC``) of view i. Factors:

- pinhole: GTSAM's ``GeneralSFMFactor2Cal3_S2`` on ``X(i)``, the target point ``L(j)`` and a
  ``Cal3_S2``; fisheye: ``GeneralSFMFactor2Cal3Fisheye`` with a ``Cal3Fisheye`` (GTSAM's own
  projection code, checked against graphpose's in ``tests/camera_models/``; it projects
  through ``(x/z, y/z)``, so the junctions must lie in front of the camera). The target
  points are variables pinned by very tight priors (:data:`LANDMARK_SIGMA_M`), as in the
  pose graph, and GTSAM's calibrations carry a skew the calibration does not
  estimate: a prior pins it at 0 (sigma 1e-6 px) and leaves the other entries free (sigma
  1e6).
- radtan: GTSAM's ``Cal3DS2`` has no ``k3``, so the calibration is a 9-vector
  ``(fx, fy, cx, cy, k1, k2, p1, p2, k3)`` in OpenCV's order (rational: a 12-vector, ``k4, k5,
  k6`` after them) and the factors are
  ``gtsam.CustomFactor`` on ``(K(0), X(i))`` whose projection and Jacobians are written out
  here, apart from :mod:`graphpose.camera_models` (the cross-check's other solver uses those). A
  Python callback per junction costs about 0.1 ms a call (some 6 s for 40 views), so there is
  one custom factor per view, vectorised over its junctions, and the Huber kernel is applied
  per junction inside it, exactly (:func:`_radtan_factor`): the cost is the same as with
  one robust factor per junction.

A bent board (``bases``, the board warp ``(w_x, w_y)`` of
:meth:`graphpose.board.Board.warp_basis`): the warp is a 2-vector variable; the radial-tangential
factors take it as a third key, and the pinhole and fisheye ones become one custom factor per
view through GTSAM's own camera (:func:`_camera_factor`; the landmark variables tied to the
warp by factors as tight as their priors made the elimination indeterminate).

Each junction's noise is isotropic, ``sigma`` px, under a Huber kernel of ``huber_k`` sigmas
(on the junction's 2-D error), when given. After Levenberg-Marquardt undamped Gauss-Newton
steps polish the solution (as in :mod:`graphpose.pose.graph`: LM stops when the cost stops
falling visibly, the steps stay accurate below that) until the calibration's step is below
1e-10 of its parameters' scale. The covariance is GTSAM's marginal of ``K(0)`` (the skew's
row and column dropped), at the given ``sigma``.
"""

from __future__ import annotations

from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import K as KEY
from gtsam.symbol_shorthand import L, X

#: The board warp's variable (a 2-vector, metres).
WARP = gtsam.symbol("w", 0)

from ..camera_models import FisheyeCamera, PinholeCamera
from ..errors import InputError

#: Standard deviation (metres) of the priors that pin the target points. Tighter than the
#: pose graph's 1e-8 m: the points are shared by every view, and at 1e-8 m their slack moved
#: a fisheye's k4 by 7e-7 of its sigma from the hand-written solver's (fixed points); 1e-10 m
#: brings that to 2e-10 (1e-11 m gains nothing more).
LANDMARK_SIGMA_M = 1e-10
_RELATIVE_TOL = 1e-10
_ABSOLUTE_TOL = 1e-14
_MAX_ITERATIONS = 200
#: Undamped steps after Levenberg-Marquardt, until the step is below _POLISH_STEP of the
#: parameters' scale (the Huber kernel's reweighted steps converge linearly, at ~0.5).
_POLISH_ITERATIONS = 80
_POLISH_STEP = 1e-11
#: Prior sigmas on a GTSAM calibration: the skew pinned, the rest free.
_SKEW_SIGMA = 1e-6
_FREE_SIGMA = 1e6


@dataclass(frozen=True)
class GraphCalibration:
    """The graph's solution.

    Attributes
    ----------
    camera : Camera
        The calibrated camera (no covariance attached).
    poses : list of (4, 4) ndarray
        ``T_WC`` per view.
    cov : (P, P) ndarray
        Marginal covariance of the parameters (the camera's ``parameter_names``
        order) at the factors' ``sigma``; NaN if GTSAM could not compute it.
    converged : bool
        LM stopped on its tolerances and the polishing steps shrank below their tolerance.
    iterations : int
        Levenberg-Marquardt iterations.
    message : str
        Empty, or what GTSAM reported.
    warp : (2,) ndarray or None
        The board warp ``(w_x, w_y)``, metres, where it was estimated.
    warp_cov : (2, 2) ndarray or None
        Its marginal covariance at the factors' ``sigma``, metres squared.
    """

    camera: object
    poses: list
    cov: np.ndarray
    converged: bool
    iterations: int
    message: str = ""
    warp: np.ndarray | None = None
    warp_cov: np.ndarray | None = None


def _radtan_factor(uv, W, cal_key, pose_key, sigma, huber_k, held=None, basis=None, warp_key=None):
    """One view's factor on the 9-vector calibration and the pose, vectorised over its m
    junctions; error (2m,) predicted - measured, whitened by ``sigma`` and, with ``huber_k``,
    scaled per junction so that half its squared norm is the Huber loss.

    Junction j's whitened residual ``r = (pi - uv) / sigma`` of norm ``a`` becomes
    ``e = s(a) r`` with ``s = 1`` up to ``k`` and ``s = sqrt(2 rho(a)) / a`` beyond, ``rho(a)
    = k a - k^2 / 2``: ``|e|^2 / 2 = rho(a)``, GTSAM's robust loss; the Jacobian is the exact
    derivative of ``e`` (``s`` is continuous with its derivative at ``k``), so the
    stationary point is the Huber cost's. ``held`` (a (9,) bool mask) zeroes the Jacobian's
    columns of parameters held at their value (``radtan4``'s k3). With ``basis`` (the board
    warp's shapes (2, m) at the junctions, :meth:`graphpose.board.Board.warp_basis`) the
    factor's third key ``warp_key`` is the board warp ``(w_x, w_y)``: each target point
    moves by ``w . b`` along the target's z.
    """
    measured = np.array(uv, dtype=float)
    W0 = np.array(W, dtype=float)
    m = measured.shape[1]
    keys = [cal_key, pose_key] + ([] if basis is None else [warp_key])

    def error(factor, values, jacobians):
        W = W0
        if basis is not None:
            W = W0.copy()
            W[2] += np.asarray(values.atVector(warp_key)) @ basis
        c = values.atVector(factor.keys()[0])
        rational = c.size == 12
        fx, fy, cx, cy, k1, k2, p1, p2, k3 = c[:9]
        k4, k5, k6 = c[9:] if rational else (0.0, 0.0, 0.0)
        n = c.size
        T = values.atPose3(factor.keys()[1])
        R = T.rotation().matrix()
        P = R.T @ (W - T.translation()[:, None])  # (3, m)
        Z = P[2]
        if np.any(Z <= 0):
            if jacobians is not None:
                jacobians[0], jacobians[1] = np.zeros((2 * m, n)), np.zeros((2 * m, 6))
                if basis is not None:
                    jacobians[2] = np.zeros((2 * m, 2))
            return np.full(2 * m, 2.0 * fx / sigma)
        x, y = P[0] / Z, P[1] / Z
        r2 = x * x + y * y
        a = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        b = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
        radial = a / b
        xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
        yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
        r = np.stack([fx * xd + cx - measured[0], fy * yd + cy - measured[1]]) / sigma  # (2, m)
        if jacobians is not None:
            r4 = r2 * r2
            zero, one = np.zeros(m), np.ones(m)
            cols_x = [xd, zero, one, zero, fx * x * r2 / b, fx * x * r4 / b, 2.0 * fx * x * y,
                      fx * (r2 + 2.0 * x * x), fx * x * r4 * r2 / b]
            cols_y = [zero, yd, zero, one, fy * y * r2 / b, fy * y * r4 / b, fy * (r2 + 2.0 * y * y),
                      2.0 * fy * x * y, fy * y * r4 * r2 / b]
            if rational:
                q = -a / (b * b)
                cols_x += [fx * x * q * r2, fx * x * q * r4, fx * x * q * r4 * r2]
                cols_y += [fy * y * q * r2, fy * y * q * r4, fy * y * q * r4 * r2]
            Jc = np.stack([np.stack(cols_x, axis=1), np.stack(cols_y, axis=1)], axis=1) / sigma  # (m, 2, n)
            if held is not None:
                Jc[:, :, held] = 0.0
            da = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
            db = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
            dr = (da * b - a * db) / (b * b)
            a00 = radial + 2.0 * x * x * dr + 2.0 * p1 * y + 6.0 * p2 * x
            a01 = 2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y
            a11 = radial + 2.0 * y * y * dr + 6.0 * p1 * y + 2.0 * p2 * x
            # d uv / dP = diag(fx, fy) A d(x, y)/dP, row by row (m, 2, 3).
            G = np.empty((m, 2, 3))
            G[:, 0, 0], G[:, 0, 1] = fx * a00 / Z, fx * a01 / Z
            G[:, 0, 2] = -fx * (a00 * x + a01 * y) / Z
            G[:, 1, 0], G[:, 1, 1] = fy * a01 / Z, fy * a11 / Z
            G[:, 1, 2] = -fy * (a01 * x + a11 * y) / Z
            # Right perturbation T Exp(omega, v): dP = P x omega - v, so a row g gives
            # (g x P) for omega and -g for v.
            Jp = np.concatenate([np.cross(G, P.T[:, None, :]), -G], axis=2) / sigma  # (m, 2, 6)
            if basis is not None:
                # dP / dW_z = R^T e_z (P = R^T (W - t)), times the shapes.
                Jw = (G @ R[2])[:, :, None] * basis.T[:, None, :] / sigma  # (m, 2, 2)
        Js = [] if jacobians is None else [Jc, Jp] + ([] if basis is None else [Jw])
        e, Js = _robust(r, Js, huber_k, jacobians is not None)
        if jacobians is not None:
            for k, J in enumerate(Js):
                jacobians[k] = J.reshape(2 * m, J.shape[2])
        return e.T.ravel()

    noise = gtsam.noiseModel.Unit.Create(2 * m)
    return gtsam.CustomFactor(noise, keys, error)


def _robust(r, jacobians, huber_k, with_jacobians=True):
    """The Huber kernel per junction on whitened residuals ``r`` (2, m) and their Jacobians
    (each (m, 2, k)): ``e = s(a) r`` with ``|e|^2 / 2 = rho(a)`` (:func:`_radtan_factor`) and
    the exact derivatives of ``e``. Without ``huber_k``: unchanged."""
    if huber_k is None:
        return r, jacobians
    a = np.hypot(r[0], r[1])
    far = a > huber_k
    rho = huber_k * a - 0.5 * huber_k * huber_k
    root = np.sqrt(np.where(far, 2.0 * rho, 1.0))
    s = np.where(far, root / np.where(far, a, 1.0), 1.0)
    if not with_jacobians:
        return r * s, jacobians
    # d e / d theta = s J + r (ds/da) (r^T J) / a, ds/da = (k^2 - k a) / (a^2 sqrt(2 rho)).
    ds = np.where(far, (huber_k * huber_k - huber_k * a) / (np.where(far, a, 1.0) ** 3 * root), 0.0)
    outer = (r.T[:, :, None] * r.T[:, None, :]) * ds[:, None, None]  # (m, 2, 2)
    return r * s, [s[:, None, None] * J + outer @ J for J in jacobians]


def _camera_factor(uv, W, basis, cal_key, pose_key, warp_key, sigma, huber_k, fisheye):
    """One view's factor on GTSAM's own calibration (``Cal3Fisheye`` or ``Cal3_S2``), the pose
    and the board warp, vectorised over its m junctions as :func:`_radtan_factor` (the Huber
    kernel per junction inside): each junction projected by GTSAM's camera
    (``PinholeCameraCal3Fisheye`` / ``PinholeCameraCal3_S2.project`` with its Jacobians) at
    the bent board's point ``W + e_z (w . b)``; the warp's Jacobian is the point's z column
    times ``b``.

    Used with a warp only: the flat board's target points are landmark variables pinned by
    tight priors (:data:`LANDMARK_SIGMA_M`), and tying them to the warp with factors as
    tight made GTSAM's elimination indeterminate (the warp's information is the small
    difference of terms of ``1 / LANDMARK_SIGMA_M^2``).
    """
    measured = np.array(uv, dtype=float)
    W0 = np.array(W, dtype=float)
    b = np.array(basis, dtype=float)
    m = measured.shape[1]
    make = gtsam.PinholeCameraCal3Fisheye if fisheye else gtsam.PinholeCameraCal3_S2

    def error(factor, values, jacobians):
        cal = values.atCal3Fisheye(cal_key) if fisheye else values.atCal3_S2(cal_key)
        n = cal.dim()
        cam = make(values.atPose3(pose_key), cal)
        warp = np.asarray(values.atVector(warp_key))
        P = W0.copy()
        P[2] += warp @ b
        pred = np.empty((2, m))
        Jc, Jp, Jz = np.empty((m, 2, n)), np.empty((m, 2, 6)), np.empty((m, 2))
        Dpose, Dpoint, Dcal = (np.zeros((2, 6), order="F"), np.zeros((2, 3), order="F"),
                               np.zeros((2, n), order="F"))
        try:
            for j in range(m):
                pred[:, j] = cam.project(P[:, j], Dpose, Dpoint, Dcal)
                Jc[j], Jp[j], Jz[j] = Dcal, Dpose, Dpoint[:, 2]
        except RuntimeError:  # a point behind the camera: a large error, no gradient
            if jacobians is not None:
                jacobians[0], jacobians[1], jacobians[2] = np.zeros((2 * m, n)), np.zeros((2 * m, 6)), np.zeros((2 * m, 2))
            return np.full(2 * m, 2.0 * cal.fx() / sigma)
        r = (pred - measured) / sigma
        Jw = Jz[:, :, None] * b.T[:, None, :]
        e, Js = _robust(r, [Jc / sigma, Jp / sigma, Jw / sigma], huber_k, jacobians is not None)
        if jacobians is not None:
            for k, J in enumerate(Js):
                jacobians[k] = J.reshape(2 * m, J.shape[2])
        return e.T.ravel()

    return gtsam.CustomFactor(gtsam.noiseModel.Unit.Create(2 * m), [cal_key, pose_key, warp_key], error)


def _gtsam_calibration(camera, p):
    if isinstance(camera, PinholeCamera):
        return gtsam.Cal3_S2(p[0], p[1], 0.0, p[2], p[3])
    if isinstance(camera, FisheyeCamera):
        return gtsam.Cal3Fisheye(p[0], p[1], 0.0, p[2], p[3], *p[4:8])
    return None


def _from_gtsam(values, camera):
    """The parameters (P,) of the calibration variable."""
    if isinstance(camera, PinholeCamera):
        c = values.atCal3_S2(KEY(0))
        return np.array([c.fx(), c.fy(), c.px(), c.py()])
    if isinstance(camera, FisheyeCamera):
        c = values.atCal3Fisheye(KEY(0))
        return np.array([c.fx(), c.fy(), c.px(), c.py(), c.k1(), c.k2(), c.k3(), c.k4()])
    return np.array(values.atVector(KEY(0)))


def solve_graph(camera, poses, observations, sigma: float, huber_k=None, prior_px=None, *,
                held=None, bases=None, warp=None) -> GraphCalibration:
    """Calibrate with a GTSAM graph from a start.

    Parameters
    ----------
    camera : Camera
        The starting camera (its model and size are kept; skew 0).
    poses : list of (4, 4) ndarray
        Starting ``T_WC`` per view.
    observations : list of (uv (2, m), W (3, m), index (m,))
        Each view's used junctions: raw pixels, board points (metres), board indices.
    sigma : float
        Pixel noise of every factor, pixels.
    huber_k : float, optional
        Huber threshold in sigmas; plain least squares when None.
    prior_px : float, optional
        As :func:`graphpose.calibrate.lm.solve_lm`'s: the model's weak prior, its residual in
        units of this pixel noise (whitened here by ``sigma``).
    held : (P,) array_like of bool, optional
        Radial-tangential parameters held at the start's value (``radtan4``'s k3 at 0): no
        factor's Jacobian moves them, a unit prior keeps the graph's system regular, and
        their rows and columns of the covariance are zero.
    bases : list of (2, m) ndarray, optional
        Per view the board warp's shapes at its junctions
        (:meth:`graphpose.board.Board.warp_basis`): the board warp is a variable of the
        graph (a 2-vector, metres), in the radial-tangential factors, or in the factors that
        project through GTSAM's own camera (:func:`_camera_factor`); None: flat.
    warp : (2,) array_like, optional
        The warp's start (zeros by default).

    Returns
    -------
    GraphCalibration
    """
    p0 = camera.parameters
    held = None if held is None or not np.any(held) else np.asarray(held, dtype=bool)
    graph = gtsam.NonlinearFactorGraph()
    initial = gtsam.Values()
    if bases is not None:
        initial.insert(WARP, np.zeros(2) if warp is None else np.asarray(warp, dtype=float))
    noise = gtsam.noiseModel.Isotropic.Sigma(2, sigma)
    if huber_k is not None:
        noise = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(huber_k), noise)
    cal = _gtsam_calibration(camera, p0)
    if held is not None and cal is not None:
        raise InputError(f"only the radtan model's parameters can be held, not the {camera.model}'s")
    if cal is None:
        initial.insert(KEY(0), p0)
        from .lm import PRIORS

        has_prior = prior_px is not None and camera.model in PRIORS
        if held is not None or has_prior:
            # A held parameter: a unit prior at its start keeps the system regular (no factor
            # moves it). The model's weak prior: the LM's 0.5 (prior_px / s)^2 p_i^2 in pixel
            # units is 0.5 (p_i / s_i)^2 in GTSAM's whitened cost (divided by sigma^2):
            # s_i = s sigma / prior_px, about zero. Every other entry free.
            sigmas, mean = np.full(p0.size, _FREE_SIGMA), p0.copy()
            if held is not None:
                sigmas[held] = 1.0
            if has_prior:
                index, prior_sigma = PRIORS[camera.model]
                sigmas[index] = prior_sigma * sigma / prior_px
                mean[index] = 0.0
            graph.add(gtsam.PriorFactorVector(KEY(0), mean, gtsam.noiseModel.Diagonal.Sigmas(sigmas)))
    else:
        initial.insert(KEY(0), cal)
        sigmas = np.full(cal.dim(), _FREE_SIGMA)
        sigmas[2] = _SKEW_SIGMA
        prior = gtsam.noiseModel.Diagonal.Sigmas(sigmas)
        graph.add((gtsam.PriorFactorCal3_S2 if isinstance(camera, PinholeCamera)
                   else gtsam.PriorFactorCal3Fisheye)(KEY(0), cal, prior))
        factor = (gtsam.GeneralSFMFactor2Cal3_S2 if isinstance(camera, PinholeCamera)
                  else gtsam.GeneralSFMFactor2Cal3Fisheye)
        landmark_noise = gtsam.noiseModel.Isotropic.Sigma(3, LANDMARK_SIGMA_M)
        landmarks = {}
        for _, W, index in observations:
            for j, w in zip(index, W.T):
                landmarks[int(j)] = w
        for j, w in (landmarks.items() if bases is None else ()):
            initial.insert(L(j), w)
            graph.add(gtsam.PriorFactorPoint3(L(j), w, landmark_noise))
    for i, ((uv, W, index), T) in enumerate(zip(observations, poses)):
        initial.insert(X(i), gtsam.Pose3(T))
        if cal is None:
            graph.add(_radtan_factor(uv, W, KEY(0), X(i), sigma, huber_k, held,
                                     None if bases is None else bases[i], WARP))
            continue
        if bases is not None:
            graph.add(_camera_factor(uv, W, bases[i], KEY(0), X(i), WARP, sigma, huber_k,
                                     isinstance(camera, FisheyeCamera)))
            continue
        for k in range(uv.shape[1]):
            graph.add(factor(uv[:, k], noise, X(i), L(int(index[k])), KEY(0)))
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(_RELATIVE_TOL)
    params.setAbsoluteErrorTol(_ABSOLUTE_TOL)
    params.setMaxIterations(_MAX_ITERATIONS)
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    nan = np.full((p0.size, p0.size), np.nan)
    try:
        result = optimizer.optimize()
        polished = False
        for _ in range(_POLISH_ITERATIONS):
            delta = graph.linearize(result).optimize()
            result = result.retract(delta)
            p = _from_gtsam(result, camera)
            step = np.asarray(delta.at(KEY(0)))
            if cal is not None:
                step = np.delete(step, 2)
            if bases is not None:  # the warp's step too, on the scale of a millimetre at least
                p = np.r_[p, result.atVector(WARP)]
                step = np.r_[step, delta.at(WARP)]
            if np.max(np.abs(step) / np.maximum(np.abs(p), 1e-3)) < _POLISH_STEP:
                polished = True
                break
        marginals = gtsam.Marginals(graph, result)
        cov = np.asarray(marginals.marginalCovariance(KEY(0)))
        warp_cov = None if bases is None else np.asarray(marginals.marginalCovariance(WARP))
        if cal is not None:
            cov = np.delete(np.delete(cov, 2, axis=0), 2, axis=1)
        if held is not None:
            cov[held, :], cov[:, held] = 0.0, 0.0
    except RuntimeError as exc:
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        return GraphCalibration(camera, list(poses), nan, False, int(optimizer.iterations()),
                                lines[0] if lines else type(exc).__name__)
    p = _from_gtsam(result, camera)
    out = [result.atPose3(X(i)).matrix() for i in range(len(observations))]
    converged = bool(optimizer.iterations() < _MAX_ITERATIONS and polished and np.isfinite(optimizer.error()))
    try:
        solved = camera.with_parameters(p)
    except InputError as exc:  # an invalid camera (a focal length <= 0): a failed solve
        return GraphCalibration(camera, out, nan, False, int(optimizer.iterations()), str(exc))
    w = None if bases is None else np.asarray(result.atVector(WARP), dtype=float)
    return GraphCalibration(solved, out, 0.5 * (cov + cov.T), converged, int(optimizer.iterations()),
                            "" if converged else "GTSAM did not converge", w,
                            None if warp_cov is None else 0.5 * (warp_cov + warp_cov.T))

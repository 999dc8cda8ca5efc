"""Projection uncertainty as mrcal defines it: the camera frame tied to the boards it saw.

A calibration estimates the intrinsics ``p`` together with every view's pose, and its noise
moves both. The camera's own frame is only defined through those poses: a calibration whose
focal length came out a little long and whose boards came out a little far projects the
boards' points to the same pixels. So the uncertainty of projecting a point is not the
intrinsics' alone (``J_p cov_p J_p^T``, :meth:`Calibration.uncertainty_map`), but that of the
whole chain mrcal describes (its "projection uncertainty"):

1. unproject the pixel ``q`` through the calibrated camera: the point ``p_cam = d v`` at the
   distance ``d`` along its unit ray ``v`` (at infinity: the direction ``v`` alone);
2. carry it into every observed board's frame through that view's pose, ``p_i = T_WC_i
   p_cam``;
3. back into a perturbed camera frame as the mean over the boards, ``p_cam' = mean_i
   T_WC_i'^-1 p_i`` (at infinity: the rotations only);
4. project through the perturbed intrinsics, ``q' = project(p_cam', p')``.

With ``b`` the intrinsics and every pose (each as ``(x, y, z, roll, pitch, yaw)`` of
``T_WC``), ``Var(q) = (dq'/db) Var(b) (dq'/db)^T``, where ``Var(b) = sigma^2 (J^T W J)^-1``
is the joint covariance of the solve (:func:`joint_information`; ``W`` the Huber weights,
``sigma`` the pixel noise the residuals give). The derivative is analytic: the intrinsics'
through the camera's ``parameter_jacobian``, the poses' through
the camera's ``d uv / d p_C`` and the derivative of ``T_WC^-1`` (the pose's compiled kernel
:func:`graphpose.pose.gauss_newton.camera_points`). Evaluated where the boards were, the
frames' share cancels most of the intrinsics' (the two are strongly correlated); at infinity
only the rotations' part of it does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import as_points
from ..errors import InputError
from ..geometry import params_from_T
from ..pose.gauss_newton import camera_points


@dataclass(frozen=True)
class ProjectionUncertainty:
    """The projection uncertainty at some pixels (:func:`projection_uncertainty`).

    Attributes
    ----------
    points_px : (2, N) ndarray
        The pixels (u, v).
    distance_m : float or None
        The distance along each pixel's ray, metres; None at infinity.
    cov : (N, 2, 2) ndarray
        The covariance of each pixel's reprojection, pixels squared; NaN where the camera
        has no ray.
    sigma_px : (N,) ndarray
        The 1-sigma along the worst direction, ``sqrt(largest eigenvalue of cov)``, pixels
        (mrcal's ``worst_direction_stdev``).
    """

    points_px: np.ndarray
    distance_m: float | None
    cov: np.ndarray
    sigma_px: np.ndarray


def joint_information(camera, poses, observations, huber_px=None, bases=None, warp=None) -> np.ndarray:
    """``J^T W J`` of the calibration's whole solve at unit pixel noise.

    Parameters
    ----------
    camera : Camera
        The calibrated camera.
    poses : list of (4, 4) ndarray
        ``T_WC`` of each view.
    observations : list of (uv (2, m), W (3, m), index (m,))
        Each view's used junctions.
    huber_px : float, optional
        The Huber threshold of the solve (the weights ``W``), pixels.
    bases : list of (2, m) ndarray, optional
        Per view the board warp's shapes (:func:`graphpose.calibrate.lm.solve_lm`): the
        board warp is among the unknowns, after the intrinsics.
    warp : (2,) array_like, optional
        The board warp, metres (with ``bases``).

    Returns
    -------
    H : (P + 6 n, P + 6 n) ndarray
        Unknowns in order: the intrinsics (the camera's ``parameter_names``; with ``bases``
        then the warp's two, P counting them), then each view's ``(x, y, z, roll, pitch, yaw)``.
    """
    from .lm import _evaluate, _normal

    p = camera.parameters
    nw = 0 if bases is None else 2
    P, n = p.size + nw, len(poses)
    x = np.concatenate([p, np.zeros(nw) if warp is None else np.asarray(warp, float)[:nw]]
                       + [params_from_T(T) for T in poses])
    views, _ = _evaluate(camera, x, observations, p.size, bases)
    U, V, Wb, _, _ = _normal(views, huber_px, P)
    H = np.zeros((P + 6 * n, P + 6 * n))
    H[:P, :P] = U
    for i in range(n):
        s = slice(P + 6 * i, P + 6 * i + 6)
        H[s, s] = V[i]
        H[:P, s] = Wb[i]
        H[s, :P] = Wb[i].T
    return H


def huber_covariance(camera, poses, observations, huber_px=None, prior_px=None, held=None, bases=None,
                     warp=None) -> np.ndarray:
    """The joint covariance of the calibration's Huber estimate (Huber's asymptotic form).

    The solve minimises ``sum_j rho(|r_j|)`` (Huber on each junction's 2-D error, threshold
    ``k``). Under independent, equal noise the estimate's covariance is Huber's

        kappa^2 (sum_j |psi_j|^2 / (2M - K)) / mean(psi')^2 (J^T J)^-1

    (Huber 1981, 7.6; statsmodels' ``H1``): ``psi_j = w_j r_j`` the junction's influence
    (``w = min(1, k / |r|)``), ``psi'`` its derivative per coordinate (1 inside the threshold;
    beyond it the radial coordinate's 0 and the tangential one's ``k / |r|``, averaged over
    the 2M coordinates), ``kappa = 1 + (K / 2M) var(psi') / mean(psi')^2`` the small-sample
    correction, K the unknowns. Without a threshold it is ``sigma^2 (J^T J)^-1`` with
    ``sigma^2 = sum r^2 / (2M - K)``.

    Why not ``sigma^2 (J^T W J)^-1`` with ``sigma^2 = sum w r^2 / (2M - K)`` (the IRLS form
    used before): with Gaussian noise a 2-D threshold at 1.345 sigma weighs down 40 % of the
    junctions (``P(|r| > k) = exp(-k^2 / 2)``), so ``sum w r^2`` is 0.745 of ``sum r^2``, the
    weights' mean 0.896, and that form 0.83 sigma^2 (J^T J)^-1 where the Huber estimate's
    spread is 1.07 sigma^2 (J^T J)^-1: the parameter NEES 1.29 times too large. (A sandwich
    ``A^-1 B A^-1`` with ``B`` from the residuals was tried too: its ``B`` is biased low where
    the poses' leverage is high, NEES 11.0 for 9 on simulated Gaussian junctions.)

    Parameters
    ----------
    camera, poses, observations, huber_px
        As :func:`joint_information`.
    prior_px : float, optional
        The solve's weak prior (:func:`graphpose.calibrate.lm.prior_terms`), whose information
        joins ``J^T J``.
    held : (P,) array_like of bool, optional
        Intrinsics held at their value, not estimated (``radtan4``'s k3): not among the K
        unknowns, their rows and columns of the covariance zero.
    bases, warp
        As :func:`joint_information`: the board warp among the unknowns.

    Returns
    -------
    cov : (P + 6 n, P + 6 n) ndarray
        Pixels and the poses' units (with ``bases``, P counts the warp's two, in metres);
        NaN if ``J^T J`` is singular.
    """
    from .lm import _evaluate, prior_terms

    H = joint_information(camera, poses, observations, None, bases, warp)
    p = camera.parameters
    H[:p.size, :p.size] += prior_terms(camera, p, prior_px)[1]
    nw = 0 if bases is None else 2
    P, n = p.size + nw, len(poses)
    free = np.ones(P + 6 * n, dtype=bool)
    if held is not None:
        free[:p.size] = ~np.asarray(held, dtype=bool)
    K = int(np.sum(free))
    x = np.concatenate([p, np.zeros(nw) if warp is None else np.asarray(warp, float)[:nw]]
                       + [params_from_T(T) for T in poses])
    views, _ = _evaluate(camera, x, observations, p.size, bases)
    r = np.concatenate([v[0] for v in views]).reshape(-1, 2)
    N = 2 * r.shape[0]
    a = np.hypot(r[:, 0], r[:, 1])
    if huber_px is None:
        return _free_covariance(H, float(np.sqrt(np.sum(r * r) / max(N - K, 1))), free)
    far = a > huber_px
    w = np.where(far, huber_px / np.where(far, a, 1.0), 1.0)
    psi2 = float(np.sum((w * a) ** 2))
    # psi' per coordinate: (1, 1) inside; beyond, (0, k / a) (radial, tangential).
    d = np.concatenate([np.where(far, 0.0, 1.0), np.where(far, w, 1.0)])
    m, var = float(np.mean(d)), float(np.var(d))
    if m <= 0:
        return np.full(H.shape, np.nan)
    kappa = 1.0 + (K / N) * var / (m * m)
    return _free_covariance(H, kappa * np.sqrt(psi2 / max(N - K, 1)) / m, free)


def _free_covariance(H, sigma_px: float, free) -> np.ndarray:
    """:func:`covariance_from_information` over the ``free`` unknowns (a bool mask) of ``H``;
    the held ones' rows and columns zero."""
    if np.all(free):
        return covariance_from_information(H, sigma_px)
    cov = np.zeros(H.shape)
    cov[np.ix_(free, free)] = covariance_from_information(H[np.ix_(free, free)], sigma_px)
    return cov


def covariance_from_information(H, sigma_px: float) -> np.ndarray:
    """``sigma^2 H^-1``, inverted at unit diagonal (the unknowns' units differ: pixels,
    metres, radians). NaN if ``H`` is singular."""
    d = np.sqrt(np.abs(np.diag(H)))
    if not np.all(d > 0):
        return np.full(H.shape, np.nan)
    try:
        inv = np.linalg.inv(H / d[:, None] / d[None, :]) / d[:, None] / d[None, :]
    except np.linalg.LinAlgError:
        return np.full(H.shape, np.nan)
    return sigma_px ** 2 * 0.5 * (inv + inv.T)


def projection_jacobian(camera, poses, points_px, distance_m=None):
    """``d q' / d b`` of steps 1-4 of the module docstring, at the unperturbed solution.

    Parameters
    ----------
    camera : Camera
    poses : list of (4, 4) ndarray
        ``T_WC`` of the views the calibration used (the frames of the mean).
    points_px : (2, N) array_like
        Pixels.
    distance_m : float, optional
        Distance along the rays, metres; None: at infinity.

    Returns
    -------
    J : (N, 2, P + 6 n) ndarray
        NaN rows where the camera has no ray.
    p_cam : (3, N) ndarray
        The points (or, at infinity, unit directions) in the camera frame.
    """
    q = as_points(points_px, 2, "points_px", min_count=0)
    v = camera.unproject(q)
    good = np.all(np.isfinite(v), axis=0)
    v = np.where(good, v, np.array([[0.0], [0.0], [1.0]]))
    p_cam = v if distance_m is None else v * distance_m
    n, N = len(poses), q.shape[1]
    dpc = np.zeros((N, 3, 6 * n))
    R_all, A = np.empty((4, 3, 3)), np.empty((12, N))
    for i, T in enumerate(poses):
        R, t = T[:3, :3], T[:3, 3]
        x6 = params_from_T(T)
        if distance_m is None:
            x6[:3] = 0.0
            p_f = R @ p_cam
        else:
            p_f = R @ p_cam + t[:, None]
            dpc[:, :, 6 * i: 6 * i + 3] = -R.T / n
        camera_points(np.ascontiguousarray(x6), np.ascontiguousarray(p_f), R_all, A)
        for k in range(3):
            dpc[:, :, 6 * i + 3 + k] = A[3 * k + 3: 3 * k + 6].T / n
    with np.errstate(divide="ignore", invalid="ignore"):
        _, G = camera.project_jacobian(p_cam)
        Jp = camera.parameter_jacobian(p_cam)
    J = np.concatenate([Jp, np.asarray(G) @ dpc], axis=2)
    J[~good] = np.nan
    return J, p_cam


def projection_uncertainty(camera, poses, joint_cov, points_px, distance_m=None) -> ProjectionUncertainty:
    """The projection uncertainty at pixels (the module docstring).

    Parameters
    ----------
    camera : Camera
        The calibrated camera.
    poses : list of (4, 4) ndarray
        ``T_WC`` of the views the calibration used, in the order of ``joint_cov``.
    joint_cov : (P + 6 n, P + 6 n) ndarray
        The joint covariance of the intrinsics and those poses.
    points_px : (2, N) array_like
        Pixels (u, v).
    distance_m : float, optional
        Distance along each ray, metres (> 0); None: at infinity.

    Returns
    -------
    ProjectionUncertainty
    """
    if distance_m is not None:
        distance_m = float(distance_m)
        if not (np.isfinite(distance_m) and distance_m > 0):
            raise InputError(f"distance_m must be a positive distance in metres or None (infinity), got {distance_m}")
    J, _ = projection_jacobian(camera, poses, points_px, distance_m)
    if joint_cov.shape != (J.shape[2], J.shape[2]):
        raise InputError(f"joint_cov must be {J.shape[2]} x {J.shape[2]} (the intrinsics and {len(poses)} poses), "
                         f"got {joint_cov.shape}")
    S = J @ joint_cov @ J.transpose(0, 2, 1)
    S = 0.5 * (S + S.transpose(0, 2, 1))
    return ProjectionUncertainty(np.asarray(points_px, float), distance_m, S, worst_direction_sigma(S))


def worst_direction_sigma(S) -> np.ndarray:
    """``sqrt(largest eigenvalue)`` of each 2 x 2 covariance (N, 2, 2)."""
    tr, det = S[:, 0, 0] + S[:, 1, 1], S[:, 0, 0] * S[:, 1, 1] - S[:, 0, 1] * S[:, 1, 0]
    return np.sqrt(np.maximum(0.5 * tr + np.sqrt(np.maximum(0.25 * tr * tr - det, 0.0)), 0.0))


def aligned_difference(camera, poses, reference, reference_poses, points_px, distance_m=None) -> np.ndarray:
    """What the projection uncertainty describes, measured: the pixel of a point through
    ``camera`` after mrcal's alignment with a ``reference`` solve of the same views (the truth
    of a rendered set, say).

    The reference camera's point at each pixel (at ``distance_m`` along its ray; None: at
    infinity) is carried into every view's board frame through the reference's poses, back
    through ``poses`` as their mean (at infinity: the rotations only), and projected by
    ``camera``.

    Parameters
    ----------
    camera, reference : Camera
    poses, reference_poses : sequence of (4, 4) ndarray
        ``T_WC`` of the same views in the same board frames.
    points_px : (2, N) array_like
    distance_m : float, optional

    Returns
    -------
    d : (2, N) ndarray
        ``camera``'s pixel minus ``points_px``.
    """
    q = as_points(points_px, 2, "points_px", min_count=0)
    if len(poses) != len(reference_poses) or not len(poses):
        raise InputError(f"poses and reference_poses must be the same views, got {len(poses)} and "
                         f"{len(reference_poses)}")
    v = reference.unproject(q)
    p = v if distance_m is None else v * distance_m
    acc = 0.0
    for Te, Tt in zip(poses, reference_poses):
        if distance_m is None:
            acc = acc + Te[:3, :3].T @ (Tt[:3, :3] @ p)
        else:
            acc = acc + Te[:3, :3].T @ (Tt[:3, :3] @ p + Tt[:3, 3:4] - Te[:3, 3:4])
    return camera.project(acc / len(poses)) - q

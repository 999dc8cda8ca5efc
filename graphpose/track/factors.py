"""The back end's own GTSAM factors, written in Python (``gtsam.CustomFactor``).

- :func:`resection_factor`: one factor holding all the junctions of a frame, the camera's
  projection (:mod:`graphpose.camera_models`, lens distortion included) of the FIXED target
  points, with its analytic Jacobian. It is the limit of the
  landmark forms of :mod:`graphpose.track.backend` as their prior sigma goes to 0.
- :func:`constant_velocity_factor`: a three-pose factor saying the body-frame twist stays
  the same from one frame interval to the next.

Pose tangent vectors are GTSAM's: rotation (rad) first, then translation (m), in the body
(camera) frame, for the right perturbation ``T Exp(omega, v)``.
"""

from __future__ import annotations

import gtsam
import numpy as np

from .._checks import as_points, check_number
from ..camera_models import as_camera
from ..errors import InputError


def resection_factor(key, points, Wpts, camera, pixel_sigma: float) -> gtsam.CustomFactor:
    """One factor holding a frame's junctions: the camera's projection of fixed target points.

    Parameters
    ----------
    key : int
        GTSAM key of the frame's ``Pose3`` (``T_WC``).
    points : (2, m) ndarray
        Measured pixels (u, v).
    Wpts : (3, m) ndarray
        The matching target points, metres; fixed.
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`), or pinhole intrinsics ``K``, pixels.
    pixel_sigma : float
        Isotropic standard deviation of a measured pixel coordinate.

    Returns
    -------
    gtsam.CustomFactor
        Error ``(u_1 - u'_1, v_1 - v'_1, ...)`` of length 2m (predicted minus measured),
        with its analytic Jacobian for the right perturbation ``T Exp(omega, v)``:
        ``dp_C = [p_C]_x omega - v``, chained with the camera's ``d uv / d p_C``
        (:meth:`graphpose.camera_models.Camera.project_jacobian`). A point at or behind the
        camera gives GTSAM's constant ``2 fx`` error with a zero Jacobian, as GTSAM's own
        projection factors do.

    Raises
    ------
    InputError
        If ``points`` or ``Wpts`` is malformed or not finite, their counts differ, the
        camera is malformed, or ``pixel_sigma`` is not a positive finite number.
    """
    points = as_points(points, 2, "points")
    Wpts = as_points(Wpts, 3, "Wpts")
    m = points.shape[1]
    if Wpts.shape[1] != m:
        raise InputError(f"points and Wpts must hold the same number of points, got {m} and {Wpts.shape[1]}")
    check_number("pixel_sigma", pixel_sigma, 0.0, strict=True)
    camera = as_camera(camera)
    behind = 2.0 * camera.fx
    noise = gtsam.noiseModel.Isotropic.Sigma(2 * m, pixel_sigma)

    def error(factor, values, jacobians):
        T = values.atPose3(factor.keys()[0])
        P = T.rotation().matrix().T @ (Wpts - T.translation()[:, None])
        front = P[2] > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            uv, G = camera.project_jacobian(P)  # G: (m, 2, 3), d uv / d p_C
        e = np.where(front, uv - points, behind).T.ravel()
        if jacobians is not None:
            G = np.where(front[:, None, None], G, 0.0)
            # d uv / d omega = g x p_C for each row g of G (g . ([p_C]x omega) = omega . (g x p_C)).
            Pt = P.T
            J = np.empty((2 * m, 6))
            J[0::2, :3], J[0::2, 3:] = np.cross(G[:, 0], Pt), -G[:, 0]
            J[1::2, :3], J[1::2, 3:] = np.cross(G[:, 1], Pt), -G[:, 1]
            jacobians[0] = J
        return e

    return gtsam.CustomFactor(noise, [key], error)


def constant_velocity_factor(ka, kb, kc, ratio: float, noise) -> gtsam.CustomFactor:
    """Three-pose factor: the body-frame twist of the second interval is ``ratio`` times the first's.

    Parameters
    ----------
    ka, kb, kc : int
        GTSAM keys of three consecutive ``Pose3`` variables ``A, B, C``.
    ratio : float
        ``dt_2 / dt_1``, the second frame interval over the first.
    noise : gtsam.noiseModel.Base
        Six-dimensional noise model, rotation (rad) then translation (m).

    Returns
    -------
    gtsam.CustomFactor
        Error ``Log(B^-1 C) - ratio Log(A^-1 B)`` (rotation first), with exact Jacobians
        through GTSAM's ``between`` and ``Logmap`` derivatives.
    """

    def error(factor, values, jacobians):
        A, B, C = (values.atPose3(key) for key in factor.keys())
        Ha, Hb1, Hb2, Hc = (np.zeros((6, 6), order="F") for _ in range(4))
        L1, L2 = np.zeros((6, 6), order="F"), np.zeros((6, 6), order="F")
        v1 = gtsam.Pose3.Logmap(A.between(B, Ha, Hb1), L1)
        v2 = gtsam.Pose3.Logmap(B.between(C, Hb2, Hc), L2)
        if jacobians is not None:
            jacobians[0] = -ratio * L1 @ Ha
            jacobians[1] = L2 @ Hb2 - ratio * L1 @ Hb1
            jacobians[2] = L2 @ Hc
        return v2 - ratio * v1

    return gtsam.CustomFactor(noise, [ka, kb, kc], error)

"""The back end's own GTSAM factors, written in Python (``gtsam.CustomFactor``).

- :func:`resection_factor`: one factor holding all the junctions of a frame, the camera's
  projection (:mod:`graphpose.camera_models`, lens distortion included) of the FIXED target
  points, with its analytic Jacobian. It is the limit of the
  landmark forms of :mod:`graphpose.track.backend` as their prior sigma goes to 0. GTSAM has
  no factor of its own for it (its C++ ``ResectioningFactor`` is an example, not in the
  Python bindings, whose own example is a ``CustomFactor``), so its error is one call of the
  compiled kernel :mod:`graphpose.track._resection` (the pinhole written out; another camera's
  projection and ``d uv / d p_C`` from its model, chained there).
- :func:`constant_velocity_factor`: a three-pose factor saying the body-frame twist stays
  the same from one frame interval to the next.

Pose tangent vectors are GTSAM's: rotation (rad) first, then translation (m), in the body
(camera) frame, for the right perturbation ``T Exp(omega, v)``.
"""

from __future__ import annotations

import gtsam
import numpy as np

from .._checks import as_points, check_number
from ..camera_models import PinholeCamera, as_camera
from ..errors import InputError
from ._resection import camera_frame, model_resection, pinhole_resection

#: Stands in for the Jacobian (and the model's d uv / d p_C) when none is asked for.
_NO_JACOBIAN, _NO_G = np.empty((0, 6)), np.empty((0, 2, 3))


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
    return _resection_factor(key, points, Wpts, as_camera(camera), float(pixel_sigma))


def _resection_factor(key, points, Wpts, camera, pixel_sigma: float) -> gtsam.CustomFactor:
    """:func:`resection_factor` on inputs already checked (a camera object, finite float
    (2, m) and (3, m) arrays, a positive sigma): the back end's frames, checked at the
    tracker's edge, build their factors through it."""
    points, Wpts = np.ascontiguousarray(points, dtype=float), np.ascontiguousarray(Wpts, dtype=float)
    m = points.shape[1]
    behind = 2.0 * camera.fx
    noise = gtsam.noiseModel.Isotropic.Sigma(2 * m, pixel_sigma)

    if isinstance(camera, PinholeCamera):
        K = np.ascontiguousarray(camera.K, dtype=float)

        def error(factor, values, jacobians):
            T = values.atPose3(factor.keys()[0]).matrix()
            e = np.empty(2 * m)
            if jacobians is None:
                pinhole_resection(T, Wpts, points, K, behind, e, _NO_JACOBIAN, False)
            else:
                J = np.empty((2 * m, 6))
                pinhole_resection(T, Wpts, points, K, behind, e, J, True)
                jacobians[0] = J
            return e

        return gtsam.CustomFactor(noise, [key], error)

    def error(factor, values, jacobians):
        P = np.empty((3, m))
        camera_frame(values.atPose3(factor.keys()[0]).matrix(), Wpts, P)
        e = np.empty(2 * m)
        with np.errstate(divide="ignore", invalid="ignore"):
            if jacobians is None:
                model_resection(P, np.ascontiguousarray(camera.project(P)), _NO_G, points, behind, e,
                                _NO_JACOBIAN, False)
            else:
                uv, G = camera.project_jacobian(P)  # G: (m, 2, 3), d uv / d p_C
                J = np.empty((2 * m, 6))
                model_resection(P, np.ascontiguousarray(uv), np.ascontiguousarray(G, dtype=float), points, behind,
                                e, J, True)
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
        a, b, c = factor.keys()
        A, B, C = values.atPose3(a), values.atPose3(b), values.atPose3(c)
        if jacobians is None:
            return gtsam.Pose3.Logmap(B.between(C)) - ratio * gtsam.Pose3.Logmap(A.between(B))
        # between's derivative by its second pose is the identity (GTSAM's LieGroup::between).
        Ha, Hb, L1, L2 = (np.zeros((6, 6), order="F") for _ in range(4))
        v1 = gtsam.Pose3.Logmap(A.between(B, Ha), L1)
        v2 = gtsam.Pose3.Logmap(B.between(C, Hb), L2)
        jacobians[0] = -ratio * L1 @ Ha
        jacobians[1] = L2 @ Hb - ratio * L1
        jacobians[2] = L2
        return v2 - ratio * v1

    return gtsam.CustomFactor(noise, [ka, kb, kc], error)

"""The intrinsic parameters a calibration estimates, and the projection's derivative in them.

It sits beside the camera models (:mod:`graphpose.camera_models`), below everything that uses a
calibration's uncertainty: the calibration (:mod:`graphpose.calibrate`, which re-exports these
functions), the camera files' ``parameters`` and ``covariance`` (:mod:`graphpose.io`), and the
pose covariance that includes the calibration's (:mod:`graphpose.pose.covariance`). Parameter vectors are in OpenCV's order, pixels and unitless:

=========  ==================================================
model      parameters
=========  ==================================================
pinhole    ``fx, fy, cx, cy``
radtan     ``fx, fy, cx, cy, k1, k2, p1, p2, k3`` (``calibrateCamera``'s five coefficients)
rational   ``fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6`` (its ``CALIB_RATIONAL_MODEL``)
fisheye    ``fx, fy, cx, cy, k1, k2, k3, k4`` (``cv::fisheye``'s)
=========  ==================================================

What is not a parameter stays as the camera has it: the skew ``K[0, 1]`` of a pinhole or
fisheye camera (a calibration finds none: it fixes it at 0, as OpenCV does by default), and a
rational radial-tangential camera's ``k4, k5, k6`` (the denominator of its radial factor).

- :func:`parameter_names` ``(camera_or_model)``: the names, in order;
- :func:`camera_parameters` ``(camera)``: the (P,) vector;
- :func:`camera_with_parameters` ``(camera, p, covariance=None)``: the camera of the same model
  and image size with those parameters (and, if given, their (P, P) covariance);
- :func:`projection_jacobian_intrinsics` ``(camera, P_C)``: ``d uv / d p``, (N, 2, P), analytic,
  for camera-frame points: the calibration's Jacobian, and the map that carries the
  parameters' covariance into pixels (``J cov J^T``).

The camera's own ``covariance`` (:mod:`graphpose.camera_models`) is in the same order.
"""

from __future__ import annotations

import numpy as np

from ._checks import as_float_array, as_points
from .camera_models import Camera, FisheyeCamera, PinholeCamera, RadTanCamera, RationalCamera, as_camera
from .errors import InputError

#: The camera class of each model name.
MODELS = {"pinhole": PinholeCamera, "radtan": RadTanCamera, "rational": RationalCamera, "fisheye": FisheyeCamera}


#: Calibration models that hold some of a camera model's parameters at 0, not estimated: name ->
#: (the camera model, the parameters held). ``radtan4`` is Kalibr's pinhole-radtan: OpenCV's
#: radial-tangential camera with ``k1, k2, p1, p2`` and ``k3 = 0``.
HELD_MODELS = {"radtan4": ("radtan", ("k3",))}


def calibration_model(model: str):
    """The camera class of a calibration model and the mask of its parameters held at 0.

    Parameters
    ----------
    model : str
        A model of :data:`MODELS`, or of :data:`HELD_MODELS` (``"radtan4"``).

    Returns
    -------
    cls : type
        The camera class.
    held : (P,) ndarray of bool
        True for each parameter (:func:`parameter_names` order) held at 0; all False for a
        model of :data:`MODELS`.

    Raises
    ------
    InputError
        For a model graphpose does not know (the message names those it knows).
    """
    base, names = HELD_MODELS.get(model, (model, ())) if isinstance(model, str) else (model, ())
    if not isinstance(base, str) or base not in MODELS:
        raise InputError(f"unknown camera model {model!r}: graphpose's models are "
                         f"{', '.join([*MODELS, *HELD_MODELS])}")
    cls = MODELS[base]
    return cls, np.isin(cls.parameter_names, names)


def model_class(model: str) -> type:
    """The camera class of a model name, or InputError naming the models there are."""
    if not isinstance(model, str) or model not in MODELS:
        raise InputError(f"unknown camera model {model!r}: graphpose's models are "
                         f"{', '.join(MODELS)}")
    return MODELS[model]


def parameter_names(camera_or_model) -> tuple:
    """The names of a model's intrinsic parameters, in the order of every parameter vector.

    Parameters
    ----------
    camera_or_model : Camera or str
        A camera, or a model name ``"pinhole"``, ``"radtan"``, ``"fisheye"``.

    Returns
    -------
    names : tuple of str
        ``("fx", "fy", "cx", "cy")`` for the pinhole, ``+ ("k1", "k2", "p1", "p2", "k3")``
        for radtan (OpenCV's order), ``+ ("k1", "k2", "k3", "k4")`` for the fisheye.

    Raises
    ------
    InputError
        For a model name graphpose does not know, or anything else than a camera or a name.
    """
    if isinstance(camera_or_model, Camera):
        return type(camera_or_model).parameter_names
    return model_class(camera_or_model).parameter_names


def _camera(camera) -> Camera:
    if not isinstance(camera, Camera):
        raise InputError(f"camera must be a graphpose camera (PinholeCamera, RadTanCamera, "
                         f"FisheyeCamera), got {type(camera).__name__}")
    return camera


def camera_parameters(camera) -> np.ndarray:
    """A camera's intrinsic parameters in :func:`parameter_names` order.

    Parameters
    ----------
    camera : Camera

    Returns
    -------
    p : (P,) ndarray
        ``fx, fy, cx, cy`` (pixels) and the model's coefficients (unitless).
    """
    camera = _camera(camera)
    head = [camera.fx, camera.fy, camera.cx, camera.cy]
    if isinstance(camera, RationalCamera):
        return np.array(head + list(camera.coefficients))
    if isinstance(camera, RadTanCamera):
        return np.array(head + list(camera.coefficients[:5]))
    if isinstance(camera, FisheyeCamera):
        return np.array(head + list(camera.distortion))
    return np.array(head)


def camera_with_parameters(camera, p, covariance=None) -> Camera:
    """The camera of the same model and image size with other intrinsic parameters.

    Parameters
    ----------
    camera : Camera
        The model, the image size, and what is not a parameter (skew; a rational camera's
        k4..k6) come from it.
    p : (P,) array_like
        The parameters in :func:`parameter_names` order.
    covariance : (P, P) array_like, optional
        Their covariance, carried by the new camera (checked there); None: unknown.

    Returns
    -------
    camera : Camera
        Of the same class; a radial-tangential camera keeps 5 coefficients (8 if it had 8).

    Raises
    ------
    InputError
        If ``p`` is not P finite numbers, makes an invalid camera (a focal length <= 0), or
        ``covariance`` is not a (P, P) symmetric positive semi-definite matrix.
    """
    camera = _camera(camera)
    names = parameter_names(camera)
    p = as_float_array(p, "parameters").ravel()
    if p.size != len(names):
        raise InputError(f"a {camera.model} camera has {len(names)} parameters "
                         f"({', '.join(names)}), got {p.size}")
    if not np.all(np.isfinite(p)):
        raise InputError(f"parameters contain NaN or infinite values: {p.tolist()}")
    K = np.array([[p[0], camera.skew, p[2]], [0.0, p[1], p[3]], [0.0, 0.0, 1.0]])
    if isinstance(camera, RationalCamera):
        return RationalCamera(K, p[4:12], camera.size, covariance)
    if isinstance(camera, RadTanCamera):
        full = camera.coefficients
        d = np.r_[p[4:9], full[5:]] if camera.distortion.size == 8 else p[4:9]
        return RadTanCamera(K, d, camera.size, covariance)
    if isinstance(camera, FisheyeCamera):
        return FisheyeCamera(K, p[4:8], camera.size, covariance)
    return PinholeCamera(K, camera.size, covariance)


def projection_jacobian_intrinsics(camera, P_C) -> np.ndarray:
    """The derivative of the pixels of camera-frame points with respect to the intrinsics.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        A camera model, or a pinhole ``K``.
    P_C : (3, N) array_like
        Points in the camera frame, metres.

    Returns
    -------
    J : (N, 2, P) ndarray
        ``J[j, :, i] = d uv_j / d p_i``, in :func:`parameter_names` order (pixels per
        pixel for ``fx, fy, cx, cy``, pixels per unit for the coefficients), the skew held
        fixed; NaN rows where :meth:`Camera.project` is NaN.

    Raises
    ------
    InputError
        If ``P_C`` is not a finite (3, N) array.
    """
    camera = as_camera(camera)
    P = as_points(P_C, 3, "P_C", min_count=0)
    uv = camera.project(P)
    # The lens's normalised coordinates from the pixels: u = fx x_d + s y_d + cx, v = fy y_d + cy.
    yd = (uv[1] - camera.cy) / camera.fy
    xd = (uv[0] - camera.cx - camera.skew * yd) / camera.fx
    n = P.shape[1]
    J = np.zeros((n, 2, len(parameter_names(camera))))
    J[:, 0, 0], J[:, 1, 1] = xd, yd
    J[:, 0, 2] = J[:, 1, 3] = 1.0
    if isinstance(camera, RadTanCamera):
        Z = np.where(P[2] > 0, P[2], np.nan)
        x, y = P[0] / Z, P[1] / Z
        r2 = x * x + y * y
        k4, k5, k6 = camera.coefficients[5:]
        b = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))  # the rational denominator (1 without it)
        # d(x_d, y_d)/d(k1, k2, p1, p2, k3), then times (fx, fy): no skew in this model.
        radial = np.stack([r2, r2 * r2, r2 ** 3]) / b  # d g / d(k1, k2, k3)
        dx = np.stack([x * radial[0], x * radial[1], 2.0 * x * y, r2 + 2.0 * x * x, x * radial[2]])
        dy = np.stack([y * radial[0], y * radial[1], r2 + 2.0 * y * y, 2.0 * x * y, y * radial[2]])
        J[:, 0, 4:9] = (camera.fx * dx).T
        J[:, 1, 4:9] = (camera.fy * dy).T
        if isinstance(camera, RationalCamera):
            # g = a / b: d g / d(k4, k5, k6) = -a (r^2, r^4, r^6) / b^2.
            k1, k2, _, _, k3 = camera.coefficients[:5]
            a = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
            dg = -a * np.stack([r2, r2 * r2, r2 ** 3]) / (b * b)
            J[:, 0, 9:] = (camera.fx * x * dg).T
            J[:, 1, 9:] = (camera.fy * y * dg).T
    elif isinstance(camera, FisheyeCamera):
        X, Y, Z = P
        rho = np.hypot(X, Y)
        th = np.arctan2(rho, Z)
        t = th * th
        # d theta_d / d k_i = theta t^i; (x_d, y_d) = theta_d (X, Y) / rho, whose limit on the
        # forward axis has zero derivative in every k_i.
        safe = np.where(rho > 0, rho, 1.0)
        powers = np.stack([th * t, th * t * t, th * t ** 3, th * t ** 4])
        dx = np.where(rho > 0, powers * X / safe, 0.0)
        dy = np.where(rho > 0, powers * Y / safe, 0.0)
        J[:, 0, 4:] = (camera.fx * dx + camera.skew * dy).T
        J[:, 1, 4:] = (camera.fy * dy).T
    J[~np.all(np.isfinite(uv), axis=0)] = np.nan
    return J

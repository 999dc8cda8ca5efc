"""The calibration's uncertainty carried into the pose, to first order.

The pose minimises the (weighted) reprojection cost ``1/2 r^T W r``, ``r = u - pi(theta, k)``,
for the intrinsics ``k`` the camera file gives. Were ``k`` a little different, the minimum
would move: at the minimum ``J_p^T W r = 0``, and differentiating it with respect to ``k``
(the implicit function theorem; second derivatives of ``pi`` dropped, as Gauss-Newton drops
them) gives

    d theta / d k = -(J_p^T W J_p)^-1 J_p^T W J_k,

with ``J_p = d pi / d theta`` (:func:`graphpose.pose.gauss_newton.projection_jacobians`, the
pose parameters ``(x, y, z, roll, pitch, yaw)``) and ``J_k = d pi / d k``
(the camera's ``parameter_jacobian`` at the pose's camera-frame
points). The pixel noise and the calibration's error are independent (the calibration was
made from other images), so

    cov = cov_pixel + D cov_k D^T,   D = d theta / d k,

in the parameterisation :class:`graphpose.estimate.PoseEstimate` reports ``cov`` in.
``W`` is the identity for least squares, the Huber weights at the solution for a robust fit.

The term does not shrink with more junctions: ``cov_pixel`` falls as 1/n, ``D cov_k D^T``
does not (every junction of an image sees the same ``k``). A focal length known to 0.1 %
alone leaves a board 1 m away uncertain by about 1 mm along the axis.
"""

from __future__ import annotations

import numpy as np

from ..geometry import to_camera
from .gauss_newton import projection_jacobians

#: ``PoseEstimate.sigma_kind``: what the reported covariance describes.
SIGMA_PIXEL = "pixel noise"
SIGMA_CALIBRATION = "pixel noise and calibration"


def pose_intrinsics_jacobian(camera, T_WC, Wpts, weights=None) -> np.ndarray:
    """How the fitted pose moves with the intrinsics: ``d theta / d k`` at a solution.

    Parameters
    ----------
    camera : Camera
        The camera the pose was fitted with (trusted).
    T_WC : (4, 4) ndarray
        The fitted pose (a minimum of the reprojection cost).
    Wpts : (3, m) ndarray
        The target points the fit used, metres (all in front of the camera).
    weights : (2m,) ndarray, optional
        The fit's weight of each residual, ``(u0, v0, u1, ...)``; ones (least squares) when
        None.

    Returns
    -------
    D : (6, P) ndarray
        ``d(x, y, z, roll, pitch, yaw) / d k``, metres and radians per unit of each
        parameter of the camera's ``parameter_names``.
    """

    Jp = projection_jacobians(camera, T_WC, Wpts)  # (2m, 6)
    Jk = camera.parameter_jacobian(to_camera(T_WC, Wpts))  # (m, 2, P)
    Jk = Jk.reshape(Jp.shape[0], -1)  # rows (u0, v0, u1, ...), as Jp's
    Jw = Jp if weights is None else Jp * np.asarray(weights)[:, None]
    return -np.linalg.solve(Jw.T @ Jp, Jw.T @ Jk)


def pose_cov_with_intrinsics(camera, T_WC, Wpts, cov_pixel, weights=None) -> np.ndarray:
    """The pose covariance with the camera's intrinsics' covariance added (module docstring).

    Parameters
    ----------
    camera : Camera
        The camera the pose was fitted with, carrying ``covariance`` (P, P) (trusted).
    T_WC : (4, 4) ndarray
        The fitted pose.
    Wpts : (3, m) ndarray
        The target points the fit used, metres.
    cov_pixel : (6, 6) ndarray
        The pose covariance from the pixel noise alone, in ``(x, y, z, roll, pitch, yaw)``.
    weights : (2m,) ndarray, optional
        As :func:`pose_intrinsics_jacobian`.

    Returns
    -------
    cov : (6, 6) ndarray
        ``cov_pixel + D cov_k D^T``, m and rad, symmetric.
    """
    D = pose_intrinsics_jacobian(camera, T_WC, Wpts, weights)
    cov = np.asarray(cov_pixel) + D @ np.asarray(camera.covariance) @ D.T
    return 0.5 * (cov + cov.T)

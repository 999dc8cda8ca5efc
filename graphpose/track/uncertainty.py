"""The calibration's uncertainty in the tracked poses: :func:`frame_covariance`.

A camera read from a calibration (``graphpose calibrate``) may carry the covariance of its
intrinsic parameters (:mod:`graphpose.camera_models`). Each tracked pose then reports a
covariance that includes it, beside the pixel-noise-only covariance of the back end, and
says which kind it is (``sigma_kind``, the convention of
:class:`graphpose.estimate.PoseEstimate`).

The propagation is first order and per frame, the single image's
(:func:`graphpose.pose.covariance.pose_cov_with_intrinsics`): at the back end's pose ``T_WC``
of frame ``k``, ``D_k = d theta_k / d k`` is how the least-squares resection of that frame's
junctions moves with the intrinsics, and

    cov_k = cov_pixel_k + D_k cov_intrinsics D_k^T,

``cov_pixel_k`` the back end's marginal (pixel noise through the smoother, motion prior
included; the intrinsics taken as exact).

What the per-frame sigma means
------------------------------
The calibration's error is ONE error, common to every frame of the sequence: the frames'
calibration terms are correlated (frames ``j`` and ``k`` share ``D_j cov_intrinsics D_k^T``),
not independent draws. So the motion prior cannot average it away, and ``D_k`` (the frame's
own resection) is the right sensitivity: neighbouring frames move the same way. The
per-frame sigma is the marginal 1-sigma of that frame's pose over both the pixel noise and
the calibration's error; the error of a whole trajectory does not shrink as the square root
of its length, and differences between nearby frames (the relative motion) are much better
known than either sigma says, since the common part cancels in them.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..pose.covariance import SIGMA_CALIBRATION, SIGMA_PIXEL, pose_cov_with_intrinsics


def frame_covariance(camera, T_WC, Wpts, cov_pixel) -> tuple:
    """A tracked frame's covariance with the calibration's, and its kind.

    Parameters
    ----------
    camera : Camera
        The sequence's camera (trusted), with or without ``covariance``.
    T_WC : (4, 4) ndarray
        The frame's pose (the back end's).
    Wpts : (3, m) ndarray
        The target points of the frame's junctions, metres.
    cov_pixel : (6, 6) ndarray
        The back end's covariance of ``(x, y, z, roll, pitch, yaw)`` (m, rad).

    Returns
    -------
    cov : (6, 6) ndarray
        ``cov_pixel`` for a camera without a covariance; else ``cov_pixel + D cov_k D^T``
        (NaN where the frame's normal equations are singular).
    sigma_kind : str
        :data:`~graphpose.pose.covariance.SIGMA_PIXEL` or
        :data:`~graphpose.pose.covariance.SIGMA_CALIBRATION`.
    """
    if getattr(camera, "covariance", None) is None:
        return cov_pixel, SIGMA_PIXEL
    try:
        return pose_cov_with_intrinsics(camera, T_WC, Wpts, cov_pixel), SIGMA_CALIBRATION
    except (np.linalg.LinAlgError, InputError):  # singular normal equations; a point behind
        return np.full((6, 6), np.nan), SIGMA_CALIBRATION

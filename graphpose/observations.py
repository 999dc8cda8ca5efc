"""The check of a pose problem's inputs at its public edge: a camera, image points that may be
NaN where unseen, target points and a trust mask (:func:`check_observations`).

It sits beside the camera models it coerces to (:mod:`graphpose.camera_models`), above
:mod:`graphpose._checks`, whose array checks it uses."""

from __future__ import annotations

import numpy as np

from ._checks import as_float_array, check_correspondences
from .camera_models import as_camera
from .errors import InputError

#: Fewest junctions a pose rests on (six, not all on one line): the detector's verdict
#: (:func:`graphpose.detect.junctions.extract_junctions`) and the pipeline
#: (:func:`graphpose.estimate.estimate_pose`) refuse fewer trusted ones.
MIN_JUNCTIONS = 6


def check_observations(camera, Ipts, Wpts, mask=None):
    """Validate a camera, image and target points and a trust mask at a public edge.

    As :func:`graphpose._checks.check_correspondences`, with a camera object accepted for
    ``K`` and image points that may be NaN where the mask leaves them out (junctions the
    image does not show, :class:`graphpose.detect.junctions.Junctions`).

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        A camera model (:mod:`graphpose.camera_models`) or pinhole intrinsics, pixels.
    Ipts : (2, n) array_like
        Image points (u, v), pixels; NaN allowed where ``mask`` is False.
    Wpts : (3, n) array_like
        Matching target points, metres.
    mask : (n,) array_like of bool, optional
        The points to use; all when None.

    Returns
    -------
    camera : Camera
    Ipts : (2, n) ndarray
    Wpts : (3, n) ndarray
    mask : (n,) ndarray of bool

    Raises
    ------
    InputError
        As :func:`graphpose._checks.check_correspondences`, and if a used point is NaN.
    """
    camera = as_camera(camera)
    Ipts = as_float_array(Ipts, "Ipts")
    finite = np.isfinite(Ipts)
    shown = np.where(finite, Ipts, 0.0) if Ipts.ndim == 2 and Ipts.shape[0] == 2 else Ipts
    _, _, Wpts, mask = check_correspondences(camera.K, shown, Wpts, mask)
    bad = np.flatnonzero(mask & ~np.all(finite, axis=0))
    if bad.size:
        raise InputError(f"Ipts contains NaN or infinite values at {bad.size} used point(s) (first index "
                         f"{bad[0]}); leave unmeasured points out with the mask")
    return camera, Ipts, Wpts, mask

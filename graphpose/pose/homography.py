"""A linear first pose from the plane-to-image homography, so no guess is needed.

The target is the plane z = 0, so a target point ``(x, y, 0)`` images as

    [u, v, 1]^T ~ K [r1 r2 t_CW] [x, y, 1]^T,

with ``C^T = [r1 r2 r3]`` the rotation from target to camera and ``t_CW = -C^T t`` (see
:mod:`graphpose.geometry`). The homography ``H ~ K [r1 r2 t_CW]`` is found by the normalised
direct linear transform (:func:`graphpose.geometry.homography_dlt`, Hartley & Zisserman, Multiple View Geometry, 2nd ed., alg. 4.2) and
split with K into a rotation (made orthonormal: the nearest rotation, the orthogonal polar
factor) and a translation whose sign puts the board in front of the camera, in one compiled
call (:func:`graphpose.pose._homography.homography_pose`). The result minimises an algebraic error, not the reprojection
error: it is a starting point for :func:`graphpose.pose.gauss_newton.gauss_newton`.

A camera with lens distortion (:mod:`graphpose.camera_models`) is handled by undistorting the image
points first (:meth:`graphpose.camera_models.Camera.undistort_pixels`, to the pixels of the
distortion-free camera with the same ``K``): the homography holds for those.
"""

from __future__ import annotations

import numpy as np

from ..observations import check_observations
from ..errors import DegenerateGeometryError, InputError
from ..geometry import homography_dlt
from ._homography import homography_pose

#: Target points farther than this (metres, relative to the board's extent) from z = 0 are refused.
_PLANE_TOL = 1e-6

def pose_from_homography(Ipts, Wpts, camera, *, check: bool = True) -> np.ndarray:
    """Camera pose from the homography between the target plane and the image.

    Parameters
    ----------
    Ipts : (2, n) array_like
        Image points (u, v), pixels; n >= 4.
    Wpts : (3, n) array_like
        Matching target points on the plane z = 0, metres.
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`; the points are then raw pixels,
        undistorted here), or pinhole intrinsics ``K``, pixels.

    check : bool
        False skips the input checks, for a caller that checked the inputs at its own edge
        (a camera object, float arrays of the right shapes, every point used; the plane and
        the geometry are still checked): pytransform3d's
        ``check=False``.

    Returns
    -------
    T_WC : (4, 4) ndarray
        Camera pose in the target frame, every point in front of the camera.

    Raises
    ------
    InputError
        If the input is malformed, the target points are not on z = 0 or fewer than 4 are
        given.
    DegenerateGeometryError
        If the points are degenerate (collinear or repeated, so no homography is fixed), no
        sign of the decomposition puts all the points in front of the camera, or a point
        lies where the camera's lens model has no ray in front of it.
    """
    if check:
        camera, Ipts, Wpts, _ = check_observations(camera, Ipts, Wpts)
    if not on_target_plane(Wpts):
        raise InputError("Wpts must lie on the target plane z = 0 for the homography initialiser")
    K = camera.K
    if np.any(camera.distortion):
        Ipts = camera.undistort_pixels(Ipts)
        bad = np.flatnonzero(~np.all(np.isfinite(Ipts), axis=0))
        if bad.size:
            raise DegenerateGeometryError(
                f"{bad.size} image point(s) (first index {bad[0]}) lie where the {camera.model} camera's "
                "lens model has no ray in front of the camera: no homography start")
    T = np.empty((4, 4))
    if not homography_pose(K, homography_dlt(Wpts[:2], Ipts), np.ascontiguousarray(Wpts[:2]), T):
        raise DegenerateGeometryError("no pose from the homography puts every target point in front of the camera")
    if not np.all(np.isfinite(T)):  # r1 and r2 (nearly) parallel: no rotation is near them
        raise DegenerateGeometryError("the homography gives no rotation (its first two columns are parallel)")
    return T


def on_target_plane(Wpts) -> bool:
    """Whether target points lie on the plane z = 0, to within rounding of their coordinates.

    Parameters
    ----------
    Wpts : (3, n) ndarray
        Target points, metres (trusted: validated by the caller).

    Returns
    -------
    bool
        True when every ``|z|`` is at most 1e-6 of the points' extent in x and y (at least
        1e-6 m): the tolerance the homography initialiser accepts.
    """
    extent = max(1.0, float(np.max(np.abs(Wpts[:2]))))
    return bool(np.max(np.abs(Wpts[2])) <= _PLANE_TOL * extent)

"""Camera model and the conventions that every module of graphpose uses.

Conventions (one set, everywhere; the README repeats them)
-----------------------------------------------------------
Pixels
    ``(u, v) = (column, row)``, 0-based: the centre of the top-left pixel is (0, 0) and
    pixel ``(u, v)`` covers ``[u - 0.5, u + 0.5] x [v - 0.5, v + 0.5]``. Arrays of image
    points are 2 x N (row 0 = u, row 1 = v); arrays of 3-D points are 3 x N.
Target (world) frame W
    Origin at the upper-left inner cross-junction, x to the right along a row, y down to
    the next row, z into the board; the board is the plane z = 0 (see :mod:`graphpose.board`).
Camera frame C
    x right, y down in the image, z along the optical axis (the camera looks along +z).
Pose
    ``T_WC`` is the 4 x 4 pose of the camera in the target frame. A target point ``p_W``
    maps into the camera frame as ``p_C = C^T (p_W - t)`` with ``C = T_WC[:3, :3]`` and
    ``t = T_WC[:3, 3]``; a camera in front of the board has ``t_z < 0``. This is the same
    object as GTSAM's ``Pose3`` of a camera in the world.
Projection
    ``[u, v, 1]^T ~ K p_C`` with ``K = [[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` in pixels;
    images are already undistorted.
Euler angles
    ``C = C_z(yaw) C_y(pitch) C_x(roll)``, each an active rotation about the named axis.
    Pose parameters are the 6-vector ``(x, y, z, roll, pitch, yaw)`` in metres and radians;
    pitch lies in [-pi/2, pi/2], roll and yaw in (-pi, pi].
"""

from __future__ import annotations

import numpy as np

from .errors import InputError

#: Orthonormality tolerance used when validating a rotation block.
ROTATION_TOL = 1e-6
#: Smallest camera-frame depth (metres) a point may have to count as in front of the camera.
MIN_DEPTH = 1e-9


def rot_x(a: float) -> np.ndarray:
    """Active rotation by ``a`` radians about x, shape (3, 3)."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a: float) -> np.ndarray:
    """Active rotation by ``a`` radians about y, shape (3, 3)."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a: float) -> np.ndarray:
    """Active rotation by ``a`` radians about z, shape (3, 3)."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def C_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation matrix ``C = C_z(yaw) C_y(pitch) C_x(roll)``, shape (3, 3); angles in radians."""
    return rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)


def rpy_from_C(C, gimbal_tol: float = 1e-9) -> np.ndarray:
    """Euler angles ``(roll, pitch, yaw)`` in radians of ``C = C_z(yaw) C_y(pitch) C_x(roll)``.

    Pitch is in [-pi/2, pi/2]. At gimbal lock (``|cos pitch| < gimbal_tol``) only
    ``roll - yaw`` (pitch = +pi/2) or ``roll + yaw`` (pitch = -pi/2) is defined; roll is then
    set to 0 and yaw carries the whole rotation about the axis.
    """
    C = np.asarray(C, dtype=float)
    pitch = np.arctan2(-C[2, 0], np.hypot(C[0, 0], C[1, 0]))
    if np.hypot(C[0, 0], C[1, 0]) < gimbal_tol:
        return np.array([0.0, pitch, np.arctan2(-C[0, 1], C[1, 1])])
    roll = np.arctan2(C[2, 1], C[2, 2])
    yaw = np.arctan2(C[1, 0], C[0, 0])
    return np.array([roll, pitch, yaw])


def T_from_params(params) -> np.ndarray:
    """4 x 4 pose ``T_WC`` from ``(x, y, z, roll, pitch, yaw)`` (metres, radians)."""
    p = np.asarray(params, dtype=float).reshape(6)
    T = np.eye(4)
    T[:3, :3] = C_from_rpy(p[3], p[4], p[5])
    T[:3, 3] = p[:3]
    return T


def params_from_T(T) -> np.ndarray:
    """The 6-vector ``(x, y, z, roll, pitch, yaw)`` (metres, radians) of a 4 x 4 pose."""
    T = np.asarray(T, dtype=float)
    return np.concatenate([T[:3, 3], rpy_from_C(T[:3, :3])])


def as_float_array(x, name: str, shape=None) -> np.ndarray:
    """Convert array-like input to float64, turning conversion failures into InputError.

    Parameters
    ----------
    x : array_like
        Numbers (bool, integer or real); strings, complex numbers, None and other objects
        and ragged nests are refused.
    name : str
        The parameter's name, used in the message.
    shape : tuple of int, optional
        Required shape; unchecked when None.

    Returns
    -------
    a : ndarray of float64
        ``x`` as an array (not copied when already float64).

    Raises
    ------
    InputError
        If ``x`` is not a rectangular array of real numbers, or does not have ``shape``.
    """
    try:
        a = np.asarray(x)
        # Strings would convert ("1.5" -> 1.5), complex would lose its imaginary part and
        # None in an object array would become NaN.
        if a.dtype.kind not in "biuf":
            raise TypeError
        a = a.astype(float, copy=False)
    except (TypeError, ValueError):
        raise InputError(
            f"{name} must be a rectangular array of real numbers, got {_describe(x)}") from None
    if shape is not None and a.shape != tuple(shape):
        raise InputError(f"{name} must have shape {tuple(shape)}, got {a.shape}")
    return a


def _describe(x) -> str:
    """A short description of a rejected value for an error message."""
    text = repr(x)
    return text if len(text) <= 60 else f"{type(x).__name__} {text[:57]}..."


def check_transform(T, name: str = "T_WC") -> np.ndarray:
    """Validate a rigid transform and return it as a (4, 4) float64 array.

    Raises
    ------
    InputError
        If T is not an array of real numbers, the shape is not (4, 4), an entry is not
        finite, the rotation block is not orthonormal with determinant +1 (tolerance
        :data:`ROTATION_TOL`), or the last row is not ``[0, 0, 0, 1]``.
    """
    T = as_float_array(T, name)
    if T.shape != (4, 4):
        raise InputError(f"{name} must have shape (4, 4), got {T.shape}")
    if not np.all(np.isfinite(T)):
        raise InputError(f"{name} contains NaN or infinite values")
    C = T[:3, :3]
    if np.max(np.abs(C.T @ C - np.eye(3))) > ROTATION_TOL or np.linalg.det(C) < 0:
        raise InputError(f"{name}[:3, :3] is not a rotation (orthonormal, det +1)")
    if not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0]):
        raise InputError(f"{name}'s last row must be [0, 0, 0, 1], got {T[3].tolist()}")
    return T


def check_K(K) -> np.ndarray:
    """Validate camera intrinsics and return them as a (3, 3) float64 array.

    Raises
    ------
    InputError
        If K is not a (3, 3) array of real numbers, not finite, its last row is not
        ``[0, 0, 1]``, ``K[1, 0]`` is not 0, or a focal length is not positive (a singular K).
    """
    K = as_float_array(K, "K")
    if K.shape != (3, 3):
        raise InputError(f"K must have shape (3, 3), got {K.shape}")
    if not np.all(np.isfinite(K)):
        raise InputError("K contains NaN or infinite values")
    if not np.allclose(K[2], [0.0, 0.0, 1.0]) or K[1, 0] != 0.0:
        raise InputError(f"K must be upper triangular with last row [0, 0, 1], got {K.tolist()}")
    if K[0, 0] <= 0 or K[1, 1] <= 0:
        raise InputError(f"K's focal lengths must be positive, got fx={K[0, 0]}, fy={K[1, 1]}")
    return K


def K_from_params(fx: float, fy: float, cx: float, cy: float, skew: float = 0.0) -> np.ndarray:
    """Intrinsics matrix from focal lengths and principal point, all in pixels."""
    return check_K([[fx, skew, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def as_points(P, dim: int, name: str = "points", min_count: int = 1) -> np.ndarray:
    """Validate a ``dim`` x N point array and return it as float64.

    Raises
    ------
    InputError
        If it is not a 2-D array of real numbers with ``dim`` rows, has fewer than
        ``min_count`` columns, or holds NaN or infinite values.
    """
    P = as_float_array(P, name)
    if P.ndim != 2 or P.shape[0] != dim:
        raise InputError(f"{name} must have shape ({dim}, N), got {P.shape}")
    if P.shape[1] < min_count:
        raise InputError(f"{name} needs at least {min_count} points, got {P.shape[1]}")
    if not np.all(np.isfinite(P)):
        raise InputError(f"{name} contains NaN or infinite values")
    return P


def check_correspondences(K, Ipts, Wpts, mask=None):
    """Validate K, image and target points and a trust mask at a public edge.

    Parameters
    ----------
    K : (3, 3) array_like
        Intrinsics, pixels (see :func:`check_K`).
    Ipts : (2, n) array_like
        Image points (u, v), pixels.
    Wpts : (3, n) array_like
        Matching target points, metres.
    mask : (n,) array_like of bool, optional
        The points to use; all when None.

    Returns
    -------
    K : (3, 3) ndarray
    Ipts : (2, n) ndarray
    Wpts : (3, n) ndarray
    mask : (n,) ndarray of bool
        All True when ``mask`` is None.

    Raises
    ------
    InputError
        If K is singular or malformed, the point arrays are malformed, hold NaN, differ in
        count, the mask is not boolean of shape (n,), or fewer than 4 points are used.
    """
    K = check_K(K)
    Ipts = as_points(Ipts, 2, "Ipts")
    Wpts = as_points(Wpts, 3, "Wpts")
    n = Ipts.shape[1]
    if Wpts.shape[1] != n:
        raise InputError(f"Ipts and Wpts must hold the same number of points, got {n} and {Wpts.shape[1]}")
    if mask is None:
        mask = np.ones(n, dtype=bool)
    else:
        mask = np.asarray(mask)
        if mask.shape != (n,) or mask.dtype != bool:
            raise InputError(f"mask must be a boolean array of shape ({n},), got {mask.dtype} {mask.shape}")
    if np.count_nonzero(mask) < 4:
        raise InputError(f"pose needs at least 4 trusted points, got {np.count_nonzero(mask)}")
    return K, Ipts, Wpts, mask


def check_in_front(depth, name: str, index=None) -> None:
    """Refuse points at or behind the camera.

    Parameters
    ----------
    depth : (m,) ndarray
        Camera-frame depths (metres), e.g. ``to_camera(T_WC, P_W)[2]``.
    name : str
        The pose the depths belong to, for the message ("the guess").
    index : (m,) array_like of int, optional
        The caller's index of each depth (``np.flatnonzero(mask)`` when the depths are of
        the masked points), so the message names the caller's point; ``arange(m)`` if None.

    Raises
    ------
    InputError
        If a depth is at most :data:`MIN_DEPTH`.
    """
    bad = np.flatnonzero(depth <= MIN_DEPTH)
    if bad.size:
        first = bad[0] if index is None else int(index[bad[0]])
        raise InputError(
            f"{bad.size} target point(s) lie at or behind the camera at {name} "
            f"(first index {first}, depth {depth[bad[0]]:.3g} m)"
        )


def to_camera(T_WC, P_W) -> np.ndarray:
    """Target points in the camera frame, ``C^T (p_W - t)``; (3, N) in, (3, N) out, metres."""
    T_WC = np.asarray(T_WC, dtype=float)
    return T_WC[:3, :3].T @ (np.asarray(P_W, dtype=float) - T_WC[:3, 3:4])


def project(K, T_WC, P_W) -> np.ndarray:
    """Pinhole projection of target points.

    Parameters
    ----------
    K : (3, 3) array_like
        Intrinsics, pixels.
    T_WC : (4, 4) array_like
        Camera pose in the target frame.
    P_W : (3, N) array_like
        Target points, metres.

    Returns
    -------
    uv : (2, N) ndarray
        Pixel coordinates (u, v); points at or behind the camera give inf or
        meaningless values, so callers that care check :func:`to_camera`'s depth first.
    """
    p = np.asarray(K, dtype=float) @ to_camera(T_WC, P_W)
    with np.errstate(divide="ignore", invalid="ignore"):
        return p[:2] / p[2]

"""The conventions that every module of graphpose uses, and the geometry on them: rotations,
poses and their parameters, the SE(3) toolkit (:func:`hat`, :func:`so3_exp`, :func:`se3_exp`,
:func:`se3_log`, :func:`invert_transform`, :func:`pose_difference`), the pinhole projection, plane-to-image homographies.

Lens models (radial-tangential, fisheye) are in :mod:`graphpose.camera_models`; this module
is the distortion-free geometry under them.

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
    ``[u, v, 1]^T ~ K p_C`` with ``K = [[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` in pixels:
    the pinhole camera. A raw image from a real lens is modelled by a camera of
    :mod:`graphpose.camera_models`, whose distortion maps these pinhole coordinates to the
    raw image's; every function that takes ``K`` there takes such a camera too.
Euler angles
    ``C = C_z(yaw) C_y(pitch) C_x(roll)``, each an active rotation about the named axis.
    Pose parameters are the 6-vector ``(x, y, z, roll, pitch, yaw)`` in metres and radians;
    pitch lies in [-pi/2, pi/2], roll and yaw in (-pi, pi].
"""

from __future__ import annotations

import math

import numpy as np

from ._checks import MIN_POSE_POINTS, check_K
from .errors import DegenerateGeometryError


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


def K_from_params(fx: float, fy: float, cx: float, cy: float, skew: float = 0.0) -> np.ndarray:
    """Intrinsics matrix from focal lengths and principal point, all in pixels."""
    return check_K([[fx, skew, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


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



# --- SE(3): the skew matrix, the exponential and logarithm, the difference of two poses ---------
#
# Twists are GTSAM's ``Pose3`` tangent vectors: ``xi = (omega, v)``, the rotation (rad) FIRST, then
# the translation part (m), for the right perturbation ``T Exp(xi)`` in the body frame, so that
# ``se3_exp(xi)`` is ``gtsam.Pose3.Expmap(xi).matrix()`` and ``se3_log(T)`` is
# ``gtsam.Pose3.Logmap(gtsam.Pose3(T))`` (to 1e-12, tested).

def hat(w) -> np.ndarray:
    """The skew matrix ``[w]_x`` (3, 3) of a 3-vector: ``hat(w) @ p == np.cross(w, p)``."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def hats(P) -> np.ndarray:
    """:func:`hat` of every column of P (3, m): the skew matrices (m, 3, 3)."""
    out = np.zeros((P.shape[1], 3, 3))
    out[:, 0, 1], out[:, 0, 2] = -P[2], P[1]
    out[:, 1, 0], out[:, 1, 2] = P[2], -P[0]
    out[:, 2, 0], out[:, 2, 1] = -P[1], P[0]
    return out


def so3_log(R) -> np.ndarray:
    """Rotation vector (3,) of a rotation matrix (3, 3), radians, accurate from 0 to pi
    (``R = exp(hat(omega))``; at pi either sign of the axis is an answer)."""
    s = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    sin = float(np.linalg.norm(s))
    cos = 0.5 * (np.trace(R) - 1.0)
    theta = math.atan2(sin, cos)
    if theta < 1e-4:
        return s * (1.0 + theta * theta / 6.0)  # theta / sin(theta)
    if math.pi - theta < 1e-3:
        # Near pi the skew part vanishes; the axis a is in the symmetric part:
        # (R + R^T) / 2 = cos(theta) I + (1 - cos(theta)) a a^T.
        A = (0.5 * (R + R.T) - cos * np.eye(3)) / (1.0 - cos)
        i = int(np.argmax(np.diag(A)))
        axis = A[:, i] / math.sqrt(A[i, i])
        return theta * (axis if axis @ s >= 0 else -axis)
    return s * (theta / sin)


def so3_exp(w) -> np.ndarray:
    """The rotation matrix (3, 3) of a rotation vector ``w`` (3,), radians (Rodrigues'
    formula; ``so3_log`` inverts it)."""
    theta = float(np.linalg.norm(w))
    if theta < 1e-12:
        return np.eye(3) + hat(w)
    W = hat(np.asarray(w) / theta)
    return np.eye(3) + np.sin(theta) * W + (1.0 - np.cos(theta)) * (W @ W)


def _se3_coefficients(theta):
    """``sin(t)/t``, ``(1 - cos t)/t^2``, ``(t - sin t)/t^3`` (series near 0)."""
    if theta < 1e-4:
        t2 = theta * theta
        return 1.0 - t2 / 6.0, 0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0
    half = math.sin(0.5 * theta)
    return math.sin(theta) / theta, 2.0 * half * half / theta**2, (theta - math.sin(theta)) / theta**3


def se3_log(T) -> np.ndarray:
    """Twist ``(omega, v)`` (6,) of a rigid transform (4, 4): ``T = se3_exp(xi)``; rotation
    (rad) first, then translation (m), GTSAM's ``Pose3.Logmap`` order."""
    omega = so3_log(T[:3, :3])
    theta = float(np.linalg.norm(omega))
    W = hat(omega)
    if theta < 1e-4:
        c = 1.0 / 12.0 + theta * theta / 720.0
    else:
        c = (1.0 - 0.5 * theta * math.cos(0.5 * theta) / math.sin(0.5 * theta)) / theta**2
    V_inv = np.eye(3) - 0.5 * W + c * (W @ W)
    return np.r_[omega, V_inv @ T[:3, 3]]


def se3_exp(xi) -> np.ndarray:
    """Rigid transform (4, 4) of a twist ``(omega, v)`` (6,): rotation (rad) first, then
    translation (m), as GTSAM's ``Pose3.Expmap``."""
    omega, v = xi[:3], xi[3:]
    theta = float(np.linalg.norm(omega))
    a, b, c = _se3_coefficients(theta)
    W = hat(omega)
    W2 = W @ W
    T = np.eye(4)
    T[:3, :3] = np.eye(3) + a * W + b * W2
    T[:3, 3] = (np.eye(3) + b * W + c * W2) @ v
    return T


def relative_pose(T_a, T_b) -> np.ndarray:
    """``T_a^-1 T_b`` (4, 4) of two rigid transforms (trusted), without a general inverse."""
    R_a = T_a[:3, :3]
    D = np.eye(4)
    D[:3, :3] = R_a.T @ T_b[:3, :3]
    D[:3, 3] = R_a.T @ (T_b[:3, 3] - T_a[:3, 3])
    return D


def invert_transform(T) -> np.ndarray:
    """The inverse (4, 4) of a rigid transform ``T`` (4, 4, trusted), without a general inverse."""
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


def pose_difference(T_a, T_b):
    """Distance (m) between two camera positions and angle (degrees) of their relative rotation.

    The angle comes from ``atan2`` of the skew and symmetric parts, accurate for tiny angles
    (``arccos`` of the trace loses half the digits there).

    Parameters
    ----------
    T_a, T_b : (4, 4) array_like
        Camera poses T_WC (trusted: rigid transforms).

    Returns
    -------
    translation_m : float
        ``|t_a - t_b|``, metres.
    rotation_deg : float
        Angle of ``C_a^T C_b``, degrees in [0, 180].
    """
    R = np.asarray(T_a)[:3, :3].T @ np.asarray(T_b)[:3, :3]
    s = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    angle = np.degrees(np.arctan2(s, 0.5 * (np.trace(R) - 1.0)))
    return float(np.linalg.norm(np.asarray(T_a)[:3, 3] - np.asarray(T_b)[:3, 3])), float(angle)


# --- homographies (the plane z = 0, and a board's grid, to the image) ---------------------------

#: Relative size of the DLT's second-smallest singular value below which the points are
#: degenerate. The singular values come squared from the normal matrix, whose eigenvalues are
#: resolved to about 1e-16 of the largest: a ratio of 1e-6 (1e-12 squared) stays clear of that.
_RANK_TOL = 1e-6
_ROOT2 = np.sqrt(2.0)


def homography_dlt(src, dst) -> np.ndarray:
    """Homography mapping ``src`` to ``dst`` by the normalised DLT.

    Parameters
    ----------
    src, dst : (2, n) ndarray
        Matching points, n >= 4 (inputs are trusted: validate before calling).

    Returns
    -------
    H : (3, 3) ndarray
        ``[dst, 1] ~ H [src, 1]``, scaled so ``||H||_F = 1``.

    Raises
    ------
    DegenerateGeometryError
        If the points do not fix a homography (collinear, repeated or coincident).
    """
    Ts, a = _normaliser(src)
    Td, b = _normaliser(dst)
    n = a.shape[1]
    A = np.zeros((n, 2, 9))  # rows 2i and 2i + 1 of the DLT matrix, filled in place
    ah = A[:, 0, 0:3]
    ah[:, :2] = a.T
    ah[:, 2] = 1.0
    A[:, 1, 3:6] = ah
    A[:, 1, 6:9] = ah * -b[1, :, None]
    A[:, 0, 6:9] = ah * -b[0, :, None]  # last: it reads ah, which this does not overwrite
    A = A.reshape(2 * n, 9)
    # The null vector of A from the 9 x 9 normal matrix: about half the time of A's SVD, and
    # with normalised points (A's condition number ~10 apart from the null direction) squaring
    # the condition costs no accuracy that matters.
    w, V = np.linalg.eigh(A.T @ A)
    if n < MIN_POSE_POINTS or w[1] < _RANK_TOL**2 * w[-1]:
        raise DegenerateGeometryError("the points do not determine a homography (collinear or repeated points)")
    H = np.linalg.solve(Td, V[:, 0].reshape(3, 3) @ Ts)
    return H / np.linalg.norm(H)


def apply_homography(H: np.ndarray, P: np.ndarray) -> np.ndarray:
    """The points ``P`` (2, N) mapped by the homography ``H`` (3, 3): ``[q, 1] ~ H [P, 1]``, (2, N)."""
    q = H[:, :2] @ P + H[:, 2:]
    return q[:2] / q[2]


def _normaliser(P):
    """Similarity moving the centroid to 0 and the mean distance to sqrt(2); and the moved points."""
    # The same sums as np.mean and np.linalg.norm (bit for bit), without their per-call
    # overhead: the detector fits several homographies per image.
    n = P.shape[1]
    c = P.sum(axis=1, keepdims=True) / n
    d = P - c
    spread = float(np.sqrt(d[0] * d[0] + d[1] * d[1]).sum()) / n
    if not spread > 0:
        raise DegenerateGeometryError("the points do not determine a homography (all points coincide)")
    k = _ROOT2 / spread
    T = np.array([[k, 0.0, -k * c[0, 0]], [0.0, k, -k * c[1, 0]], [0.0, 0.0, 1.0]])
    return T, k * d

"""A rig of cameras fixed to one another: :class:`Rig`, and the stereo pair's derived matrices.

Frames and directions (``docs/rigs.md``): camera 0 is the rig's reference. ``T_C0_C[i]`` is
camera i's pose in camera 0's frame (a point ``p_Ci`` in camera i's frame is ``p_C0 = T_C0_C[i]
p_Ci`` in camera 0's), and ``T_C0_C[0]`` is the identity. The rig's pose in the target frame is
camera 0's, ``T_WC0``; camera i is then at ``T_WCi = T_WC0 T_C0_C[i]``.

The stereo quantities of a pair (i, j) follow OpenCV's ``stereoCalibrate`` and
``stereoRectify`` (:meth:`Rig.stereo`, :func:`stereo_rectify`): ``R, T`` take a point from the
first camera's frame into the second's, ``p_j = R p_i + T`` (that is ``T_Cj_Ci``);
``E = [T]_x R``; ``F = K_j^-T E K_i^-1``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._checks import check_covariance, check_transform
from .camera_models import Camera
from .errors import InputError
from .geometry import hat, invert_transform, so3_exp, so3_log

#: The extrinsic parameters of each camera after the first, in the rig's covariance.
EXTRINSIC_NAMES = ("x", "y", "z", "roll", "pitch", "yaw")


@dataclass(frozen=True, eq=False)
class Rig:
    """Cameras fixed to one another, and where each is in camera 0's frame.

    Parameters
    ----------
    cameras : sequence of Camera
        The cameras (:mod:`graphpose.camera_models`), at least two; their models may differ.
    T_C0_C : sequence of (4, 4) array_like
        Camera i's pose in camera 0's frame (metres); the first must be the identity.
    names : sequence of str, optional
        The cameras' names (``cam0``, ``cam1``, ... by default), distinct.
    cov : (N, N) array_like, optional
        The joint covariance of the calibration's parameters, named by ``parameter_names``
        (each camera's intrinsics ``camI.fx`` ..., then each further camera's extrinsics
        ``camI.x`` ... ``camI.yaw``: ``T_C0_C[i]``'s (x, y, z, roll, pitch, yaw), metres and
        radians); None when unknown.
    parameter_names : sequence of str, optional
        Required with ``cov``.

    Raises
    ------
    InputError
        If fewer than two cameras are given, a camera is not a graphpose camera, a transform
        is not rigid, the first is not the identity, the names repeat, or ``cov`` does not fit
        ``parameter_names``.
    """

    cameras: tuple
    T_C0_C: tuple
    names: tuple | None = None
    cov: np.ndarray | None = field(default=None, repr=False)
    parameter_names: tuple | None = field(default=None, repr=False)

    def __post_init__(self):
        cameras = tuple(self.cameras)
        if len(cameras) < 2:
            raise InputError(f"a rig needs at least two cameras, got {len(cameras)}")
        for i, c in enumerate(cameras):
            if not isinstance(c, Camera):
                raise InputError(f"rig camera {i} must be a graphpose camera, got {type(c).__name__}")
        Ts = tuple(check_transform(T, f"T_C0_C[{i}]").copy() for i, T in enumerate(self.T_C0_C))
        if len(Ts) != len(cameras):
            raise InputError(f"T_C0_C must give one pose per camera: {len(cameras)} cameras, {len(Ts)} poses")
        if not np.allclose(Ts[0], np.eye(4), atol=1e-12, rtol=0.0):
            raise InputError("T_C0_C[0] must be the identity (camera 0 is the rig's reference frame)")
        for T in Ts:
            T.setflags(write=False)
        names = tuple(f"cam{i}" for i in range(len(cameras))) if self.names is None else tuple(map(str, self.names))
        if len(names) != len(cameras) or len(set(names)) != len(names):
            raise InputError(f"names must name each camera once: {len(cameras)} cameras, names {list(names)}")
        object.__setattr__(self, "cameras", cameras)
        object.__setattr__(self, "T_C0_C", Ts)
        object.__setattr__(self, "names", names)
        if self.cov is not None:
            pn = tuple(self.parameter_names or ())
            cov = check_covariance(self.cov, len(pn), "rig covariance (of its parameter_names)")
            cov = np.array(cov)
            cov.setflags(write=False)
            object.__setattr__(self, "cov", cov)
            object.__setattr__(self, "parameter_names", pn)
        elif self.parameter_names is not None:
            object.__setattr__(self, "parameter_names", tuple(self.parameter_names))

    def __len__(self) -> int:
        return len(self.cameras)

    def index(self, name_or_index) -> int:
        """The index of a camera given by name (``cam1``) or index; InputError naming the cameras."""
        if isinstance(name_or_index, (int, np.integer)) and not isinstance(name_or_index, bool):
            if 0 <= int(name_or_index) < len(self):
                return int(name_or_index)
        elif name_or_index in self.names:
            return self.names.index(name_or_index)
        raise InputError(f"no camera {name_or_index!r} in this rig; it holds {', '.join(self.names)}")

    def camera(self, name_or_index):
        """One camera of the rig, by name or index."""
        return self.cameras[self.index(name_or_index)]

    def T_Ci_Cj(self, i, j) -> np.ndarray:
        """Camera j's pose in camera i's frame (4, 4): takes a point from j's frame into i's."""
        i, j = self.index(i), self.index(j)
        return invert_transform(self.T_C0_C[i]) @ self.T_C0_C[j]

    def T_cn_cnm1(self, n) -> np.ndarray:
        """Kalibr's ``T_cn_cnm1`` of camera n (>= 1): the transform that takes a point from
        camera n-1's frame into camera n's, ``T_Cn_C0 T_C0_Cn-1``."""
        n = self.index(n)
        if n == 0:
            raise InputError("T_cn_cnm1 is defined for cameras 1, 2, ... (camera 0 has no predecessor)")
        return self.T_Ci_Cj(n, n - 1)

    def stereo(self, i=0, j=1) -> dict:
        """OpenCV's ``stereoCalibrate`` outputs of the pair (i, j).

        Returns
        -------
        dict
            ``R`` (3, 3) and ``T`` (3,) with ``p_j = R p_i + T`` (metres), ``E = [T]_x R`` and
            ``F = K_j^-T E K_i^-1`` (on pixels of the distortion-free cameras).
        """
        T = self.T_Ci_Cj(j, i)
        R, t = T[:3, :3], T[:3, 3]
        E = hat(t) @ R
        Ki, Kj = self.camera(i).K, self.camera(j).K
        F = np.linalg.inv(Kj).T @ E @ np.linalg.inv(Ki)
        return {"R": R.copy(), "T": t.copy(), "E": E, "F": F}

    def baseline_m(self, i) -> float:
        """Distance from camera 0 to camera i, metres."""
        return float(np.linalg.norm(self.T_C0_C[self.index(i)][:3, 3]))

    def rotation_deg(self, i) -> float:
        """Angle of camera i's rotation relative to camera 0, degrees."""
        return float(np.degrees(np.linalg.norm(so3_log(self.T_C0_C[self.index(i)][:3, :3]))))


def rig_parameter_names(cameras) -> tuple:
    """The names of a rig calibration's parameters: ``camI.<intrinsic>`` for every camera,
    then ``camJ.x`` ... ``camJ.yaw`` for every camera J >= 1."""
    names = [f"cam{i}.{n}" for i, c in enumerate(cameras) for n in c.parameter_names]
    names += [f"cam{i}.{n}" for i in range(1, len(cameras)) for n in EXTRINSIC_NAMES]
    return tuple(names)


def stereo_rectify(rig: Rig, i=0, j=1, *, zero_disparity: bool = True) -> dict:
    """OpenCV's ``stereoRectify`` of the pair (i, j), computed here (alpha -1: no scaling).

    The steps of OpenCV 4's own: half of the relative rotation to each camera, then the
    rotation that brings the baseline onto x (or y, for a vertical pair); a common focal
    length (the mean of the pair's ``K[1, 1]``, ``K[0, 0]`` for a vertical pair); each
    principal point that puts the mean of the image's undistorted corners ``(0, 0) ..
    (width - 1, height - 1)`` at the image's centre ``((width - 1) / 2, (height - 1) / 2)``
    (with ``zero_disparity`` the two equal). The corners are undistorted exactly
    here; OpenCV stops after five iterations in single precision, so the principal points
    may differ from its by a fraction of a pixel where the lens is strong.

    Returns
    -------
    dict
        ``R1``, ``R2`` (3, 3): rotations of each camera's frame into its rectified frame;
        ``P1``, ``P2`` (3, 4): the rectified projections, ``P2[0, 3] = f T'_x`` (or
        ``P2[1, 3]``) with ``T'`` the baseline in the rectified frame; ``Q`` (4, 4): the
        disparity-to-depth map, ``[x y z w]^T = Q [u v d 1]^T``.
    """
    cam1, cam2 = rig.camera(i), rig.camera(j)
    pair = rig.stereo(i, j)
    R, T = pair["R"], pair["T"]
    # Half the rotation to each camera.
    om = -0.5 * so3_log(R)
    r_r = so3_exp(om)
    t = r_r @ T
    idx = 0 if abs(t[0]) > abs(t[1]) else 1
    uu = np.zeros(3)
    uu[idx] = 1.0 if t[idx] > 0 else -1.0
    ww = np.cross(t, uu)
    nw = np.linalg.norm(ww)
    if nw > 0:
        ww *= np.arccos(abs(t[idx]) / np.linalg.norm(t)) / nw
    wR = so3_exp(ww)
    R1 = wR @ r_r.T
    R2 = wR @ r_r
    t = R2 @ T
    # The common focal length: the mean of the two K[1, 1] (K[0, 0] for a vertical pair), as
    # OpenCV 4 does (new image size = the old).
    width, height = cam1.size if cam1.size is not None else (2 * cam1.cx + 1, 2 * cam1.cy + 1)
    fc_new = 0.5 * (cam1.K[1 - idx, 1 - idx] + cam2.K[1 - idx, 1 - idx])
    # Principal points that centre each image's undistorted corners.
    corners = np.array([[0.0, width - 1, 0.0, width - 1], [0.0, 0.0, height - 1, height - 1]])
    cc = []
    for cam, Rk in ((cam1, R1), (cam2, R2)):
        rays = Rk @ cam.unproject(corners)
        cc.append(np.array([(width - 1) / 2.0, (height - 1) / 2.0])
                  - fc_new * np.mean(rays[:2] / rays[2], axis=1))
    if zero_disparity:
        cc[0] = cc[1] = 0.5 * (cc[0] + cc[1])
    elif idx == 0:
        cc[0][1] = cc[1][1] = 0.5 * (cc[0][1] + cc[1][1])
    else:
        cc[0][0] = cc[1][0] = 0.5 * (cc[0][0] + cc[1][0])
    P1 = np.array([[fc_new, 0.0, cc[0][0], 0.0], [0.0, fc_new, cc[0][1], 0.0], [0.0, 0.0, 1.0, 0.0]])
    P2 = np.array([[fc_new, 0.0, cc[1][0], 0.0], [0.0, fc_new, cc[1][1], 0.0], [0.0, 0.0, 1.0, 0.0]])
    P2[idx, 3] = t[idx] * fc_new
    Q = np.array([[1.0, 0.0, 0.0, -cc[0][0]], [0.0, 1.0, 0.0, -cc[0][1]], [0.0, 0.0, 0.0, fc_new],
                  [0.0, 0.0, -1.0 / t[idx], (cc[0][idx] - cc[1][idx]) / t[idx]]])
    return {"R1": R1, "R2": R2, "P1": P1, "P2": P2, "Q": Q}

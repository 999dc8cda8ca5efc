"""The closed-form start of a calibration: intrinsics and poses from per-image homographies.

Pinhole and radial-tangential models: Zhang's method (Z. Zhang, "A flexible new technique
for camera calibration", IEEE TPAMI 22(11), 2000). Each view's plane-to-image homography
``H = [h1 h2 h3] ~ K [r1 r2 t]`` gives two linear constraints on the image of the absolute
conic ``B = K^-T K^-1``: ``h1^T B h2 = 0`` and ``h1^T B h1 = h2^T B h2``. With zero skew
(``B12 = 0``, as the calibration assumes) B has five unknowns ``(B11, B22, B13, B23, B33)``
up to scale, so three views fix it; ``K`` follows from B in closed form. To keep the linear
system well conditioned the pixels are first mapped to about [-1, 1] (centre of the image,
scaled by half its larger side). The distortion starts at zero.

The fisheye: its junctions lie far from a homography of the raw pixels, so Zhang's method
does not apply. The start is the equidistant model's own (``theta_d = theta``, the fisheye
model with ``k = 0``), with the principal point at the image's centre and one focal length:
for a candidate ``f`` the junctions are unprojected to rays, whose ``(x/z, y/z)`` must be
a homography of the board; ``f`` is the one whose homographies fit best (a search over a
logarithmic grid, then golden-section refinement).

Poses come from each view's homography through the starting camera
(:func:`graphpose.pose.homography.pose_from_homography`, which undistorts first).

Degenerate views (all boards parallel to each other, so the focal length is not
constrained) make Zhang's system lose rank: its second-smallest singular value falls to the
noise (:data:`DEGENERATE_RATIO`); :func:`zhang_intrinsics` then raises
:class:`~graphpose.errors.InputError`. Nearly degenerate sets pass here and are caught by the
calibration's own focal-length sigma (:data:`graphpose.calibrate.run.MAX_FOCAL_SIGMA`).
"""

from __future__ import annotations

import numpy as np

from ..camera_models import FisheyeCamera, PinholeCamera, RadTanCamera, RationalCamera
from ..errors import DegenerateGeometryError, InputError
from ..geometry import homography_dlt
from ..pose.homography import pose_from_homography

#: Zhang's system is degenerate when its second-smallest singular value is below this
#: fraction of the largest: its null space is then more than one-dimensional, up to the noise
#: (boards all parallel, or too few distinct views). Measured: 1.7e-4 and 2.3e-5 for four
#: renders of one pose, 0.02-0.04 for three to ten tilted views through k1 = -0.3.
DEGENERATE_RATIO = 3e-3
#: Candidate focal lengths of the fisheye start, as fractions of the image's diagonal.
_FISHEYE_F = (0.1, 2.0)


def _v(H, i, j):
    """Zhang's vector ``v_ij`` for the zero-skew unknowns (B11, B22, B13, B23, B33)."""
    hi, hj = H[:, i], H[:, j]
    return np.array([hi[0] * hj[0], hi[1] * hj[1], hi[2] * hj[0] + hi[0] * hj[2],
                     hi[2] * hj[1] + hi[1] * hj[2], hi[2] * hj[2]])


def zhang_intrinsics(homographies, size) -> np.ndarray:
    """``K`` (zero skew) from three or more plane-to-image homographies by Zhang's method.

    Parameters
    ----------
    homographies : list of (3, 3) ndarray
        Board-plane ``(x, y, 1)`` (metres) to pixels, one per view.
    size : (int, int)
        Image ``(width, height)``, pixels (for the conditioning).

    Returns
    -------
    K : (3, 3) ndarray

    Raises
    ------
    InputError
        If the views do not constrain the focal lengths (all boards parallel, or too few
        views), so that the image of the absolute conic is not determined or not positive
        definite.
    """
    width, height = size
    s = 0.5 * max(width, height)
    N = np.array([[1.0 / s, 0.0, -0.5 * (width - 1) / s], [0.0, 1.0 / s, -0.5 * (height - 1) / s],
                  [0.0, 0.0, 1.0]])
    rows = []
    for H in homographies:
        Hn = N @ H
        Hn = Hn / np.linalg.norm(Hn[:, :2])
        rows += [_v(Hn, 0, 1), _v(Hn, 0, 0) - _v(Hn, 1, 1)]
    V = np.array(rows)
    _, sv, Vt = np.linalg.svd(V)
    not_fixed = ("the views do not constrain the focal length: the board must be seen at "
                 "different tilts (boards all parallel to each other leave the focal length and "
                 "the distance indistinguishable); tilt it by 20-50 degrees in different directions")
    if V.shape[0] < 5 or sv[-2] < DEGENERATE_RATIO * sv[0]:
        raise InputError(not_fixed)
    b11, b22, b13, b23, b33 = Vt[-1]
    if b11 < 0:
        b11, b22, b13, b23, b33 = -b11, -b22, -b13, -b23, -b33
    # B ~ K^-T K^-1 with K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]:
    # B11 = l / fx^2, B22 = l / fy^2, B13 = -l cx / fx^2, B23 = -l cy / fy^2, B33 = l (cx^2/fx^2 + cy^2/fy^2 + 1).
    if b11 <= 0 or b22 <= 0:
        raise InputError(not_fixed)
    cx, cy = -b13 / b11, -b23 / b22
    lam = b33 - cx * cx * b11 - cy * cy * b22
    if not lam > 0:
        raise InputError(not_fixed)
    fx, fy = np.sqrt(lam / b11), np.sqrt(lam / b22)
    Kn = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    K = np.linalg.solve(N, Kn)
    K[0, 1] = 0.0
    return K / K[2, 2]


def start(model: str, size, observations):
    """The starting camera and poses of a calibration.

    Parameters
    ----------
    model : str
        ``"pinhole"``, ``"radtan"`` or ``"fisheye"``.
    size : (int, int)
        Image ``(width, height)``, pixels.
    observations : list of (uv (2, m), W (3, m))
        Each view's trusted junctions (raw pixels) and their board points (z = 0), metres.

    Returns
    -------
    camera : Camera
        Of the model and size; zero distortion.
    poses : list of (4, 4) ndarray
        ``T_WC`` of each view.

    Raises
    ------
    InputError
        As :func:`zhang_intrinsics`.
    DegenerateGeometryError
        If a view's junctions fix no homography or no pose in front of the camera
        (:func:`graphpose.pose.homography.pose_from_homography`).
    """
    if model == "fisheye":
        camera = fisheye_start(size, observations)
    else:
        Hs = [homography_dlt(W[:2], uv) for uv, W in observations]
        K = zhang_intrinsics(Hs, size)
        camera = (PinholeCamera(K, size) if model == "pinhole"
                  else RationalCamera(K, np.zeros(8), size) if model == "rational"
                  else RadTanCamera(K, np.zeros(5), size))
    poses = [pose_from_homography(uv, W, camera) for uv, W in observations]
    return camera, poses


def fisheye_start(size, observations) -> FisheyeCamera:
    """The equidistant camera (``k = 0``, the principal point at the image's centre) whose
    focal length makes the views' junctions planar boards best (see the module docstring).

    Parameters
    ----------
    size : (int, int)
        Image ``(width, height)``, pixels.
    observations : list of (uv (2, m), W (3, m))
        Junctions (raw pixels) and board points of one view or more.

    Raises
    ------
    InputError
        If no focal length in the search range fits.
    """
    width, height = size
    cx, cy = 0.5 * (width - 1), 0.5 * (height - 1)
    diagonal = float(np.hypot(width, height))

    def misfit(f):
        """RMS angle (rad) of the rays about the best homography of each view, for focal f."""
        total, count = 0.0, 0
        for uv, W in observations:
            d = np.hypot(uv[0] - cx, uv[1] - cy)
            theta = d / f
            front = theta < np.radians(85.0)
            if front.sum() < 6:
                return np.inf
            scale = np.tan(theta[front]) / np.where(d[front] > 0, d[front], 1.0)
            xy = np.stack([(uv[0, front] - cx) * scale, (uv[1, front] - cy) * scale])
            xy = np.where(d[front] > 0, xy, 0.0)
            try:
                H = homography_dlt(W[:2, front], xy)
            except DegenerateGeometryError:
                return np.inf
            p = H @ np.vstack([W[:2, front], np.ones(int(front.sum()))])
            # Angle between the rays through the fit and the unprojected ones.
            a = np.vstack([p[:2] / p[2], np.ones(p.shape[1])])
            b = np.vstack([xy, np.ones(xy.shape[1])])
            cos = np.sum(a * b, axis=0) / np.linalg.norm(a, axis=0) / np.linalg.norm(b, axis=0)
            total += float(np.sum(np.arccos(np.clip(cos, -1.0, 1.0)) ** 2))
            count += int(front.sum())
        return np.sqrt(total / count)

    grid = np.geomspace(_FISHEYE_F[0] * diagonal, _FISHEYE_F[1] * diagonal, 60)
    costs = np.array([misfit(f) for f in grid])
    if not np.any(np.isfinite(costs)):
        raise InputError("no focal length makes the fisheye views planar boards: the junctions do "
                         "not fit the equidistant model")
    i = int(np.argmin(costs))
    lo, hi = np.log(grid[max(i - 1, 0)]), np.log(grid[min(i + 1, grid.size - 1)])
    g = (np.sqrt(5.0) - 1.0) / 2.0
    a, b = hi - g * (hi - lo), lo + g * (hi - lo)
    fa, fb = misfit(np.exp(a)), misfit(np.exp(b))
    for _ in range(40):
        if fa < fb:
            hi, b, fb = b, a, fa
            a = hi - g * (hi - lo)
            fa = misfit(np.exp(a))
        else:
            lo, a, fa = a, b, fb
            b = lo + g * (hi - lo)
            fb = misfit(np.exp(b))
    f = float(np.exp(0.5 * (lo + hi)))
    return FisheyeCamera([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]], np.zeros(4), size)

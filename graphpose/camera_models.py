"""Camera models with lens distortion, one object per camera, in OpenCV's definitions.

Three models share one interface (:class:`Camera`):

- :class:`PinholeCamera`: ``[u, v, 1]^T ~ K p_C``, the model of :mod:`graphpose.geometry`
  (skew allowed), and the default: :func:`as_camera` turns a 3 x 3 ``K`` into one;
- :class:`RadTanCamera`: OpenCV's radial-tangential (Brown-Conrady) model, coefficients in
  OpenCV's order ``(k1, k2, p1, p2[, k3[, k4, k5, k6]])`` (4, 5 or 8 of them; 8 is OpenCV's
  rational model); no skew, as in OpenCV;
- :class:`FisheyeCamera`: OpenCV's fisheye (equidistant Kannala-Brandt) model, ``(k1, k2,
  k3, k4)``, skew allowed (OpenCV's ``alpha = K[0, 1] / fx``), defined beyond 90 degrees
  off the axis.

Conventions are those of :mod:`graphpose.geometry`: pixels ``(u, v)`` with the centre of the
upper-left pixel at (0, 0) (as OpenCV), 2 x N and 3 x N point arrays, camera frame x right,
y down, z forward. The equations are in ``docs/cameras.md``.

Every camera offers

- ``project(P_C)``: camera-frame points (3, N), metres -> pixels (2, N);
- ``project_jacobian(P_C)``: the pixels and the analytic ``d uv / d P_C``, (N, 2, 3);
- ``unproject(uv)``: pixels (2, N) -> unit rays (3, N) in the camera frame (one API for all
  three models: a fisheye sees rays at more than 90 degrees, which normalised coordinates
  ``(x/z, y/z)`` cannot hold). Iterative for the distorting models; the ray reprojects onto
  ``uv`` within :data:`UNPROJECT_TOL` in normalised units, that is within 1e-12 x the focal
  length in pixels (5e-10 px at f = 533 px, as measured over whole images; the tests hold
  it to 1e-9 px). Where the inversion finds no ray on the model's unfolded branch (past
  the radius where a strong radial term folds the image back; past the fisheye's
  ``theta_max``) the column is NaN, never a flipped or folded-back ray;
- ``distort(xy)`` / ``undistort(xy_d)`` on normalised image coordinates, and
  ``distort_pixels`` / ``undistort_pixels`` between this camera's pixels and those of the
  distortion-free pinhole camera with the same ``K`` (:meth:`Camera.pinhole`);
- ``gtsam_calibration()``: the matching GTSAM calibration (Cal3_S2, Cal3DS2, Cal3Fisheye)
  or None where GTSAM has none (a radial-tangential camera with k3..k6 not all zero).

A camera may carry the ``covariance`` of its intrinsic parameters (a calibration's, see
:mod:`graphpose.calibrate`): (P, P) in the order of the class's ``parameter_names``, pixels and
unitless, None (unknown) by default; symmetric positive semi-definite, read-only. It is not
part of equality or the hash: two cameras are equal when they project alike (same model, ``K``,
coefficients, size), so a camera read back from a file format that cannot hold a covariance
(OpenCV, ROS, Kalibr) still equals the calibrated one it was written from.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ._checks import as_float_array, as_points, check_covariance, check_K, check_size
from .errors import InputError

#: Iterative inversions stop when the forward model reproduces its target to within this,
#: in normalised image units (radians of theta_d for the fisheye): 1e-12 is 1e-9 px at a
#: focal length of 1000 px.
UNPROJECT_TOL = 1e-12
#: Iteration cap of the inversions (Newton with step halving, or Newton-bisection).
MAX_ITERATIONS = 100

#: The coefficient counts each model takes, for messages.
_COUNTS = {
    "RadTanCamera": "4, 5 or 8 (k1, k2, p1, p2[, k3[, k4, k5, k6]]), OpenCV's radial-tangential",
    "FisheyeCamera": "4 (k1, k2, k3, k4), OpenCV's fisheye",
}


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)  # a copy: the camera owns its arrays
    a.setflags(write=False)
    return a


def _coefficients(distortion) -> np.ndarray:
    """The distortion coefficients as a finite 1-D array, or InputError."""
    d = as_float_array(distortion, "distortion")
    if d.ndim > 2 or (d.ndim == 2 and 1 not in d.shape):
        raise InputError(f"distortion must be a vector of coefficients, got shape {d.shape}")
    d = d.ravel()
    if not np.all(np.isfinite(d)):
        raise InputError(f"distortion contains NaN or infinite values: {d.tolist()}")
    return d


def _count_error(n: int, cls: str) -> InputError:
    """The message for ``n`` coefficients that ``cls`` does not take: what ``n`` could be."""
    fits = []
    if n in (4, 5, 8):
        fits.append(f"RadTanCamera takes {n}")
    if n == 4:
        fits.append("FisheyeCamera takes 4")
    if n in (12, 14):
        extra = "OpenCV's thin-prism model (s1..s4)" + (
            " with the tilted sensor (tau_x, tau_y)" if n == 14 else "")
        hint = f"{n} coefficients are {extra}, which graphpose does not support"
    elif fits:
        hint = "; ".join(fits)
    else:
        hint = f"{n} fits no model"
    models = "; ".join(f"{name} takes {what}" for name, what in _COUNTS.items())
    return InputError(f"{cls} got {n} distortion coefficients: {hint} ({models})")


class Camera:
    """What every camera model offers; see the module docstring. Not instantiated itself.

    Attributes
    ----------
    K : (3, 3) ndarray
        Intrinsics, pixels, read-only.
    distortion : (n,) ndarray
        The coefficients in OpenCV's order, read-only; empty for the pinhole.
    size : (int, int) or None
        The image size ``(width, height)`` the calibration holds for, pixels; None when
        unknown (then :func:`check_image_size` accepts any image).
    model : str
        ``"pinhole"``, ``"radtan"`` or ``"fisheye"`` (the names of the JSON camera file).
    parameter_names : tuple of str
        The intrinsic parameters a calibration estimates, in the order of ``covariance``
        (:func:`graphpose.calibrate.parameter_names`).
    covariance : (P, P) ndarray or None
        Covariance of those parameters (pixels, unitless), read-only; None when unknown. Not
        part of equality (see the module docstring).
    """

    model: ClassVar[str] = ""
    parameter_names: ClassVar[tuple] = ()
    K: np.ndarray
    distortion: np.ndarray
    size: tuple | None

    # ---- intrinsics -------------------------------------------------------------------
    @property
    def fx(self) -> float:
        """Focal length along u, pixels."""
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        """Focal length along v, pixels."""
        return float(self.K[1, 1])

    @property
    def cx(self) -> float:
        """Principal point u, pixels."""
        return float(self.K[0, 2])

    @property
    def cy(self) -> float:
        """Principal point v, pixels."""
        return float(self.K[1, 2])

    @property
    def skew(self) -> float:
        """``K[0, 1]``, pixels (OpenCV's fisheye ``alpha`` is ``skew / fx``)."""
        return float(self.K[0, 1])

    def pinhole(self) -> PinholeCamera:
        """The distortion-free camera with the same ``K`` and size."""
        return PinholeCamera(self.K, self.size)

    # ---- equality: same model, same numbers ---------------------------------------------
    def _key(self) -> tuple:
        # + 0.0 turns -0.0 into 0.0, so that equal numbers give equal bytes.
        return (type(self).__name__, (self.K + 0.0).tobytes(), (self._full() + 0.0).tobytes(),
                self.size)

    def _full(self) -> np.ndarray:
        return self.distortion

    def __eq__(self, other):
        if not isinstance(other, Camera):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self):
        return hash(self._key())

    # ---- pixels <-> normalised image coordinates ----------------------------------------
    def _to_pixels(self, xy: np.ndarray) -> np.ndarray:
        return self.K[:2, :2] @ xy + self.K[:2, 2:3]

    def _from_pixels(self, uv: np.ndarray) -> np.ndarray:
        y = (uv[1] - self.cy) / self.fy
        x = (uv[0] - self.cx - self.skew * y) / self.fx
        return np.stack([x, y])

    # ---- the public operations ----------------------------------------------------------
    def project(self, P_C) -> np.ndarray:
        """Pixels of camera-frame points.

        Parameters
        ----------
        P_C : (3, N) array_like
            Points in the camera frame, metres.

        Returns
        -------
        uv : (2, N) ndarray
            Pixels (u, v). Columns of points the model cannot image are NaN: points at or
            behind the plane z = 0 for the pinhole and radial-tangential models, the centre
            and the backward axis for the fisheye.

        Raises
        ------
        InputError
            If ``P_C`` is not a finite (3, N) array.
        """
        return self._project(as_points(P_C, 3, "P_C", min_count=0), False)[0]

    def project_jacobian(self, P_C):
        """Pixels of camera-frame points and their analytic Jacobian.

        Parameters
        ----------
        P_C : (3, N) array_like
            Points in the camera frame, metres.

        Returns
        -------
        uv : (2, N) ndarray
            As :meth:`project`.
        J : (N, 2, 3) ndarray
            ``J[j] = d uv_j / d P_C[:, j]``, pixels per metre; NaN where ``uv`` is.

        Raises
        ------
        InputError
            If ``P_C`` is not a finite (3, N) array.
        """
        return self._project(as_points(P_C, 3, "P_C", min_count=0), True)

    def unproject(self, uv) -> np.ndarray:
        """Unit rays of pixels, in the camera frame.

        Parameters
        ----------
        uv : (2, N) array_like
            Pixels (u, v).

        Returns
        -------
        rays : (3, N) ndarray
            Unit vectors along which each pixel sees, ``project(rays) == uv`` to within
            :data:`UNPROJECT_TOL` in normalised units (found by iteration for the
            distorting models). ``z`` may be negative for a fisheye beyond 90 degrees.
            NaN columns where no ray on the model's unfolded branch reaches the pixel.

        Raises
        ------
        InputError
            If ``uv`` is not a finite (2, N) array.
        """
        return self._unproject(self._from_pixels(as_points(uv, 2, "uv", min_count=0)))

    def distort(self, xy) -> np.ndarray:
        """Distorted normalised coordinates of ideal ones (the lens model on its own).

        Parameters
        ----------
        xy : (2, N) array_like
            Ideal (pinhole) normalised image coordinates ``(x/z, y/z)``.

        Returns
        -------
        xy_d : (2, N) ndarray
            Distorted normalised coordinates; the pixels are ``K [xy_d; 1]``.
        """
        return self._distort(as_points(xy, 2, "xy", min_count=0))

    def undistort(self, xy_d) -> np.ndarray:
        """Ideal normalised coordinates of distorted ones, the inverse of :meth:`distort`.

        Parameters
        ----------
        xy_d : (2, N) array_like
            Distorted normalised image coordinates, ``K^-1 [u, v, 1]``.

        Returns
        -------
        xy : (2, N) ndarray
            Ideal normalised coordinates ``(x/z, y/z)``; NaN columns where there is none (no
            ray reaches the point, or the ray points at or behind z = 0, which a fisheye
            sees and ``(x/z, y/z)`` cannot hold: use :meth:`unproject` for those).
        """
        rays = self._unproject(as_points(xy_d, 2, "xy_d", min_count=0))
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(rays[2] > 0, rays[:2] / rays[2], np.nan)

    def distort_pixels(self, uv) -> np.ndarray:
        """This camera's pixels of pixels of the distortion-free camera :meth:`pinhole`.

        Parameters
        ----------
        uv : (2, N) array_like
            Pixels of the ideal pinhole camera with the same ``K``.

        Returns
        -------
        uv_d : (2, N) ndarray
            The same rays' pixels in this camera.
        """
        xy = self._from_pixels(as_points(uv, 2, "uv", min_count=0))
        return self._to_pixels(self._distort(xy))

    def undistort_pixels(self, uv_d) -> np.ndarray:
        """Pixels of the distortion-free camera :meth:`pinhole` of this camera's pixels.

        Parameters
        ----------
        uv_d : (2, N) array_like
            Pixels of this camera (raw image).

        Returns
        -------
        uv : (2, N) ndarray
            The same rays' pixels in the ideal pinhole camera with the same ``K``; NaN
            where :meth:`undistort` is.
        """
        xy_d = self._from_pixels(as_points(uv_d, 2, "uv_d", min_count=0))
        rays = self._unproject(xy_d)
        with np.errstate(divide="ignore", invalid="ignore"):
            xy = np.where(rays[2] > 0, rays[:2] / rays[2], np.nan)
        return self._to_pixels(xy)

    def gtsam_calibration(self):
        """The GTSAM calibration with the same projection, or None where GTSAM has none.

        Returns
        -------
        gtsam.Cal3_S2, gtsam.Cal3DS2, gtsam.Cal3Fisheye or None
            Cal3_S2 for the pinhole; Cal3DS2 for a radial-tangential camera whose k3..k6
            are all zero (GTSAM's Cal3DS2 has k1, k2, p1, p2 only), None otherwise (use a
            custom factor around :meth:`project_jacobian`); Cal3Fisheye for the fisheye
            (GTSAM projects through ``(x/z, y/z)``, so only points in front, z > 0).
            GTSAM is imported here, on first call.
        """
        raise NotImplementedError  # pragma: no cover  (every model overrides it)

    # ---- model-specific parts ----------------------------------------------------------
    def _distort(self, xy: np.ndarray) -> np.ndarray:
        raise NotImplementedError  # pragma: no cover

    def _project(self, P: np.ndarray, jacobian: bool):
        raise NotImplementedError  # pragma: no cover

    def _unproject(self, xy_d: np.ndarray) -> np.ndarray:
        raise NotImplementedError  # pragma: no cover


_NONE = _readonly(np.zeros(0))


def _init_common(camera, K, size) -> None:
    object.__setattr__(camera, "K", _readonly(check_K(K)))
    object.__setattr__(camera, "size", None if size is None else check_size(size))
    if camera.covariance is not None:
        names = type(camera).parameter_names
        cov = check_covariance(camera.covariance, len(names),
                               f"{type(camera).__name__} covariance (of {', '.join(names)})")
        object.__setattr__(camera, "covariance", _readonly(cov))


def _rays(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Unit rays through normalised coordinates (x, y, 1)."""
    norm = np.sqrt(x * x + y * y + 1.0)
    return np.stack([x / norm, y / norm, 1.0 / norm])


def _perspective(P: np.ndarray, jacobian: bool):
    """``(x, y) = (X/Z, Y/Z)`` with NaN where Z <= 0, and d(x, y)/dP, (N, 2, 3)."""
    Z = np.where(P[2] > 0, P[2], np.nan)
    x, y = P[0] / Z, P[1] / Z
    if not jacobian:
        return np.stack([x, y]), None
    n = P.shape[1]
    J = np.zeros((n, 2, 3))
    J[:, 0, 0] = J[:, 1, 1] = 1.0 / Z
    J[:, 0, 2] = -x / Z
    J[:, 1, 2] = -y / Z
    return np.stack([x, y]), J


@dataclass(frozen=True, eq=False)
class PinholeCamera(Camera):
    """The distortion-free camera ``[u, v, 1]^T ~ K p_C`` (graphpose's model until now).

    Parameters
    ----------
    K : (3, 3) array_like
        Intrinsics, pixels; skew ``K[0, 1]`` allowed.
    size : (int, int), optional
        Image ``(width, height)``, pixels.
    covariance : (P, P) array_like, optional
        Covariance of the intrinsic parameters in ``parameter_names`` order (pixels,
        unitless), symmetric positive semi-definite; None (unknown) by default.

    Raises
    ------
    InputError
        If ``K`` fails :func:`graphpose.check_K`, ``size`` is not two positive integers or
        ``covariance`` fails :func:`graphpose._checks.check_covariance`.
    """

    K: np.ndarray
    size: tuple | None = None
    covariance: np.ndarray | None = field(default=None, repr=False, compare=False)
    model: ClassVar[str] = "pinhole"
    parameter_names: ClassVar[tuple] = ("fx", "fy", "cx", "cy")

    def __post_init__(self):
        _init_common(self, self.K, self.size)

    @property
    def distortion(self) -> np.ndarray:
        """No coefficients: an empty array."""
        return _NONE

    def _distort(self, xy):
        return xy.copy()

    def _project(self, P, jacobian):
        xy, N = _perspective(P, jacobian)
        uv = self._to_pixels(xy)
        return (uv, self.K[:2, :2] @ N) if jacobian else (uv, None)

    def _unproject(self, xy_d):
        return _rays(xy_d[0], xy_d[1])

    def gtsam_calibration(self):
        import gtsam

        return gtsam.Cal3_S2(self.fx, self.fy, self.skew, self.cx, self.cy)


@dataclass(frozen=True, eq=False)
class RadTanCamera(Camera):
    """OpenCV's radial-tangential (Brown-Conrady) camera, rational model included.

    With ``(x, y) = (X/Z, Y/Z)``, ``r^2 = x^2 + y^2``,

        x_d = x g + 2 p1 x y + p2 (r^2 + 2 x^2)
        y_d = y g + p1 (r^2 + 2 y^2) + 2 p2 x y
        g   = (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6)

    and ``u = fx x_d + cx``, ``v = fy y_d + cy`` (OpenCV's ``projectPoints``).

    Parameters
    ----------
    K : (3, 3) array_like
        Intrinsics, pixels; ``K[0, 1]`` must be 0 (OpenCV's model has no skew: its
        functions ignore ``K[0, 1]``).
    distortion : (n,) array_like
        ``(k1, k2, p1, p2)``, ``(k1, k2, p1, p2, k3)`` or ``(k1, k2, p1, p2, k3, k4, k5,
        k6)``; absent ones are 0. Shapes (1, n) and (n, 1), as OpenCV returns them, are
        accepted.
    size : (int, int), optional
        Image ``(width, height)``, pixels.
    covariance : (P, P) array_like, optional
        Covariance of the intrinsic parameters in ``parameter_names`` order (pixels,
        unitless), symmetric positive semi-definite; None (unknown) by default.

    Raises
    ------
    InputError
        If ``K`` is invalid or has skew, a coefficient is not finite, their count is not 4,
        5 or 8 (the message says which models the count would fit), or ``size`` or
        ``covariance`` is bad.
    """

    K: np.ndarray
    distortion: np.ndarray
    size: tuple | None = None
    covariance: np.ndarray | None = field(default=None, repr=False, compare=False)
    model: ClassVar[str] = "radtan"
    parameter_names: ClassVar[tuple] = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")

    def __post_init__(self):
        _init_common(self, self.K, self.size)
        if self.K[0, 1] != 0.0:
            raise InputError(
                f"RadTanCamera: OpenCV's radial-tangential model has no skew (its functions "
                f"ignore K[0, 1]); K[0, 1] must be 0, got {self.K[0, 1]}")
        d = _coefficients(self.distortion)
        if d.size not in (4, 5, 8):
            raise _count_error(d.size, "RadTanCamera")
        object.__setattr__(self, "distortion", _readonly(d))
        full = self.coefficients
        object.__setattr__(self, "_coeffs", tuple(float(c) for c in full))
        object.__setattr__(self, "_rational", bool(np.any(full[5:] != 0.0)))

    @property
    def coefficients(self) -> np.ndarray:
        """All eight ``(k1, k2, p1, p2, k3, k4, k5, k6)``, zeros for absent ones."""
        full = np.zeros(8)
        full[: self.distortion.size] = self.distortion
        return full

    def _full(self):
        return self.coefficients

    def _parts(self, x, y, jacobian):
        """Distorted ``(x_d, y_d)``, the radial factor ``g`` and, if asked, the three distinct
        entries ``(d00, d01, d11)`` of the symmetric ``d(x_d, y_d) / d(x, y)``.

        The rational denominator is left out when k4..k6 are all zero (it is exactly 1).
        """
        k1, k2, p1, p2, k3, k4, k5, k6 = self._coeffs
        r2 = x * x + y * y
        a = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        if self._rational:
            b = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
            g = a / b
        else:
            g = a
        xd = x * g + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
        yd = y * g + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
        if not jacobian:
            return xd, yd, g, None
        da = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
        if self._rational:
            db = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
            dg = (da * b - a * db) / (b * b)  # d g / d r^2
        else:
            dg = da
        d00 = g + 2.0 * x * x * dg + 2.0 * p1 * y + 6.0 * p2 * x
        d01 = 2.0 * x * y * dg + 2.0 * p1 * x + 2.0 * p2 * y
        d11 = g + 2.0 * y * y * dg + 6.0 * p1 * y + 2.0 * p2 * x
        return xd, yd, g, (d00, d01, d11)

    def _distort_jac(self, x, y, jacobian):
        xd, yd, g, d = self._parts(x, y, jacobian)
        if not jacobian:
            return xd, yd, g, None
        D = np.empty((x.size, 2, 2))
        D[:, 0, 0], D[:, 0, 1], D[:, 1, 1] = d
        D[:, 1, 0] = d[1]
        return xd, yd, g, D

    def _distort(self, xy):
        xd, yd, _, _ = self._parts(xy[0], xy[1], False)
        return np.stack([xd, yd])

    def _project(self, P, jacobian):
        Z = np.where(P[2] > 0, P[2], np.nan)
        x, y = P[0] / Z, P[1] / Z
        xd, yd, _, d = self._parts(x, y, jacobian)
        fx, fy, cx, cy = self.fx, self.fy, self.cx, self.cy
        uv = np.empty((2, x.size))
        uv[0], uv[1] = fx * xd + cx, fy * yd + cy
        if not jacobian:
            return uv, None
        # K (no skew) times d(x_d, y_d)/d(x, y) (symmetric) times d(x, y)/dP, written out.
        d00, d01, d11 = d
        iz = 1.0 / Z
        J = np.empty((x.size, 2, 3))
        J[:, 0, 0], J[:, 0, 1] = fx * d00 * iz, fx * d01 * iz
        J[:, 0, 2] = -fx * (d00 * x + d01 * y) * iz
        J[:, 1, 0], J[:, 1, 1] = fy * d01 * iz, fy * d11 * iz
        J[:, 1, 2] = -fy * (d01 * x + d11 * y) * iz
        return uv, J

    def _unproject(self, xy_d):
        """Newton's method with step halving on distort(x) = x_d, started at x_d.

        A root counts only on the unfolded branch: radial factor g > 0 (not the image turned
        through the centre) and an orientation-preserving lens map (not the folded-back
        ring); else NaN. For a calibration that is one-to-one over its image every pixel
        gets its ray; for a model driven past its fold, a pixel whose Newton path ends on the
        folded branch is NaN even where an unfolded ray exists.
        """
        tx, ty = xy_d[0], xy_d[1]
        x, y = tx.copy(), ty.copy()
        tol = UNPROJECT_TOL * np.maximum(1.0, np.maximum(np.abs(tx), np.abs(ty)))
        xd, yd, _, (d00, d01, d11) = self._parts(x, y, True)
        rx, ry = xd - tx, yd - ty
        err = np.maximum(np.abs(rx), np.abs(ry))
        active = err > tol
        for _ in range(MAX_ITERATIONS):
            idx = np.flatnonzero(active)
            if idx.size == 0:
                break
            if idx.size == x.size:  # all still moving: no gathers
                xi, yi, a00, a01, a11, rxi, ryi, ei, txi, tyi = x, y, d00, d01, d11, rx, ry, err, tx, ty
            else:
                xi, yi, a00, a01, a11 = x[idx], y[idx], d00[idx], d01[idx], d11[idx]
                rxi, ryi, ei, txi, tyi = rx[idx], ry[idx], err[idx], tx[idx], ty[idx]
            det = a00 * a11 - a01 * a01
            sx = (a11 * rxi - a01 * ryi) / det
            sy = (a00 * ryi - a01 * rxi) / det
            t = np.ones(idx.size)
            for _ in range(40):  # halve the step where it does not reduce the residual
                ux, uy = xi - t * sx, yi - t * sy
                xd, yd, _, dt = self._parts(ux, uy, True)
                rtx, rty = xd - txi, yd - tyi
                e = np.maximum(np.abs(rtx), np.abs(rty))
                worse = ~(e < ei)
                if not worse.any():
                    break
                t[worse] *= 0.5
            moved = ~worse
            if moved.all():
                keep = idx
            else:
                keep = idx[moved]
                ux, uy, rtx, rty, e = ux[moved], uy[moved], rtx[moved], rty[moved], e[moved]
                dt = tuple(d[moved] for d in dt)
                active[idx[worse]] = False  # stalled: judged below
            x[keep], y[keep], rx[keep], ry[keep], err[keep] = ux, uy, rtx, rty, e
            d00[keep], d01[keep], d11[keep] = dt
            active[keep] = e > tol[keep]
        # A root on the model's one-to-one branch: converged, the radial factor positive (not
        # the image flipped through the centre), and distort locally orientation-preserving.
        _, _, g, (d00, d01, d11) = self._parts(x, y, True)
        det = d00 * d11 - d01 * d01
        good = (err <= tol) & (g > 0) & (det > 0)
        rays = _rays(x, y)
        rays[:, ~good] = np.nan
        return rays

    def gtsam_calibration(self):
        if np.any(self.coefficients[4:] != 0.0):
            return None
        import gtsam

        k1, k2, p1, p2 = self.coefficients[:4]
        return gtsam.Cal3DS2(self.fx, self.fy, 0.0, self.cx, self.cy, k1, k2, p1, p2)


@dataclass(frozen=True, eq=False)
class FisheyeCamera(Camera):
    """OpenCV's fisheye camera (equidistant Kannala-Brandt, ``cv::fisheye``).

    With ``theta`` the angle between the ray ``P_C`` and the optical axis (``atan2(rho, Z)``,
    ``rho = sqrt(X^2 + Y^2)``, which is OpenCV's ``atan(r)`` for points in front and goes on
    past 90 degrees),

        theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)
        (x_d, y_d) = theta_d (X, Y) / rho

    and ``u = fx x_d + skew y_d + cx``, ``v = fy y_d + cy`` (OpenCV's ``alpha`` is ``skew / fx``).

    Parameters
    ----------
    K : (3, 3) array_like
        Intrinsics, pixels; skew ``K[0, 1]`` allowed.
    distortion : (4,) array_like
        ``(k1, k2, k3, k4)``; shapes (1, 4) and (4, 1) are accepted.
    size : (int, int), optional
        Image ``(width, height)``, pixels.
    covariance : (P, P) array_like, optional
        Covariance of the intrinsic parameters in ``parameter_names`` order (pixels,
        unitless), symmetric positive semi-definite; None (unknown) by default.

    Attributes
    ----------
    theta_max : float
        The largest angle off the axis (radians, at most pi) up to which ``theta_d`` grows
        with ``theta``: the model is one-to-one there, and :meth:`unproject` answers for
        pixels up to ``theta_d(theta_max)`` from the centre, NaN beyond.

    Raises
    ------
    InputError
        If ``K`` is invalid, a coefficient is not finite, there are not 4, or ``size`` or
        ``covariance`` is bad.
    """

    K: np.ndarray
    distortion: np.ndarray
    size: tuple | None = None
    theta_max: float = field(init=False, repr=False)
    covariance: np.ndarray | None = field(default=None, repr=False, compare=False)
    model: ClassVar[str] = "fisheye"
    parameter_names: ClassVar[tuple] = ("fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4")

    def __post_init__(self):
        _init_common(self, self.K, self.size)
        d = _coefficients(self.distortion)
        if d.size != 4:
            raise _count_error(d.size, "FisheyeCamera")
        object.__setattr__(self, "distortion", _readonly(d))
        # d theta_d / d theta = 1 + 3 k1 t + 5 k2 t^2 + 7 k3 t^3 + 9 k4 t^4, t = theta^2:
        # its first positive root (if below pi^2) is where the model folds back.
        k1, k2, k3, k4 = d
        roots = np.roots([9.0 * k4, 7.0 * k3, 5.0 * k2, 3.0 * k1, 1.0])
        real = roots[np.abs(roots.imag) <= 1e-12 * np.maximum(1.0, np.abs(roots))].real
        real = real[real > 0]
        t_max = min(real.min(), np.pi ** 2) if real.size else np.pi ** 2
        object.__setattr__(self, "theta_max", float(np.sqrt(t_max)))

    def _theta_d(self, th):
        k1, k2, k3, k4 = self.distortion
        t = th * th
        return th * (1.0 + t * (k1 + t * (k2 + t * (k3 + t * k4))))

    def _dtheta_d(self, th):
        k1, k2, k3, k4 = self.distortion
        t = th * th
        return 1.0 + t * (3.0 * k1 + t * (5.0 * k2 + t * (7.0 * k3 + t * 9.0 * k4)))

    def _distort(self, xy):
        P = np.vstack([xy, np.ones(xy.shape[1])])
        return self._distorted(P, False)[0]

    def _distorted(self, P, jacobian):
        """(x_d, y_d) of camera-frame points, and d(x_d, y_d)/dP, (N, 2, 3)."""
        X, Y, Z = P
        rho = np.hypot(X, Y)
        R2 = rho * rho + Z * Z
        th = np.arctan2(rho, Z)
        td = self._theta_d(th)
        on_axis = rho == 0
        safe = np.where(on_axis, 1.0, rho)
        # s = theta_d / rho; on the forward axis its limit is 1 / Z; undefined backwards.
        s = np.where(on_axis, np.where(Z > 0, 1.0 / np.where(Z > 0, Z, 1.0), np.nan), td / safe)
        xy = np.stack([s * X, s * Y])
        if not jacobian:
            return xy, None
        m = self._dtheta_d(th)
        # d s / d(X, Y) = (X, Y) c, c = (m Z / R^2 - s) / rho^2 (0 on the axis, by symmetry);
        # d s / d Z = -m / R^2.
        c = np.where(on_axis, 0.0, (m * Z / np.where(R2 > 0, R2, 1.0) - s) / (safe * safe))
        dsdZ = -m / np.where(R2 > 0, R2, np.nan)
        J = np.empty((X.size, 2, 3))
        J[:, 0, 0] = s + X * X * c
        J[:, 0, 1] = J[:, 1, 0] = X * Y * c
        J[:, 1, 1] = s + Y * Y * c
        J[:, 0, 2] = X * dsdZ
        J[:, 1, 2] = Y * dsdZ
        J[np.isnan(s)] = np.nan
        return xy, J

    def _project(self, P, jacobian):
        xy, D = self._distorted(P, jacobian)
        uv = self._to_pixels(xy)
        return (uv, self.K[:2, :2] @ D) if jacobian else (uv, None)

    def _theta(self, td):
        """theta in [0, theta_max] with theta_d(theta) = td, NaN where td is out of range.

        Newton's method safeguarded by bisection on the bracket [0, theta_max], where
        theta_d rises monotonically: it converges for every td in range.
        """
        hi0 = self.theta_max
        ok = td <= self._theta_d(hi0) * (1.0 + 1e-15)
        lo = np.zeros_like(td)
        hi = np.full_like(td, hi0)
        th = np.clip(td, 0.0, hi0)
        for _ in range(MAX_ITERATIONS + 60):  # bisection alone needs ~60 halvings
            f = self._theta_d(th) - td
            if np.all(~ok | (np.abs(f) <= UNPROJECT_TOL * np.maximum(1.0, td))):
                break
            lo = np.where(f < 0, th, lo)
            hi = np.where(f > 0, th, hi)
            with np.errstate(divide="ignore", invalid="ignore"):
                new = th - f / self._dtheta_d(th)
            bad = ~((new > lo) & (new < hi))
            th = np.where(f == 0, th, np.where(bad, 0.5 * (lo + hi), new))
        return np.where(ok, th, np.nan)

    def _unproject(self, xy_d):
        td = np.hypot(xy_d[0], xy_d[1])
        th = self._theta(td)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(td > 0, np.sin(th) / np.where(td > 0, td, 1.0), 0.0)
        return np.stack([scale * xy_d[0], scale * xy_d[1], np.cos(th)])

    def gtsam_calibration(self):
        import gtsam

        return gtsam.Cal3Fisheye(self.fx, self.fy, self.skew, self.cx, self.cy,
                                 *(float(k) for k in self.distortion))


def as_camera(camera_or_K) -> Camera:
    """A camera object from either a camera or a pinhole ``K``, for APIs that take both.

    Parameters
    ----------
    camera_or_K : Camera or (3, 3) array_like
        A :class:`Camera` is returned as it is; anything else is read as the intrinsics of a
        :class:`PinholeCamera` (no distortion, size unknown).

    Raises
    ------
    InputError
        If a ``K`` fails :func:`graphpose.check_K`.
    """
    if isinstance(camera_or_K, Camera):
        return camera_or_K
    return PinholeCamera(camera_or_K)


def check_image_size(camera, image_shape, what: str = "image") -> None:
    """Refuse an image whose size differs from the calibration's.

    Parameters
    ----------
    camera : Camera
        Its ``size`` (width, height); None accepts any image.
    image_shape : tuple of int or ndarray
        The image's ``shape``, ``(height, width[, channels])``, or the image itself.
    what : str
        The image's name in the message (its file, say).

    Raises
    ------
    InputError
        If the sizes differ: a calibration holds at its own resolution only (``K`` scales
        with the image, and a crop moves the principal point).
    """
    camera = as_camera(camera)
    shape = tuple(getattr(image_shape, "shape", image_shape))
    if len(shape) not in (2, 3):
        raise InputError(f"{what}: image shape must be (height, width[, channels]), got {shape}")
    if camera.size is None:
        return
    height, width = int(shape[0]), int(shape[1])
    if (width, height) != tuple(camera.size):
        raise InputError(
            f"{what} is {width} x {height} pixels but the camera is calibrated for "
            f"{camera.size[0]} x {camera.size[1]} (width x height); a calibration holds at "
            f"its own resolution only: use this camera's calibration at {width} x {height}")

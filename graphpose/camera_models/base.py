"""The interface every camera model offers, and the distortion-free pinhole camera.

:class:`Camera` holds what the three models share (the intrinsics, equality, the conversion
between pixels and normalised image coordinates, and the public operations, which check their
input and call the model's own ``_distort``, ``_project`` and ``_unproject``);
:class:`PinholeCamera` is the default model, and :func:`as_camera` turns a 3 x 3 ``K`` into one.
The helpers the distorting models share (read-only arrays, coefficient counts and their
messages, the perspective division, unit rays, the iteration limits) are here too; the models
themselves are in :mod:`graphpose.camera_models.radtan` and
:mod:`graphpose.camera_models.fisheye`. See :mod:`graphpose.camera_models` for the interface.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from .._checks import as_float_array, as_points, check_covariance, check_K, check_size
from ..errors import InputError


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
        ``"pinhole"``, ``"radtan"``, ``"rational"`` or ``"fisheye"`` (the names of the JSON
        camera file and of :data:`graphpose.camera_models.MODELS`).
    parameter_names : tuple of str
        The names of the intrinsic parameters a calibration estimates, in the order of
        :attr:`parameters` and ``covariance``; a class attribute.
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

    # ---- the intrinsic parameters a calibration estimates -------------------------------
    @property
    def parameters(self) -> np.ndarray:
        """The intrinsic parameters, (P,), in :attr:`parameter_names` order.

        ``fx, fy, cx, cy`` (pixels), then the model's coefficients (unitless) in OpenCV's
        order. What is not a parameter stays as the camera has it: the skew ``K[0, 1]``, and
        the ``k4, k5, k6`` of an eight-coefficient :class:`RadTanCamera`. A new array each time.
        """
        return np.array([self.fx, self.fy, self.cx, self.cy] + self._coefficient_parameters())

    def _coefficient_parameters(self) -> list:
        """The model's coefficients among the parameters, in order (none for the pinhole)."""
        return []

    @classmethod
    def _parameter_vector(cls, parameters) -> np.ndarray:
        """``parameters`` as a finite (P,) vector of this model's, or InputError."""
        names = cls.parameter_names
        p = as_float_array(parameters, "parameters").ravel()
        if p.size != len(names):
            raise InputError(f"a {cls.model} camera has {len(names)} parameters "
                             f"({', '.join(names)}), got {p.size}")
        if not np.all(np.isfinite(p)):
            raise InputError(f"parameters contain NaN or infinite values: {p.tolist()}")
        return p

    @staticmethod
    def _parameter_K(p: np.ndarray, skew: float) -> np.ndarray:
        """``K`` of the parameters ``fx, fy, cx, cy`` and a skew that is not one of them."""
        return np.array([[p[0], skew, p[2]], [0.0, p[1], p[3]], [0.0, 0.0, 1.0]])

    @classmethod
    def from_parameters(cls, parameters, size=None, covariance=None, *, skew: float = 0.0) -> Camera:
        """The camera of this model with the given intrinsic parameters.

        Parameters
        ----------
        parameters : (P,) array_like
            In :attr:`parameter_names` order: ``fx, fy, cx, cy`` (pixels), then the model's
            coefficients.
        size : (int, int), optional
            Image ``(width, height)``, pixels.
        covariance : (P, P) array_like, optional
            The parameters' covariance, carried by the camera; None: unknown.
        skew : float
            ``K[0, 1]``, pixels: not a parameter (a calibration holds it at 0, as OpenCV does);
            the radial-tangential models take 0 only.

        Returns
        -------
        camera : Camera
            Of this class.

        Raises
        ------
        InputError
            If ``parameters`` is not P finite numbers or makes an invalid camera (a focal
            length <= 0), or ``covariance`` is not a (P, P) symmetric positive semi-definite
            matrix.
        """
        raise NotImplementedError  # pragma: no cover  (every model overrides it)

    def with_parameters(self, parameters, covariance=None) -> Camera:
        """The camera of the same model and image size with other intrinsic parameters.

        What is not a parameter (the skew; an eight-coefficient :class:`RadTanCamera`'s ``k4,
        k5, k6``) comes from this camera; see :meth:`from_parameters`.

        Parameters
        ----------
        parameters : (P,) array_like
            In :attr:`parameter_names` order.
        covariance : (P, P) array_like, optional
            Their covariance, carried by the new camera; None: unknown.

        Returns
        -------
        camera : Camera
            Of the same class; a radial-tangential camera keeps 5 coefficients (8 if it had 8).

        Raises
        ------
        InputError
            As :meth:`from_parameters`.
        """
        return type(self).from_parameters(parameters, self.size, covariance, **self._held())

    def _held(self) -> dict:
        """What :meth:`with_parameters` keeps that is not a parameter, as keywords of
        :meth:`from_parameters`."""
        return {"skew": self.skew}

    def parameter_jacobian(self, P_C) -> np.ndarray:
        """The derivative of the pixels of camera-frame points with respect to the parameters.

        Parameters
        ----------
        P_C : (3, N) array_like
            Points in the camera frame, metres.

        Returns
        -------
        J : (N, 2, P) ndarray
            ``J[j, :, i] = d uv_j / d p_i``, analytic, in :attr:`parameter_names` order (pixels
            per pixel for ``fx, fy, cx, cy``, pixels per unit for the coefficients), the skew
            held fixed; NaN rows where :meth:`project` is NaN. It is a calibration's Jacobian,
            and the map that carries the parameters' covariance into pixels (``J cov J^T``).

        Raises
        ------
        InputError
            If ``P_C`` is not a finite (3, N) array.
        """
        P = as_points(P_C, 3, "P_C", min_count=0)
        uv = self.project(P)
        xd, yd = self._from_pixels(uv)  # the lens's normalised coordinates: d uv / d(fx, fy)
        n = P.shape[1]
        J = np.zeros((n, 2, len(self.parameter_names)))
        J[:, 0, 0], J[:, 1, 1] = xd, yd
        J[:, 0, 2] = J[:, 1, 3] = 1.0
        self._coefficient_jacobian(P, J)
        J[~np.all(np.isfinite(uv), axis=0)] = np.nan
        return J

    def _coefficient_jacobian(self, P: np.ndarray, J: np.ndarray) -> None:
        """Fill ``J[:, :, 4:]``, the derivative in the model's coefficients (none for the pinhole)."""

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
        If ``K`` fails :func:`graphpose._checks.check_K`, ``size`` is not two positive integers or
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

    @classmethod
    def from_parameters(cls, parameters, size=None, covariance=None, *, skew: float = 0.0) -> PinholeCamera:
        """The pinhole camera of ``fx, fy, cx, cy``; see :meth:`Camera.from_parameters`."""
        p = cls._parameter_vector(parameters)
        return cls(cls._parameter_K(p, skew), size, covariance)

    def gtsam_calibration(self):
        import gtsam

        return gtsam.Cal3_S2(self.fx, self.fy, self.skew, self.cx, self.cy)


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
        If a ``K`` fails :func:`graphpose._checks.check_K`.
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

"""OpenCV's fisheye camera (equidistant Kannala-Brandt, ``cv::fisheye``).

The equations are in :class:`FisheyeCamera` and ``docs/cameras.md``; the interface is
:class:`graphpose.camera_models.Camera`'s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from .base import MAX_ITERATIONS, UNPROJECT_TOL, Camera, _coefficients, _count_error, _init_common, _readonly


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

    # ---- the parameters: fx, fy, cx, cy, k1, k2, k3, k4 --------------------------------
    def _coefficient_parameters(self) -> list:
        return list(self.distortion)

    @classmethod
    def from_parameters(cls, parameters, size=None, covariance=None, *, skew: float = 0.0) -> FisheyeCamera:
        """The camera of ``fx, fy, cx, cy, k1, k2, k3, k4``; see :meth:`Camera.from_parameters`."""
        p = cls._parameter_vector(parameters)
        return cls(cls._parameter_K(p, skew), p[4:8], size, covariance)

    def _coefficient_jacobian(self, P, J):
        X, Y, Z = P
        rho = np.hypot(X, Y)
        th = np.arctan2(rho, Z)
        t = th * th
        # d theta_d / d k_i = theta t^i; (x_d, y_d) = theta_d (X, Y) / rho, whose limit on the
        # forward axis has zero derivative in every k_i.
        safe = np.where(rho > 0, rho, 1.0)
        powers = np.stack([th * t, th * t * t, th * t ** 3, th * t ** 4])
        dx = np.where(rho > 0, powers * X / safe, 0.0)
        dy = np.where(rho > 0, powers * Y / safe, 0.0)
        J[:, 0, 4:] = (self.fx * dx + self.skew * dy).T
        J[:, 1, 4:] = (self.fy * dy).T

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

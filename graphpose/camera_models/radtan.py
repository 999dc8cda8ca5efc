"""OpenCV's radial-tangential (Brown-Conrady) camera, rational model included.

The equations are in :class:`RadTanCamera` and ``docs/cameras.md``; the interface is
:class:`graphpose.camera_models.Camera`'s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..errors import InputError
from .base import (MAX_ITERATIONS, UNPROJECT_TOL, Camera, _coefficients, _count_error, _init_common,
                   _rays, _readonly)


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

    # ---- the parameters: fx, fy, cx, cy, k1, k2, p1, p2, k3 ----------------------------
    def _coefficient_parameters(self) -> list:
        return list(self.coefficients[:5])

    @classmethod
    def from_parameters(cls, parameters, size=None, covariance=None, *, skew: float = 0.0,
                        rational=None) -> RadTanCamera:
        """The camera of ``fx, fy, cx, cy, k1, k2, p1, p2, k3``; see :meth:`Camera.from_parameters`.

        ``rational``: ``(k4, k5, k6)``, the denominator of an eight-coefficient camera, held as
        given (they are not parameters of this model); None gives five coefficients.
        """
        p = cls._parameter_vector(parameters)
        d = p[4:9] if rational is None else np.r_[p[4:9], rational]
        return cls(cls._parameter_K(p, skew), d, size, covariance)

    def _held(self) -> dict:
        full = self.coefficients
        return {"skew": self.skew, "rational": full[5:] if self.distortion.size == 8 else None}

    def _coefficient_jacobian(self, P, J):
        Z = np.where(P[2] > 0, P[2], np.nan)
        x, y = P[0] / Z, P[1] / Z
        r2 = x * x + y * y
        k4, k5, k6 = self.coefficients[5:]
        b = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))  # the rational denominator (1 without it)
        # d(x_d, y_d)/d(k1, k2, p1, p2, k3), then times (fx, fy): no skew in this model.
        radial = np.stack([r2, r2 * r2, r2 ** 3]) / b  # d g / d(k1, k2, k3)
        dx = np.stack([x * radial[0], x * radial[1], 2.0 * x * y, r2 + 2.0 * x * x, x * radial[2]])
        dy = np.stack([y * radial[0], y * radial[1], r2 + 2.0 * y * y, 2.0 * x * y, y * radial[2]])
        J[:, 0, 4:9] = (self.fx * dx).T
        J[:, 1, 4:9] = (self.fy * dy).T
        if J.shape[2] > 9:  # the rational model's k4, k5, k6 are parameters too
            # g = a / b: d g / d(k4, k5, k6) = -a (r^2, r^4, r^6) / b^2.
            k1, k2, _, _, k3 = self.coefficients[:5]
            a = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
            dg = -a * np.stack([r2, r2 * r2, r2 ** 3]) / (b * b)
            J[:, 0, 9:] = (self.fx * x * dg).T
            J[:, 1, 9:] = (self.fy * y * dg).T

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
class RationalCamera(RadTanCamera):
    """OpenCV's rational model (``CALIB_RATIONAL_MODEL``; mrcal's ``OPENCV8``) as a model of
    its own: the equations of :class:`RadTanCamera` with all eight coefficients ``(k1, k2, p1,
    p2, k3, k4, k5, k6)`` estimated by a calibration (``parameter_names`` has twelve).

    A :class:`RadTanCamera` with eight coefficients projects alike and compares equal (the
    files that cannot name the model, OpenCV's and ROS's ``rational_polynomial``, read it back
    as one); graphpose's JSON keeps the model ``"rational"``.

    Raises
    ------
    InputError
        As :class:`RadTanCamera`, and if ``distortion`` is not eight coefficients.
    """

    model: ClassVar[str] = "rational"
    parameter_names: ClassVar[tuple] = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")

    def __post_init__(self):
        d = _coefficients(self.distortion)
        if d.size != 8:
            raise InputError(f"RationalCamera takes 8 coefficients (k1, k2, p1, p2, k3, k4, k5, k6: OpenCV's "
                             f"rational model), got {d.size}")
        super().__post_init__()

    def _coefficient_parameters(self) -> list:
        return list(self.coefficients)

    @classmethod
    def from_parameters(cls, parameters, size=None, covariance=None, *, skew: float = 0.0) -> RationalCamera:
        """The camera of ``fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6``; see
        :meth:`Camera.from_parameters`."""
        p = cls._parameter_vector(parameters)
        return cls(cls._parameter_K(p, skew), p[4:12], size, covariance)

    def _held(self) -> dict:
        return {"skew": self.skew}  # all eight coefficients are parameters

    def _key(self) -> tuple:
        # Equal to the radial-tangential camera with the same eight coefficients: same projection.
        return ("RadTanCamera",) + super()._key()[1:]

"""Sub-pixel saddle points of image patches (Lucchese & Mitra, 2002).

Near a cross-junction of a checkerboard a smoothed image looks like a hyperbolic paraboloid.
Fitting Eqn. (4) of Lucchese & Mitra,

    I(x, y) ~ alpha x^2 + beta x y + gamma y^2 + delta x + epsilon y + zeta,

by linear least squares and solving for the point where its gradient vanishes,

    [[2 alpha, beta], [beta, 2 gamma]] [x, y]^T = -[delta, epsilon]^T,

gives the junction to a fraction of a pixel. The quadric is a saddle only when
``4 alpha gamma - beta^2 < 0``.

Coordinates are those of :mod:`graphpose.geometry`: ``x = u`` is the column and ``y = v`` the
row of the patch, 0-based, pixel centres at integers.

References
----------
L. Lucchese and S. K. Mitra, "Using saddle points for subpixel feature detection in camera
calibration targets", Asia-Pacific Conference on Circuits and Systems, 2002, pp. 191-195.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .._checks import as_float_array
from ..errors import InputError
from ._refine import fit_weighted_grid


@dataclass(frozen=True)
class SaddleFit:
    """Saddle points of a batch of patches, as fitted by :func:`fit_saddles`.

    Attributes
    ----------
    points : (2, m) ndarray of float64
        Stationary point (u, v) of each patch's fitted quadric in patch pixel coordinates;
        NaN where the quadric is degenerate (no unique stationary point).
    valid : (m,) ndarray of bool
        True where the quadric is a saddle (``4 alpha gamma - beta^2 < 0``) and its
        stationary point lies inside the patch (``0 <= u <= w - 1``, ``0 <= v <= h - 1``).
    residual : (m,) ndarray of float64
        RMS of the (weighted) fit residual, in the patches' grey units.
    coeffs : (6, m) ndarray of float64
        ``alpha, beta, gamma, delta, epsilon, zeta`` of each fit, in patch coordinates.
    """

    points: np.ndarray
    valid: np.ndarray
    residual: np.ndarray
    coeffs: np.ndarray


def fit_saddles(patches, weights=None) -> SaddleFit:
    """Fit the saddle quadric to many patches of one size in one solve.

    Parameters
    ----------
    patches : (m, h, w) array_like
        Smoothed grey patches, ``h, w >= 3``.
    weights : (m, h, w) or (h, w) array_like, optional
        Non-negative least-squares weights per pixel. Without them every pixel counts the
        same and the fit is one multiplication by the pseudo-inverse of the shared design
        matrix; with them each patch's 6 x 6 normal equations are solved (still batched).

    Returns
    -------
    SaddleFit
        Points (2, m) in patch pixel coordinates, validity mask, fit RMS and coefficients;
        a patch that is not a saddle or whose saddle is outside it is marked invalid,
        never dropped.

    Raises
    ------
    InputError
        If ``patches`` is not 3-D with patches of at least 3 x 3 pixels, or ``weights`` does
        not match it.
    """
    P = as_float_array(patches, "patches")
    if P.ndim != 3 or P.shape[1] < 3 or P.shape[2] < 3:
        raise InputError(f"patches must have shape (m, h, w) with h, w >= 3, got {P.shape}")
    if weights is not None:
        weights = as_float_array(weights, "weights")
        if weights.shape not in (P.shape, P.shape[1:]):
            raise InputError(f"weights must have shape {P.shape} or {P.shape[1:]}, got {weights.shape}")
        weights = np.broadcast_to(weights, P.shape)
    points, saddle, inside, coeffs, residual = fit_quadrics(P, weights)
    return SaddleFit(points, saddle & inside, residual, coeffs)


def fit_quadrics(P: np.ndarray, weights):
    """Unchecked core of :func:`fit_saddles` for trusted callers.

    Returns points (2, m), saddle mask (m,), inside mask (m,), coefficients (6, m) in
    patch coordinates and the (weighted) RMS residual (m,).
    """
    m, h, w = P.shape
    y = P.reshape(m, h * w)
    if weights is None:
        coeffs = _pinv(h, w) @ y.T
        res = y - (_design(h, w) @ coeffs).T
        rms = np.sqrt(np.mean(res * res, axis=1))
    else:
        coeffs, rms = _weighted(h, w, weights.reshape(m, h * w), y)
    points, saddle, inside = _stationary(coeffs, h, w, _curvature_floor(y, h, w))
    return points, saddle, inside, _uncentre(coeffs, (w - 1) / 2.0, (h - 1) / 2.0), rms


def _weighted(h: int, w: int, W: np.ndarray, y: np.ndarray):
    """Per-patch weighted least squares through the 6 x 6 normal equations, in the compiled
    :func:`graphpose.detect._refine.fit_weighted_grid` (the refinement's own fit).

    Returns the coefficients (6, m), centred coordinates, and the weighted RMS residual
    (m,), from ``sum W r^2 = sum W y^2 - c . A^T W y`` at the solution.
    """
    m = W.shape[0]
    coeffs, rms = np.empty((6, m)), np.empty(m)
    fit_weighted_grid(np.ascontiguousarray(y.reshape(m, h, w), dtype=float),
                      np.ascontiguousarray(W.reshape(m, h, w), dtype=float), coeffs, rms)
    return coeffs, rms


def _curvature_floor(y: np.ndarray, h: int, w: int) -> np.ndarray:
    """Smallest ``-det`` that counts as a saddle rather than rounding noise, per patch.

    A flat patch fits coefficients of order 1e-16 whose sign means nothing; curvature
    a millionth of the patch's grey range over its half-size squared is far below any
    junction's.
    """
    span = np.ptp(y, axis=1)
    curvature = 1e-6 * span / (max(h, w) / 2.0) ** 2
    return np.where(span > 1e-12, curvature * curvature, np.inf)


def _stationary(coeffs: np.ndarray, h: int, w: int, floor: np.ndarray):
    """Stationary points (2, m) in patch coordinates, saddle mask (m,), inside mask (m,).

    The coefficients are in coordinates centred on the patch.
    """
    a, b, g, d, e = coeffs[:5]
    det = 4.0 * a * g - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (-2.0 * g * d + b * e) / det
        y = (b * d - 2.0 * a * e) / det
    cx, cy = (w - 1) / 2.0, (h - 1) / 2.0
    u, v = x + cx, y + cy
    finite = np.isfinite(u) & np.isfinite(v) & (det != 0)
    u = np.where(finite, u, np.nan)
    v = np.where(finite, v, np.nan)
    with np.errstate(invalid="ignore"):
        inside = (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1)
    return np.vstack([u, v]), finite & (-det > floor), inside


def _uncentre(c: np.ndarray, cx: float, cy: float) -> np.ndarray:
    """Coefficients of the same quadric in coordinates shifted by (cx, cy)."""
    a, b, g, d, e, z = c
    d2 = d - 2 * a * cx - b * cy
    e2 = e - b * cx - 2 * g * cy
    z2 = z + a * cx * cx + b * cx * cy + g * cy * cy - d * cx - e * cy
    return np.vstack([a, b, g, d2, e2, z2])


@lru_cache(maxsize=32)
def _design(h: int, w: int) -> np.ndarray:
    """Design matrix (h*w, 6) in coordinates centred on the patch (better conditioned)."""
    v, u = np.mgrid[0:h, 0:w].astype(float)
    x = (u - (w - 1) / 2.0).ravel()
    y = (v - (h - 1) / 2.0).ravel()
    A = np.column_stack([x * x, x * y, y * y, x, y, np.ones_like(x)])
    A.setflags(write=False)
    return A


@lru_cache(maxsize=32)
def _pinv(h: int, w: int) -> np.ndarray:
    P = np.linalg.pinv(_design(h, w))
    P.setflags(write=False)
    return P

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

from .._checks import as_float_array, check_image
from ..errors import InputError, SaddleError


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


def saddle_point(I) -> np.ndarray:
    """Sub-pixel saddle point of one image patch.

    Parameters
    ----------
    I : (h, w) array_like
        A small grey patch, already smoothed (e.g. with a Gaussian of 1-2 px), holding one
        cross-junction; ``h, w >= 3``.

    Returns
    -------
    pt : (2, 1) ndarray of float64
        The saddle point (u, v) in patch pixel coordinates (u = column, 0-based).

    Raises
    ------
    InputError
        If the patch is not 2-D, is smaller than 3 x 3, or holds NaN or infinite values.
    SaddleError
        If the fitted quadric is not a saddle (``4 alpha gamma - beta^2 >= 0``) or its
        saddle point lies outside the patch.

    Examples
    --------
    >>> v, u = np.mgrid[0:9, 0:9]
    >>> saddle_point((u - 4.3) * (v - 3.6)).ravel().round(6)
    array([4.3, 3.6])
    """
    P = as_float_array(check_image(I, "I", min_side=3, colour=False), "I")
    points, saddle, inside, coeffs, _ = fit_quadrics(P[None], None)
    if not saddle[0]:
        a, b, g = coeffs[:3, 0]
        raise SaddleError(
            "the fitted quadric is not a saddle: 4 alpha gamma - beta^2 = "
            f"{4 * a * g - b * b:.3g} is not clearly negative"
        )
    if not inside[0]:
        u, v = points[:, 0]
        raise SaddleError(
            f"the saddle point ({u:.2f}, {v:.2f}) lies outside the {P.shape[1]} x {P.shape[0]} patch"
        )
    return points[:, :1].copy()


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


def fit_quadrics_at(P: np.ndarray, weights: np.ndarray, x: np.ndarray, y: np.ndarray):
    """Weighted saddle fit with every pixel at its own position, for trusted callers.

    :func:`fit_quadrics` places the pixels on their grid; here pixel ``k`` of patch ``i``
    sits at ``(x[i, k], y[i, k])``, for instance where a lens model undistorts it, so that
    the board's edges are straight lines and the hyperbolic paraboloid of Lucchese & Mitra
    fits them. The grey values are the patch's own: nothing is resampled.

    Parameters
    ----------
    P, weights : (m, h, w) ndarray
        Patches and non-negative weights.
    x, y : (m, h, w) ndarray
        Each pixel's position, in coordinates centred near the junction (pixels).

    Returns
    -------
    points : (2, m) ndarray
        Stationary points in the same coordinates; NaN where there is none.
    saddle : (m,) ndarray of bool
        The quadric is a saddle (beyond rounding noise).
    rms : (m,) ndarray
        Weighted RMS residual.
    """
    m = P.shape[0]
    X, Y = x.reshape(m, -1), y.reshape(m, -1)
    size = max(float(np.nanmax(np.abs(X))), 1.0)
    return fit_quadrics_moments(quadric_monomials(X, Y), P.reshape(m, -1), weights.reshape(m, -1), size)


#: Exponents (a, b) of the monomials x^a y^b of degree up to four: the quadric's design columns
#: x^2, x y, y^2, x, y, 1 first, then their products' other monomials.
_POWERS = ((2, 0), (1, 1), (0, 2), (1, 0), (0, 1), (0, 0),
           (4, 0), (3, 1), (2, 2), (1, 3), (0, 4), (3, 0), (2, 1), (1, 2), (0, 3))
#: Which monomial each entry of the 6 x 6 normal matrix sums.
_NORMAL = np.array([[_POWERS.index((a + c, b + d)) for (c, d) in _POWERS[:6]] for (a, b) in _POWERS[:6]])


def quadric_monomials(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The monomials (m, 15, n) of degree up to four at positions ``x, y`` (m, n), whose
    weighted sums are the quadric fit's normal equations (:func:`fit_quadrics_moments`);
    the first six are its design columns ``x^2, x y, y^2, x, y, 1``."""
    # Filled monomial by monomial, each one contiguous block (then viewed as (m, 15, n)).
    M = np.empty((15,) + x.shape)
    x2, y2 = np.multiply(x, x, out=M[0]), np.multiply(y, y, out=M[2])
    xy = np.multiply(x, y, out=M[1])
    M[3], M[4], M[5] = x, y, 1.0
    np.multiply(x2, x2, out=M[6])
    np.multiply(x2, xy, out=M[7])
    np.multiply(x2, y2, out=M[8])
    np.multiply(xy, y2, out=M[9])
    np.multiply(y2, y2, out=M[10])
    np.multiply(x2, x, out=M[11])
    np.multiply(x2, y, out=M[12])
    np.multiply(x, y2, out=M[13])
    np.multiply(y2, y, out=M[14])
    return M.transpose(1, 0, 2)


def fit_quadrics_moments(M: np.ndarray, v: np.ndarray, W: np.ndarray, size: float):
    """Weighted saddle fits from the pixels' monomials, for trusted callers that reuse them.

    The normal matrix of the fit sums 15 distinct monomials, and its right-hand side the
    grey values against the first six, so one batched product with the weights gives both.

    Parameters
    ----------
    M : (m, 15, n) ndarray
        :func:`quadric_monomials` of each pixel's position (pixels, about the junction).
    v, W : (m, n) ndarray
        Grey values and non-negative weights.
    size : float
        The positions' extent, pixels (for the floor below which a curvature is rounding
        noise, as :func:`fit_quadrics`).

    Returns
    -------
    points, saddle, rms
        As :func:`fit_quadrics_at`, in the monomials' coordinates.
    """
    Wv = W * v
    moments = (M @ W[:, :, None])[:, :, 0]
    rhs = (M[:, :6] @ Wv[:, :, None])[:, :, 0]
    N = moments[:, _NORMAL]
    N += np.eye(6) * (1e-12 * np.trace(N, axis1=1, axis2=2)[:, None, None] + 1e-300)
    c = np.linalg.solve(N, rhs[:, :, None])[:, :, 0]
    rss = np.maximum(np.sum(Wv * v, axis=1) - np.sum(c * rhs, axis=1), 0.0)
    rms = np.sqrt(rss / np.maximum(moments[:, 5], 1e-300))
    a, b, g, d, e = c[:, :5].T
    det = 4.0 * a * g - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        px = (-2.0 * g * d + b * e) / det
        py = (b * d - 2.0 * a * e) / det
    span = np.ptp(v, axis=1)
    size = max(float(size), 1.0)
    floor = np.where(span > 1e-12, (1e-6 * span / size ** 2) ** 2, np.inf)
    finite = np.isfinite(px) & np.isfinite(py) & (det != 0)
    points = np.vstack([np.where(finite, px, np.nan), np.where(finite, py, np.nan)])
    return points, finite & (-det > floor), rms


def _weighted(h: int, w: int, W: np.ndarray, y: np.ndarray):
    """Per-patch weighted least squares through batched 6 x 6 normal equations.

    Returns the coefficients (6, m), centred coordinates, and the weighted RMS residual
    (m,), from ``sum W r^2 = sum W y^2 - c . A^T W y`` at the solution.
    """
    upper = W @ _outer(h, w)
    N = np.empty((W.shape[0], 6, 6))
    N[:, _UPPER[0], _UPPER[1]] = upper
    N[:, _UPPER[1], _UPPER[0]] = upper
    Wy = W * y
    rhs = Wy @ _design(h, w)
    # A tiny ridge keeps all-zero-weight patches solvable; they come out invalid anyway.
    N += np.eye(6) * (1e-12 * np.trace(N, axis1=1, axis2=2)[:, None, None] + 1e-300)
    coeffs = np.linalg.solve(N, rhs[:, :, None])[:, :, 0]
    rss = np.maximum(np.sum(Wy * y, axis=1) - np.sum(coeffs * rhs, axis=1), 0.0)
    return coeffs.T, np.sqrt(rss / np.maximum(W.sum(axis=1), 1e-300))


#: Upper triangle of a 6 x 6 matrix: the normal matrix is symmetric, so 21 sums suffice.
_UPPER = np.triu_indices(6)


@lru_cache(maxsize=32)
def _outer(h: int, w: int) -> np.ndarray:
    """Row-wise products of design columns, upper triangle only, (h*w, 21)."""
    A = _design(h, w)
    O = np.ascontiguousarray(A[:, _UPPER[0]] * A[:, _UPPER[1]])
    O.setflags(write=False)
    return O


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

"""Input checks at graphpose's public edge, one coercing checker per concept.

Each checker takes what a user may pass (lists, integer arrays, arrays of another float
type), converts it, checks shape then meaning, and returns the float64 array, or raises
:class:`~graphpose.errors.InputError` with a message that names the parameter, what was
expected and what came. Public functions call these once, at the edge; the numerical code
behind them trusts its callers.

Concepts: arrays of numbers (:func:`as_float_array`), point sets (:func:`as_points`),
images (:func:`check_image`), polygons (:func:`as_polygon`) and a board's bounding
polygon in an image (:func:`check_bounds`), intrinsics (:func:`check_K`), poses
(:func:`check_transform`), correspondences (:func:`check_correspondences`; with a camera model and unseen points,
:func:`graphpose.observations.check_observations`), points in front of a camera
(:func:`check_in_front`), and scalar settings and ranges (:func:`check_number`, :func:`check_range`, :func:`check_count`, :func:`check_size`),
and covariance matrices (:func:`check_covariance`).
This module imports nothing of graphpose but its errors, so every layer may use it; the
checks that need a board or a camera model live beside them (:func:`graphpose.board.check_board`,
:func:`graphpose.observations.check_observations`). Other modules raise InputError themselves only for what belongs to them alone (a file's
syntax, a parameter no other function has).
"""

from __future__ import annotations

import numpy as np

from .errors import InputError

#: Orthonormality tolerance used when validating a rotation block.
ROTATION_TOL = 1e-6
#: Smallest camera-frame depth (metres) a point may have to count as in front of the camera.
MIN_DEPTH = 1e-9
#: Fewest points any pose is solved from: four points of the board's plane, no three on a line,
#: fix its homography, the pose's linear start (the public solvers refuse fewer; the pipeline
#: and the detector ask for :data:`graphpose.observations.MIN_JUNCTIONS`, which leaves a margin).
MIN_POSE_POINTS = 4


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


def as_polygon(P, name: str = "polygon", vertices=None) -> np.ndarray:
    """Validate a polygon in the image, (2, m) vertices (u, v) in pixels, as float64.

    Parameters
    ----------
    P : (2, m) array_like
        Vertices, row 0 = u, row 1 = v.
    name : str
        The parameter's name in messages.
    vertices : int, optional
        The number of vertices required (4 for a board's bounds); any m >= 3 when None.

    Raises
    ------
    InputError
        If it is not a finite array of real numbers of shape (2, m), m >= 3 (or
        ``(2, vertices)``).
    """
    P = as_float_array(P, name)
    if vertices is not None and P.shape != (2, vertices):
        raise InputError(f"{name} must have shape (2, {vertices}) (u and v of {vertices} vertices), got {P.shape}")
    if P.ndim != 2 or P.shape[0] != 2 or P.shape[1] < 3:
        raise InputError(f"{name} must have shape (2, m) with m >= 3 vertices (u and v), got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise InputError(f"{name} contains NaN or infinite values")
    return P


def check_image(image, name: str = "image", *, min_side: int = 1, colour: bool = True) -> np.ndarray:
    """Validate an image and return it as an array of its own dtype (not converted, not copied).

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) array_like
        Grey, or colour with an optional alpha channel; bool, integer or float.
    name : str
        The parameter's name in messages ("image", "I", "frame 3").
    min_side : int
        Smallest height and width accepted, pixels.
    colour : bool
        Whether (H, W, 3|4) colour is accepted; only (H, W) when False.

    Returns
    -------
    image : ndarray
        ``np.asarray(image)``.

    Raises
    ------
    InputError
        If it is empty, has another shape, is smaller than ``min_side`` either way, is not of
        a numeric dtype, or holds NaN or infinite values.
    """
    try:
        I = np.asarray(image)
    except (TypeError, ValueError):  # ragged nests
        raise InputError(f"{name} must be a rectangular array of real numbers, got {_describe(image)}") from None
    if I.dtype.kind not in "biuf":
        raise InputError(f"{name} has unsupported dtype {I.dtype} (bool, integer or float pixels)")
    if I.size == 0:
        raise InputError(f"{name} is empty, shape {I.shape}")
    grey = I.ndim == 2
    if not (grey or (colour and I.ndim == 3 and I.shape[2] in (3, 4))):
        form = "2-D grey or (H, W, 3|4) colour" if colour else "2-D"
        raise InputError(f"{name} must be {form}, got shape {I.shape}")
    if min(I.shape[:2]) < min_side:
        raise InputError(f"{name} must be at least {min_side} x {min_side} pixels, got shape {I.shape}")
    if I.dtype.kind == "f" and not np.all(np.isfinite(I)):
        raise InputError(f"{name} contains NaN or infinite values")
    return I


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
    if np.count_nonzero(mask) < MIN_POSE_POINTS:
        raise InputError(f"pose needs at least {MIN_POSE_POINTS} trusted points, got {np.count_nonzero(mask)}")
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


def check_bounds(bounds, shape, name: str = "bounds") -> np.ndarray:
    """Validate a board's bounding polygon in an image and return it as (2, 4) float64.

    Parameters
    ----------
    bounds : (2, 4) array_like
        Vertices (u, v), pixels, clockwise in the image (v down) from the vertex nearest
        the board's upper-left junction.
    shape : tuple of int or None
        The image's ``(height, width)``; None leaves out the test against the image.
    name : str
        The parameter's name in messages (``"bounds"``, ``"--bounds"``, ``name``).

    Raises
    ------
    InputError
        If it is not a finite 2 x 4 array (:func:`as_polygon`), lies more than 5 % of the
        image diagonal off the image, is degenerate, not convex, or runs counter-clockwise.
    """
    poly = as_polygon(bounds, name, 4)
    if shape is not None:
        height, width = shape
        slack = 0.05 * np.hypot(height, width)
        outside = (poly[0] < -slack) | (poly[0] > width - 1 + slack) | \
            (poly[1] < -slack) | (poly[1] > height - 1 + slack)
        if np.any(outside):
            raise InputError(
                f"{name} vertices {np.flatnonzero(outside).tolist()} lie off the {width} x {height} image "
                f"(more than {slack:.0f} px outside): {poly.round(1).tolist()}"
            )
    edges = np.roll(poly, -1, axis=1) - poly
    turns = edges[0] * np.roll(edges[1], -1) - edges[1] * np.roll(edges[0], -1)
    area = 0.5 * np.sum(poly[0] * np.roll(poly[1], -1) - np.roll(poly[0], -1) * poly[1])
    if _edges_cross(poly):
        raise InputError(f"{name} is a self-intersecting polygon (two of its edges cross): list its corners in "
                         f"order around the board, clockwise, starting at the corner nearest junction 0; got "
                         f"{poly.round(1).tolist()}")
    if abs(area) < 100.0:
        raise InputError(f"{name} is degenerate (area {abs(area):.1f} px^2): {poly.round(1).tolist()}")
    if area < 0:
        raise InputError(f"{name} must run clockwise (in the image, v down), starting at the corner nearest "
                         f"junction 0; these corners run counter-clockwise: {poly.round(1).tolist()}")
    if np.any(turns <= 0):
        raise InputError(f"{name} must be a convex quadrilateral, got {poly.round(1).tolist()}")
    return poly


def _edges_cross(poly: np.ndarray) -> bool:
    """Whether a quadrilateral's opposite edges (0-1 with 2-3, 1-2 with 3-0) properly cross."""
    def side(a, b, c):
        return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))

    p = poly.T
    for i, j in ((0, 2), (1, 3)):
        a, b, c, d = p[i], p[(i + 1) % 4], p[j], p[(j + 1) % 4]
        if side(a, b, c) * side(a, b, d) < 0 and side(c, d, a) * side(c, d, b) < 0:
            return True
    return False


def check_number(name: str, value, minimum=None, *, strict: bool = False, maximum=None) -> float:
    """A finite real number (not a bool or a string), within bounds, returned as float.

    Parameters
    ----------
    name : str
        The setting's name, for the message.
    value : object
        What came.
    minimum : float, optional
        Lower bound; ``value >= minimum`` (``>`` when ``strict``).
    maximum : float, optional
        Upper bound, inclusive.

    Raises
    ------
    InputError
        If ``value`` is not a finite real number or lies outside the bounds.
    """
    real = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
    if real and np.isfinite(value) \
            and (minimum is None or (value > minimum if strict else value >= minimum)) \
            and (maximum is None or value <= maximum):
        return float(value)
    bound = [] if minimum is None else [f"{'>' if strict else '>='} {minimum:g}"]
    bound += [] if maximum is None else [f"<= {maximum:g}"]
    raise InputError(f"{name} must be a finite number{' ' + ' and '.join(bound) if bound else ''}, got {value!r}")


def check_range(name: str, value, what: str, minimum=None, *, strict: bool = False) -> tuple:
    """An ordered pair ``low <= high`` of finite numbers, both ``>= minimum`` (``>`` if strict).

    Parameters
    ----------
    name : str
        The setting's name, for the message.
    value : sequence of two numbers
        What came.
    what : str
        What the pair means, for the message, e.g. ``"(near, far) metres"``.
    minimum : float, optional
        Lower bound of ``low``.

    Returns
    -------
    (low, high) : tuple of float

    Raises
    ------
    InputError
        If ``value`` is not two finite numbers with ``low <= high`` and ``low`` in bounds.
    """
    try:
        if isinstance(value, (str, bytes)):
            raise TypeError
        low, high = (float(v) for v in value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a pair {what}, got {value!r}") from None
    below = minimum is not None and (low <= minimum if strict else low < minimum)
    if not (np.isfinite(low) and np.isfinite(high) and low <= high) or below:
        bound = "" if minimum is None else f", low {'>' if strict else '>='} {minimum:g}"
        raise InputError(f"{name} must be a pair {what} with low <= high{bound}, got {value!r}")
    return low, high


def check_count(name: str, value, minimum: int) -> int:
    """An integer (not a bool) of at least ``minimum``, returned as int.

    Raises
    ------
    InputError
        If ``value`` is not an integer or is below ``minimum``.
    """
    if not isinstance(value, (int, np.integer)) or isinstance(value, (bool, np.bool_)) or value < minimum:
        raise InputError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def check_size(size) -> tuple:
    """An image size ``(width, height)`` of positive integers, pixels.

    Raises
    ------
    InputError
        If ``size`` is not a pair of positive integers.
    """
    try:
        width, height = size
    except (TypeError, ValueError):
        raise InputError(f"size must be (width, height), got {size!r}") from None
    for name, value in (("width", width), ("height", height)):
        if not isinstance(value, (int, np.integer)) or isinstance(value, (bool, np.bool_)) or value < 1:
            raise InputError(f"size {name} must be a positive integer, got {value!r}")
    return int(width), int(height)


def check_covariance(cov, n: int, name: str = "covariance") -> np.ndarray:
    """A covariance matrix: (n, n), finite, symmetric and positive semi-definite, as float64.

    Symmetry and definiteness are judged on the correlation matrix ``D^-1/2 cov D^-1/2``
    (``D`` its diagonal; a zero variance counts as 1 there), so parameters of very different
    scales (a focal length in pixels, a distortion coefficient) are judged alike: asymmetry
    and negative eigenvalues up to 1e-9 are rounding and are accepted.

    Returns
    -------
    cov : (n, n) ndarray
        ``(cov + cov.T) / 2``, exactly symmetric.

    Raises
    ------
    InputError
        If it is not a finite (n, n) array of real numbers, not symmetric, or has a negative
        variance or eigenvalue.
    """
    cov = as_float_array(cov, name)
    if cov.shape != (n, n):
        raise InputError(f"{name} must have shape ({n}, {n}), got {cov.shape}")
    if not np.all(np.isfinite(cov)):
        raise InputError(f"{name} contains NaN or infinite values")
    d = np.diag(cov)
    if np.any(d < 0):
        raise InputError(f"{name} has negative variances at {np.flatnonzero(d < 0).tolist()}")
    s = np.where(d > 0, np.sqrt(np.where(d > 0, d, 1.0)), 1.0)
    corr = cov / np.outer(s, s)
    if np.max(np.abs(corr - corr.T), initial=0.0) > 1e-9:
        raise InputError(f"{name} is not symmetric")
    sym = 0.5 * (cov + cov.T)
    low = np.linalg.eigvalsh(0.5 * (corr + corr.T))[0] if n else 0.0
    if low < -1e-9:
        raise InputError(f"{name} is not positive semi-definite (its correlation matrix has "
                         f"eigenvalue {low:.3g})")
    return sym


def check_timestamps(t, name: str = "timestamps") -> np.ndarray:
    """Frame times, seconds: a 1-D array, finite and strictly increasing, as float64.

    Raises
    ------
    InputError
        If ``t`` is not a 1-D array of real numbers, holds NaN, or does not increase.
    """
    t = as_float_array(t, name)
    if t.ndim != 1:
        raise InputError(f"{name} must be 1-D (one time per frame), got shape {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise InputError(f"{name}: timestamps must be finite and strictly increasing")
    return t

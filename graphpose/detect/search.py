"""Junction candidates anywhere in the image, and the ring test that judges them.

The whole image is searched at one scale: on 2^level x 2^level block means, by default at
half resolution (``level=1``), where a Gaussian of 1 pixel (2 pixels of the full image)
smooths it, and the saddle response ``Ixy^2 - Ixx Iyy`` (the negative Hessian
determinant) is high at cross-junctions, about four times lower at L-corners and near
zero on edges. A junction looks the same at every scale up to blur, so this one scale
serves squares from about 12 pixels (6 at half resolution, where the Gaussian spans a
sixth of a square) to a third of the image; ``level=0`` searches the full image for
smaller squares (from about 7 pixels), and large images start coarser still
(:func:`search_levels`: a 12 MP image at an eighth), so that the search costs about the
same at any resolution. The lattice and the ring test, not this response, decide what is
a junction.

Its local maxima above a fraction of a typical strong peak are the candidates. Each comes
with the direction of its bright sectors' bisector, ``theta``: the two lines of a
cross-junction split the plane into two bright and two dark sectors, and whatever the
perspective the bisectors of the bright pair and of the dark pair are perpendicular. One
step along a grid line swaps bright and dark, so neighbours along a line have ``theta``
90 degrees apart and diagonal neighbours the same ``theta``: the parity that
:mod:`graphpose.detect.lattice` checks.

The lattice and the identification read the image through one sampling context,
:class:`SearchImage` (the smoothed search level and the full image, with their bilinear
samples and the ring test), which :class:`Candidates` carries as ``view``; the refinement's
judging scores its own patches with the same ring arithmetic (``_sampling._ring_score``). The loops are compiled
(``_search.pyx``, with ``_sampling.pxd``): one call per batch of points.

Coordinates follow :mod:`graphpose.geometry`: full-image pixels ``(u, v)``, 2 x N arrays.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import InputError
from . import _search

#: Gaussian scale of the saddle response at the search level, pixels of that level (2
#: full-image pixels at half resolution).
RESPONSE_SIGMA = 1.0
#: A candidate's response must exceed this fraction of a typical strong peak (the 16th).
RELATIVE_THRESHOLD = 0.03
#: Under noise, candidates rise this many standard deviations of the response's ``Ixy``
#: noise above it (:func:`noise_floor`): 6 squared is above the largest peak pure noise made.
NOISE_THRESHOLD = 6.0
#: The first search level's image is at most this many pixels on its shorter side
#: (:func:`search_levels`): 640 x 480 starts at half resolution, 12 MP at an eighth.
SEARCH_SIDE = 400


@dataclass(frozen=True)
class SearchImage:
    """What the search saw of one image, and the sampling the lattice, the identification
    and the refinement read from it: the only context they share.

    Attributes
    ----------
    smooth : (h, w) ndarray of float32
        The image at the search's level, smoothed (:data:`RESPONSE_SIGMA`): block means of
        2^level x 2^level pixels, C-contiguous.
    level : int
        The search level (0 the full image, 1 half resolution, ...; :func:`search_levels`).
    image : (H, W) ndarray
        The full-resolution grey image itself (not copied), any real dtype.

    Every method takes full-image pixel coordinates ``(u, v)``, 2 x N, and returns float64.
    """

    smooth: np.ndarray
    level: int
    image: np.ndarray

    @property
    def shape(self) -> tuple:
        """The full image's ``(height, width)``."""
        return tuple(self.image.shape[:2])

    def to_level(self, points) -> np.ndarray:
        """Full-image pixel coordinates (2, N) as coordinates (x, y) of :attr:`smooth`."""
        s = 2 ** self.level
        return (np.asarray(points, dtype=float) - 0.5 * (s - 1)) / s

    def sample(self, points) -> np.ndarray:
        """Bilinear samples (N,) of :attr:`smooth` at full-image points (2, N), edges
        repeated (as ``scipy.ndimage.map_coordinates(order=1, mode="nearest")``, rounded to
        float32 as it gives them)."""
        x, y = _xy(self.to_level(points))
        out = np.empty(x.size)
        _search.bilinear(self.smooth, x, y, out)
        return out.astype(np.float32).astype(float)

    def sample_fine(self, points, reach: float = 1.0) -> np.ndarray:
        """Mean (N,) of the full-resolution image over a 3 x 3 grid of bilinear samples,
        ``reach`` pixels apart, around each full-image point (2, N): grey levels at a scale of
        a couple of pixels, for evidence on squares too small for :attr:`smooth`."""
        x, y = _xy(points)
        out = np.empty(x.size)
        _search.bilinear_mean3x3(_kernel_grey(self.image), x, y, float(reach), out)
        return out

    def ring_test(self, points, radius) -> tuple:
        """:func:`ring_test` on :attr:`smooth` at full-image points (2, m), ``radius``
        full-image pixels (a float or (m,))."""
        x, y = _xy(self.to_level(points))
        rad = np.ascontiguousarray(np.broadcast_to(np.asarray(radius, dtype=float), x.shape)) / 2 ** self.level
        score, theta, contrast = np.empty(x.size), np.empty(x.size), np.empty(x.size)
        _search.ring_image(self.smooth, x, y, rad, score, theta, contrast)
        return score, theta, contrast


@dataclass(frozen=True)
class Candidates:
    """Junction candidates of one image.

    Attributes
    ----------
    points : (2, N) ndarray of float64
        Positions (u, v), full-image pixels, to about half a pixel.
    theta : (N,) ndarray of float64
        Direction of the bisector of the bright sectors, radians in (-pi/2, pi/2].
    strength : (N,) ndarray of float64
        Saddle response at the peak (arbitrary units), for ordering seeds.
    seed : (N,) ndarray of bool
        Candidates that may seed a lattice (those inside the search region).
    view : SearchImage
        The images the candidates were found in, for the lattice and the identification to
        sample.
    noise_limited : bool
        The noise floor (:func:`noise_floor`), not the relative threshold, bounded the
        candidates: without it they would have been others.
    """

    points: np.ndarray
    theta: np.ndarray
    strength: np.ndarray
    seed: np.ndarray
    view: SearchImage
    noise_limited: bool = False


def find_candidates(image: np.ndarray, region=None, *, level: int = 1, noise: float | None = None) -> Candidates:
    """Junction candidates anywhere in a grey image.

    Parameters
    ----------
    image : (H, W) ndarray
        Grey image, any real dtype (uint8 is read as it is: every step is invariant to a
        positive grey scale).
    region : (2, K) ndarray, optional
        A polygon (u, v) in full-image pixels; only candidates inside it may seed a lattice
        (all of them may join one).
    level : int
        Search on 2^level x 2^level block means: 1 (default) at half resolution, 0 on the
        full image (small squares), 2 or more on large images (:func:`search_levels`).
    noise : float, optional
        The image's pixel noise, grey units (:func:`graphpose.detect.noise.estimate_noise`):
        candidates must then also rise :data:`NOISE_THRESHOLD` standard deviations of
        the response's noise above it (:func:`noise_floor`), so that peaks noise alone
        makes are none. Without it only the relative threshold applies (the fast path).

    Returns
    -------
    Candidates
        Possibly empty.
    """
    if int(level) != level or level < 0:
        raise InputError(f"level must be a whole number >= 0, got {level!r}")
    a = downsample(image, int(level))
    S = smooth(a)
    r, ys, xs = _response_peaks(S)
    ys, xs, value, limited = _threshold(r, ys, xs, 0.0 if noise is None else noise_floor(noise, level))
    # The bright bisector is the principal direction of positive curvature (the curvatures
    # at the peaks, as the response's kernel computes them).
    y, x = ys + 1, xs + 1
    Ixx = S[y, x + 1] - 2 * S[y, x] + S[y, x - 1]
    Iyy = S[y + 1, x] - 2 * S[y, x] + S[y - 1, x]
    Ixy = 0.25 * (S[y + 1, x + 1] - S[y + 1, x - 1] - S[y - 1, x + 1] + S[y - 1, x - 1])
    theta = 0.5 * np.arctan2(2 * Ixy, Ixx - Iyy)
    dx, dy = _subpixel(r, ys, xs)
    # Interior pixel (y, x) of r is pixel (y + 1, x + 1) of the level, whose centre is
    # full-image s (x + 1) + (s - 1) / 2 for the level's scale s.
    s = 2 ** level
    points = np.vstack([s * (xs + dx + 1) + 0.5 * (s - 1), s * (ys + dy + 1) + 0.5 * (s - 1)])
    seed = np.ones(points.shape[1], dtype=bool)
    if region is not None and points.shape[1]:
        seed = in_polygon(points, region)
    return Candidates(points, theta.astype(float), value.astype(float), seed, SearchImage(S, level, image), limited)


def ring_test(view: SearchImage, points: np.ndarray, radius) -> tuple:
    """Cross-junction ring test of the ChESS kind, on the search's smoothed image.

    Sixteen bilinear samples on a circle: at a cross-junction opposite samples agree (point
    symmetry) and samples a quarter-turn apart disagree; an L-corner breaks the first, an
    edge the second, flat ground both.

    Parameters
    ----------
    view : SearchImage
        Whose smoothed image is read.
    points : (2, m) ndarray
        Centres, full-image pixels.
    radius : float or (m,) ndarray
        Ring radius, full-image pixels: about a third of the local square keeps the ring
        inside the four squares around a junction and outside a thin white margin.

    Returns
    -------
    score : (m,) ndarray
        ``(sum - 2 diff) / (sum + diff)`` of the ChESS sum and diff responses, in
        [-2, 1]; above 0 the ring looks like a cross-junction.
    theta : (m,) ndarray
        Direction of the bright sectors' bisector (the ring's second angular harmonic),
        radians.
    contrast : (m,) ndarray
        Peak-to-peak grey range on the ring, in the image's grey units.
    """
    return view.ring_test(points, radius)


def _xy(points):
    """Contiguous float64 rows x, y of points (2, N), all finite: the kernels clamp a sample
    to the image, which a NaN position would escape (an index from ``floor(NaN)``)."""
    P = np.asarray(points, dtype=float).reshape(2, -1)
    if not np.all(np.isfinite(P)):
        raise InputError("sample positions must be finite (no NaN or inf)")
    return np.ascontiguousarray(P[0]), np.ascontiguousarray(P[1])


def _kernel_grey(image: np.ndarray) -> np.ndarray:
    """``image`` as a dtype the sampling kernels read (uint8, uint16, float32, float64): the
    others (bool, ints) converted to float64."""
    if image.dtype in (np.uint8, np.uint16, np.float32, np.float64):
        return image
    return image.astype(np.float64)


def search_levels(shape, *, side: int = SEARCH_SIDE) -> range:
    """Search levels to try, coarsest first, for an image of ``shape`` (H, W).

    The first is the coarsest level at or above 1 whose image is at most ``side`` pixels
    on its shorter side, so a 640 x 480 image starts at half resolution and a
    4032 x 3024 one at an eighth; each failure falls back to the next finer level, down
    to the full image. The response's cost, and its memory, then scale with ``side``
    squared rather than with the image, for boards whose squares are large enough
    (:data:`RESPONSE_SIGMA`) at the coarse level; smaller ones cost the finer levels too.
    """
    short = min(shape[:2])
    first = 1
    while short / 2 ** first > side:
        first += 1
    return range(first, -1, -1)


def downsample(image: np.ndarray, level: int) -> np.ndarray:
    """Means over 2^level x 2^level blocks as float32 (odd last rows and columns dropped).

    uint8 images are summed exactly in integers (up to level 4: 4^4 x 255 < 2^16), without
    a float copy of the full image: a C-contiguous one in one compiled pass
    (``_search.block_means_u8``), another (a strided view) with NumPy, rows summed first (in
    uint16), then columns of the 2^level times smaller result. Others are summed in float32,
    converted once (adding float64 into float32 would convert at every sum), as NumPy sums.
    """
    if level == 0:
        return image.astype(np.float32, copy=False)
    s = 2**level
    h, w = image.shape[0] // s * s, image.shape[1] // s * s
    exact = image.dtype == np.uint8 and 4**level * 255 < 2**16
    if exact and image.flags.c_contiguous:  # one compiled pass, the same sums and scaling
        out = np.empty((h // s, w // s), dtype=np.float32)
        _search.block_means_u8(image, level, np.float32(4.0 ** -level), out, np.empty(w, dtype=np.uint16))
        return out
    src = image if image.dtype == np.uint8 else image.astype(np.float32, copy=False)
    rows = np.add(src[0:h:s, :w], src[1:h:s, :w], dtype=np.uint16 if exact else np.float32)
    for k in range(2, s):
        rows += src[k:h:s, :w]
    out = np.add(rows[:, 0::s], rows[:, 1::s])
    for k in range(2, s):
        out += rows[:, k::s]
    return out.astype(np.float32) * np.float32(4.0 ** -level)


def smooth(a: np.ndarray) -> np.ndarray:
    """``a`` (h, w) float32 smoothed by the search's Gaussian (:data:`RESPONSE_SIGMA`, cut at
    3 sigma, edges reflected about their outer half-pixel), float32: what
    ``scipy.ndimage.gaussian_filter(a, RESPONSE_SIGMA, truncate=3.0)`` gives, to the bit, in
    one compiled pass (``_search.gaussian_smooth``) at a third of its time."""
    a = np.ascontiguousarray(a, dtype=np.float32)
    taps = _gaussian_taps()
    out = np.empty_like(a)
    _search.gaussian_smooth(a, taps, out, np.empty(2 * a.shape[1] + 2 * (taps.size - 1)))
    return out


@lru_cache(maxsize=1)
def _gaussian_taps() -> np.ndarray:
    """The centre and one side of the search's Gaussian kernel (:data:`RESPONSE_SIGMA`, cut
    at 3 sigma): ``exp(-x^2 / (2 sigma^2))`` at whole pixels, normalised to sum 1."""
    radius = int(3.0 * RESPONSE_SIGMA + 0.5)
    x = np.arange(-radius, radius + 1)
    phi = np.exp(-0.5 / RESPONSE_SIGMA**2 * x**2)
    phi /= phi.sum()
    return phi[radius:].copy()


def median(values) -> float:
    """``np.median`` of a few values (1-D), in one compiled call (``_search.median``) at a
    tenth of its time: the middle value, the mean of the middle two for an even count, NaN if
    any is NaN or there are none."""
    x = np.ascontiguousarray(values, dtype=float).reshape(-1)
    return _search.median(x, np.empty_like(x))


def noise_floor(noise: float, level: int) -> float:
    """The saddle response that white pixel noise of ``noise`` grey levels stays below.

    On the search's level the noise is ``noise / 2^level`` (block means of white noise);
    the Gaussian and the difference operators of :func:`find_candidates` turn it into
    ``Ixy`` noise of standard deviation ``noise / 2^level * _IXY_GAIN``, and the local
    maxima of the response ``Ixy^2 - Ixx Iyy`` over pure noise reach about 30 times its
    variance (measured on 640 x 480 images of white noise: 99.9 % below 24, the largest 30).
    :data:`NOISE_THRESHOLD` squared times the variance is the floor.
    """
    s = noise / 2.0 ** level * _ixy_gain()
    return (NOISE_THRESHOLD * s) ** 2


@lru_cache(maxsize=1)
def _ixy_gain() -> float:
    """Standard deviation of ``Ixy`` per unit of white noise at the search level: the taps
    of the Gaussian (:data:`RESPONSE_SIGMA`, truncated at 3 sigma as the search's) convolved
    with the central difference, squared and summed, in each direction."""
    taps = _gaussian_taps()
    g = np.concatenate([taps[:0:-1], taps])
    return float(np.sum(np.convolve(g, [0.5, 0.0, -0.5]) ** 2))


def _response_peaks(S: np.ndarray):
    """The saddle response ``Ixy^2 - Ixx Iyy`` (float32) of the smoothed image ``S`` at its
    interior pixels, and the rows and columns of its 3 x 3 local maxima (edge pixels
    repeated) above 0, row-major: one compiled pass (``_search.saddle_peaks``)."""
    h, w = S.shape[0] - 2, S.shape[1] - 2
    if h < 1 or w < 1:
        return np.zeros((max(h, 0), max(w, 0)), np.float32), np.zeros(0, np.int64), np.zeros(0, np.int64)
    r, scratch, peak = np.empty((h, w), np.float32), np.empty((3, w), np.float32), np.empty((h, w), np.uint8)
    _search.saddle_peaks(np.ascontiguousarray(S, dtype=np.float32), r, scratch, peak)
    # Flat indices of the 0/1 bytes read as bool, then rows and columns: the same row-major
    # peaks as np.nonzero(peak), which on a 2-D uint8 array costs ten times as long.
    rows, cols = np.divmod(np.flatnonzero(peak.view(bool)), w)
    return r, rows, cols


def _threshold(r: np.ndarray, ys: np.ndarray, xs: np.ndarray, floor: float = 0.0):
    """Of the peaks (ys, xs) of ``r``, those above the relative threshold and above
    ``floor``: rows, columns, values, and whether the floor removed any that the threshold
    kept."""
    value = r[ys, xs]
    if value.size == 0:
        return ys, xs, value, False
    # Relative to a typical strong peak rather than the strongest, which may be clutter.
    typical = np.partition(value, max(value.size - 16, 0))[max(value.size - 16, 0)]
    relative = RELATIVE_THRESHOLD * typical
    keep = value > max(relative, floor)
    limited = bool(floor > relative and np.any(keep != (value > relative)))
    return ys[keep], xs[keep], value[keep], limited


def _subpixel(r: np.ndarray, ys: np.ndarray, xs: np.ndarray):
    """Parabolic sub-pixel offsets (dx, dy) of peaks of ``r``, each within half a pixel."""
    h, w = r.shape
    xm, xp = np.maximum(xs - 1, 0), np.minimum(xs + 1, w - 1)
    ym, yp = np.maximum(ys - 1, 0), np.minimum(ys + 1, h - 1)
    c = r[ys, xs]
    dxx = r[ys, xp] - 2 * c + r[ys, xm]
    dyy = r[yp, xs] - 2 * c + r[ym, xs]
    with np.errstate(divide="ignore", invalid="ignore"):
        dx = np.where(dxx < 0, -0.5 * (r[ys, xp] - r[ys, xm]) / dxx, 0.0)
        dy = np.where(dyy < 0, -0.5 * (r[yp, xs] - r[ym, xs]) / dyy, 0.0)
    return np.clip(dx, -0.5, 0.5), np.clip(dy, -0.5, 0.5)


def in_polygon(points: np.ndarray, polygon) -> np.ndarray:
    """Which points lie inside a polygon or on its boundary.

    Parameters
    ----------
    points : (2, N) array_like
        Positions (u, v), pixels.
    polygon : (2, V) array_like
        The polygon's corners (u, v) in order (either turn), pixels.

    Returns
    -------
    inside : (N,) ndarray of bool
        True inside, on an edge, or within 1e-12 px of a corner (one compiled pass,
        ``_search.in_polygon``: the crossing-number test).
    """
    P = np.ascontiguousarray(points, dtype=float).reshape(2, -1)
    out = np.empty(P.shape[1], dtype=np.uint8)
    _search.in_polygon(P, np.ascontiguousarray(polygon, dtype=float).reshape(2, -1), out)
    return out.view(bool)

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

Coordinates follow :mod:`graphpose.geometry`: full-image pixels ``(u, v)``, 2 x N arrays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..errors import InputError

#: Gaussian scale of the saddle response at the search level, pixels of that level (2
#: full-image pixels at half resolution).
RESPONSE_SIGMA = 1.0
#: A candidate's response must exceed this fraction of a typical strong peak (the 16th).
RELATIVE_THRESHOLD = 0.03
#: The first search level's image is at most this many pixels on its shorter side
#: (:func:`search_levels`): 640 x 480 starts at half resolution, 12 MP at an eighth.
SEARCH_SIDE = 400
#: Ring samples of the ring test.
_RING = np.arange(16) * (np.pi / 8)


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
    smooth : ndarray of float32
        The smoothed image at the search's level that the response came from;
        :func:`sample` and :func:`ring_test` read it at full-image coordinates.
    level : int
        The search level: block means of 2^level x 2^level pixels (0 the full image, 1 half
        resolution, 2 a quarter, ...; :func:`search_levels`).
    shape : tuple of int
        The full image's ``(height, width)``.
    image : (H, W) ndarray
        The full-resolution grey image itself (not copied), for :func:`sample_fine`.
    """

    points: np.ndarray
    theta: np.ndarray
    strength: np.ndarray
    seed: np.ndarray
    smooth: np.ndarray
    level: int
    shape: tuple
    image: np.ndarray

    def to_level(self, points) -> np.ndarray:
        """Full-image pixel coordinates (2, N) as coordinates (x, y) of :attr:`smooth`."""
        s = 2 ** self.level
        return (np.asarray(points, dtype=float) - 0.5 * (s - 1)) / s


def find_candidates(image: np.ndarray, region=None, *, level: int = 1) -> Candidates:
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

    Returns
    -------
    Candidates
        Possibly empty.
    """
    if int(level) != level or level < 0:
        raise InputError(f"level must be a whole number >= 0, got {level!r}")
    a = downsample(image, int(level))
    S = ndimage.gaussian_filter(a, RESPONSE_SIGMA, truncate=3.0)
    Ixx = S[1:-1, 2:] - 2 * S[1:-1, 1:-1] + S[1:-1, :-2]
    Iyy = S[2:, 1:-1] - 2 * S[1:-1, 1:-1] + S[:-2, 1:-1]
    Ixy = 0.25 * (S[2:, 2:] - S[2:, :-2] - S[:-2, 2:] + S[:-2, :-2])
    r = Ixy * Ixy - Ixx * Iyy
    ys, xs, value = _peaks(r)
    # The bright bisector is the principal direction of positive curvature.
    theta = 0.5 * np.arctan2(2 * Ixy[ys, xs], Ixx[ys, xs] - Iyy[ys, xs])
    dx, dy = _subpixel(r, ys, xs)
    # Interior pixel (y, x) of r is pixel (y + 1, x + 1) of the level, whose centre is
    # full-image s (x + 1) + (s - 1) / 2 for the level's scale s.
    s = 2 ** level
    points = np.vstack([s * (xs + dx + 1) + 0.5 * (s - 1), s * (ys + dy + 1) + 0.5 * (s - 1)])
    seed = np.ones(points.shape[1], dtype=bool)
    if region is not None and points.shape[1]:
        from skimage.measure import points_in_poly

        seed = points_in_poly(points.T, np.asarray(region, dtype=float).T)
    return Candidates(points, theta.astype(float), value.astype(float), seed, S, level, tuple(image.shape[:2]), image)


def sample_fine(cands: Candidates, points: np.ndarray, reach: float = 1.0) -> np.ndarray:
    """Mean of the full-resolution image over a 3 x 3 grid of bilinear samples, ``reach``
    pixels apart, around each full-image point (2, N): grey levels at a scale of a couple
    of pixels, for evidence on squares too small for the smoothed search image."""
    P = np.asarray(points, dtype=float)
    off = np.array([-reach, 0.0, reach])
    grid = (P.shape[1], 3, 3)
    u = np.broadcast_to(P[0][:, None, None] + off[None, None, :], grid).ravel()
    v = np.broadcast_to(P[1][:, None, None] + off[None, :, None], grid).ravel()
    values = ndimage.map_coordinates(cands.image, [v, u], order=1, mode="nearest", output=np.float64)
    return values.reshape(P.shape[1], 9).mean(axis=1)


def sample(cands: Candidates, points: np.ndarray) -> np.ndarray:
    """Bilinear samples of the candidates' smoothed image at full-image points (2, N)."""
    x, y = cands.to_level(points)
    return ndimage.map_coordinates(cands.smooth, [y, x], order=1, mode="nearest")


def ring_test(cands: Candidates, points: np.ndarray, radius) -> tuple:
    """Cross-junction ring test of the ChESS kind, on the candidates' smoothed image.

    Sixteen samples on a circle: at a cross-junction opposite samples agree (point
    symmetry) and samples a quarter-turn apart disagree; an L-corner breaks the first, an
    edge the second, flat ground both.

    Parameters
    ----------
    cands : Candidates
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
        Direction of the bright sectors' bisector, radians.
    contrast : (m,) ndarray
        Peak-to-peak grey range on the ring, in the image's grey units.
    """
    X, Y = cands.to_level(points)
    rad = np.broadcast_to(np.asarray(radius, dtype=float), X.shape)[:, None] / 2 ** cands.level
    x = X[:, None] + rad * np.cos(_RING)
    y = Y[:, None] + rad * np.sin(_RING)
    ring = ndimage.map_coordinates(cands.smooth, [y.ravel(), x.ravel()], order=1, mode="nearest").reshape(x.shape)
    ring = ring - ring.mean(axis=1, keepdims=True)
    total = np.abs(ring[:, 0:4] + ring[:, 8:12] - ring[:, 4:8] - ring[:, 12:16]).sum(axis=1)
    diff = np.abs(ring[:, 0:8] - ring[:, 8:16]).sum(axis=1)
    # The second angular harmonic of the ring points along the bright bisector.
    theta = 0.5 * np.arctan2(ring @ np.sin(2 * _RING), ring @ np.cos(2 * _RING))
    score = (total - 2 * diff) / np.maximum(total + diff, 1e-12)
    return score, theta, np.ptp(ring, axis=1)


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

    Rows are summed first (whole rows, contiguous), then columns of the 2^level times
    smaller result. uint8 images are summed exactly in uint16 (up to level 4: 4^4 x 255 <
    2^16), without a float copy of the full image; others in float32, converted once
    (adding float64 into float32 would convert at every sum).
    """
    if level == 0:
        return image.astype(np.float32, copy=False)
    s = 2**level
    h, w = image.shape[0] // s * s, image.shape[1] // s * s
    exact = image.dtype == np.uint8 and 4**level * 255 < 2**16
    src = image if image.dtype == np.uint8 else image.astype(np.float32, copy=False)
    rows = np.add(src[0:h:s, :w], src[1:h:s, :w], dtype=np.uint16 if exact else np.float32)
    for k in range(2, s):
        rows += src[k:h:s, :w]
    out = np.add(rows[:, 0::s], rows[:, 1::s])
    for k in range(2, s):
        out += rows[:, k::s]
    return out.astype(np.float32) * np.float32(4.0 ** -level)


def _peaks(r: np.ndarray):
    """Rows, columns and values of the 3 x 3 local maxima of ``r`` above the threshold."""
    # The 3 x 3 maximum (edge pixels repeated, as ndimage.maximum_filter's "reflect"), by
    # rows then columns: the same values, several times faster than maximum_filter here.
    p = np.pad(r, 1, mode="edge")
    rows = np.maximum(np.maximum(p[:, :-2], p[:, 1:-1]), p[:, 2:])
    local = np.maximum(np.maximum(rows[:-2], rows[1:-1]), rows[2:])
    ys, xs = np.nonzero((r >= local) & (r > 0))
    value = r[ys, xs]
    if value.size == 0:
        return ys, xs, value
    # Relative to a typical strong peak rather than the strongest, which may be clutter.
    typical = np.partition(value, max(value.size - 16, 0))[max(value.size - 16, 0)]
    keep = value > RELATIVE_THRESHOLD * typical
    return ys[keep], xs[keep], value[keep]


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

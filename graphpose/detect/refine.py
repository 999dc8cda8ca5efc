"""Sub-pixel refinement of junction positions.

Every junction is refined by the saddle fit of :mod:`graphpose.detect.saddle` on a Gaussian-
smoothed patch, whose window is a smooth disc of radius a fraction of the local square
(so no other edge enters it), re-centred on the estimate until it stops moving. Around
the true junction of a blurred checkerboard such a window is point-symmetric, which
makes the fitted saddle unbiased whatever the perspective. The fit is weighted by the
squared gradient over the squared distance from the centre, which concentrates it on
the two edges (where the position information is) and brings its noise within a factor
~1.7 of the Cramer-Rao bound; the settings come from measurements on the real and
synthetic images (see the README section on cross-junctions).

Coordinates follow :mod:`graphpose.geometry`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import as_float_array, as_points, check_image, check_number
from ..errors import InputError
from ..image import as_grey
from ._refine import fit_through_lens, lens_centres, lens_disc, refine_grid, ring_crosses, smoothed_patches

#: Default refinement window radius, as a fraction of the local square side.
WINDOW_FRACTION = 0.5

#: Gaussian pre-smoothing of refinement patches, pixels.
SMOOTH_SIGMA = 0.5

#: Under noise the smoothing grows from SMOOTH_SIGMA by this many pixels per unit of noise
#: over contrast beyond NOISE_RATIO0, up to MAX_SMOOTH_SIGMA (:func:`noise_smoothing`).
SMOOTH_SLOPE = 30.0
#: Noise over contrast up to which the smoothing stays SMOOTH_SIGMA (clean images: the
#: course's camera about 0.006, rendered noise of 2 grey levels 0.011).
NOISE_RATIO0 = 0.015
#: Largest smoothing chosen from the noise, pixels, and at most this fraction of a square.
MAX_SMOOTH_SIGMA = 2.0
SMOOTH_SQUARE_FRACTION = 0.1

#: Largest refinement window radius, pixels (beyond it the fit gains little and costs time).
MAX_RADIUS = 12.0


def refine_junctions(I, points, half_width, *, smooth_sigma: float = SMOOTH_SIGMA, camera=None,
                     check: bool = True):
    """Refine predicted junction positions with the re-centred saddle fit.

    The same refinement :func:`graphpose.detect.refine` applies to a found board; the tracker
    uses it on positions predicted from the previous frame (with ``check=False``: it checked
    each frame once, at its edge).

    Parameters
    ----------
    I : (H, W) or (H, W, 3|4) array_like
        The image (converted as by :func:`graphpose.image.as_grey`).
    points : (2, m) array_like
        Predicted positions (u, v), pixels; each should be within about a third of the
        window radius of its junction.
    half_width : float or (m,) array_like
        Window radius per point, pixels, >= 2: about half the local square side, so that no
        other edge of the board enters the window.
    smooth_sigma : float
        Gaussian smoothing of the patches, pixels (>= 0).
    camera : Camera or (3, 3) array_like, optional
        The camera when the image is raw, with lens distortion: the saddle is then fitted
        with each pixel where the lens straightens the edges, in the patch's own pinhole
        frame (as :func:`graphpose.detect.refine` does).
    check : bool
        Whether to check the arguments (pytransform3d's ``check``). With False they are
        trusted: ``I`` a grey (H, W) image as :func:`graphpose.image.as_grey` leaves it (or
        8-bit), ``points`` (2, m) finite, ``half_width`` >= 2, ``smooth_sigma`` >= 0,
        ``camera`` a camera or None; the refinement is the same, without the checks' passes
        over the image.

    Returns
    -------
    points : (2, m) ndarray of float64
        Refined positions; where the fit failed, its last good estimate (or the input).
    trusted : (m,) ndarray of bool
        True where the fit converged to a saddle inside its window, the window lies in the
        image, and a ring around the point looks like a cross-junction (point-symmetric,
        four alternating sectors).
    residual : (m,) ndarray of float64
        RMS residual of the weighted saddle fit, grey units of the image scaled to [0, 1];
        NaN where it failed.

    Raises
    ------
    InputError
        If the image or points are malformed, or ``half_width`` is not >= 2 (scalar or one
        per point).
    """
    if check:
        image, scale = grey_and_scale(I)
        P = as_points(points, 2, "points")
        radius = as_float_array(half_width, "half_width")
        if radius.ndim > 1 or radius.size not in (1, P.shape[1]) or not np.all(np.isfinite(radius)) \
                or np.any(radius < 2):
            raise InputError(f"half_width must be >= 2 px, a scalar or one per point ({P.shape[1]}), "
                             f"got {radius!r}")
        smooth_sigma = check_number("smooth_sigma", smooth_sigma, 0.0)
        if camera is not None:
            from ..camera_models import as_camera

            camera = as_camera(camera)
    else:
        image, P, radius = I, points, np.asarray(half_width, dtype=float)
        scale = 1.0 / 255.0 if image.dtype == np.uint8 else 1.0  # grey_and_scale's
    radius = np.broadcast_to(radius, P.shape[1:]).astype(float)
    lens = camera if camera is not None and np.any(camera.distortion) else None
    points, trusted, residual = refine_points(image, P, radius, smooth_sigma, lens=lens)
    return points, trusted, residual * scale


def noise_smoothing(noise: float, contrast: float, square_px: float) -> float:
    """Gaussian smoothing of the refinement patches for an image's noise, pixels.

    The saddle fit is noisier by the noise over the junctions' contrast; smoothing before
    it (the course notes: images "are typically smoothed with a Gaussian filter prior to
    computing the saddle points") trades that noise for blur, which a point-symmetric
    window does not turn into bias. Up to :data:`NOISE_RATIO0` of noise over contrast it is
    :data:`SMOOTH_SIGMA`, as measured best on clean real and rendered images; beyond, it
    grows by :data:`SMOOTH_SLOPE` pixels per unit of that ratio, up to
    :data:`MAX_SMOOTH_SIGMA` and :data:`SMOOTH_SQUARE_FRACTION` of the square (measured on
    rendered boards at noise 2-16 and blur 0.5-4, squares of 12-50 px: 10-25 % lower
    junction RMS than SMOOTH_SIGMA at noise 12 and over).

    Parameters
    ----------
    noise : float
        Pixel noise, grey units (:func:`graphpose.detect.noise.estimate_noise`).
    contrast : float
        Black-to-white grey range of the board, the same units.
    square_px : float
        Typical square side, pixels.
    """
    ratio = noise / max(contrast, 1e-12)
    grown = SMOOTH_SIGMA + SMOOTH_SLOPE * max(ratio - NOISE_RATIO0, 0.0)
    return float(max(SMOOTH_SIGMA, min(grown, MAX_SMOOTH_SIGMA, SMOOTH_SQUARE_FRACTION * square_px)))


def grey_and_scale(I, min_side: int = 1):
    """Grey pixels and the factor that scales them to [0, 1], as :func:`graphpose.image.as_grey`.

    An 8-bit grey image is used as it is (every step but the residual is invariant to the
    grey scale), which spares converting the whole image for the few pixels read. Both are
    checked by :func:`graphpose._checks.check_image`, at least ``min_side`` pixels each way.
    """
    if isinstance(I, np.ndarray) and I.dtype == np.uint8 and I.ndim == 2:
        return check_image(I, min_side=min_side), 1.0 / 255.0
    return as_grey(I, min_side=min_side), 1.0


#: The ring test's 16 directions (:func:`graphpose.detect._refine.refine_grid`).
_RING_ANGLES = np.arange(16) * (np.pi / 8)
_RING_COS, _RING_SIN = np.cos(_RING_ANGLES), np.sin(_RING_ANGLES)


def refine_points(image: np.ndarray, points: np.ndarray, radius: np.ndarray, sigma: float,
            max_iter: int = 8, tol: float = 0.02, lens=None, undistorted=None):
    """Re-centred, gradient-weighted saddle fits: (points (2, m), trusted (m,), residual (m,)).

    Each junction is refitted until it stops moving; one that drifts off its patch's centre
    gets a new patch. Without a lens the whole refinement is one call of the compiled kernel
    :func:`graphpose.detect._refine.refine_grid`. With a distorting ``lens`` (a camera of
    :mod:`graphpose.camera_models`) the fit places each raw pixel where the lens undistorts it
    (:func:`graphpose.detect._refine.fit_through_lens`): the board's edges, curved in the raw
    image, are straight there, as the saddle model assumes, and no pixel is resampled. Each
    accepted fit is a ray first, so an ``undistorted`` (2, m) array, if given, receives the
    refined points' pixels in the lens's distortion-free image (:meth:`Camera.undistort_pixels`
    of them, without inverting the lens again; NaN where no fit was accepted).
    """
    m = points.shape[1]
    current = np.array(points, dtype=float, order="C")
    radius = np.ascontiguousarray(radius, dtype=float)
    slack = 2
    half = int(np.ceil(radius.max())) + slack
    kernel = _gaussian_kernel(sigma).astype(np.float32)
    if lens is None:
        trusted, residual = np.zeros(m, dtype=np.uint8), np.empty(m)
        refine_grid(image, current, radius, kernel, half, max_iter, tol, float(slack), _RING_COS, _RING_SIN,
                    trusted, residual)
        return current, trusted.view(bool), residual
    offs = np.arange(-half, half + 1, dtype=float)
    base = np.rint(current).astype(np.intp)
    patches, grad2, inside = _patches(image, base, half, kernel, radius)
    # The window (radius at most radius.max(), about an estimate within the slack of
    # the patch's centre) stays inside this disc of the patch's pixels.
    disc = (offs[:, None] ** 2 + offs[None, :] ** 2) <= (radius.max() + slack + 1.0) ** 2
    through = _lens_patches(lens, base, offs, disc, patches, grad2)
    residual = np.full(m, np.nan)
    ideal = np.full((2, m), np.nan) if undistorted is None else undistorted
    ideal[:] = np.nan
    state = np.zeros(m, dtype=int)  # 0 moving, 1 converged, 2 failed
    for _ in range(max_iter):
        act = np.flatnonzero(state == 0)
        if act.size == 0:
            break
        drift = act[np.any(np.abs(current[:, act] - base[:, act]) > slack - 0.5, axis=0)]
        if drift.size:
            base[:, drift] = np.rint(current[:, drift])
            fresh = _patches(image, base[:, drift], half, kernel, radius[drift])
            patches[drift], grad2[drift], inside[drift] = fresh
            through.replace(drift, _lens_patches(lens, base[:, drift], offs, disc, patches[drift], grad2[drift]))
        new, flat, fitted, residual[act] = _fit_through(lens, through, act, half, current[:, act] - base[:, act],
                                                        radius[act])
        step = np.hypot(*(new - current[:, act]))
        ok = fitted & np.isfinite(step) & (step < radius[act])
        current[:, act[ok]] = new[:, ok]
        ideal[:, act[ok]] = flat[:, ok]
        state[act[~ok]] = 2
        state[act[ok & (step < tol)]] = 1
    fitted = state != 2
    residual[~fitted] = np.nan
    crosses = np.zeros(m, dtype=np.uint8)
    ring_crosses(patches, np.ascontiguousarray(current - base + half), 0.6 * radius, _RING_COS, _RING_SIN, crosses)
    return current, (state == 1) & inside & crosses.view(bool), residual


@dataclass
class _LensPatches:
    """What the fits through the lens reuse while a patch stays (m patches, n disc pixels).

    Attributes
    ----------
    origin : (2, m) ndarray
        The undistorted position of each patch's base pixel, in its own frame.
    V : (2, m, 5, 5) ndarray
        The lens's node values (:func:`_node_values`).
    x, y : (m, n) ndarray
        The disc pixels' positions about ``origin``.
    values, g2 : (m, n) ndarray
        Their grey values and squared gradients, zero where the lens gives no position.
    frames : (m, 4, 3) ndarray
        Each patch's own frame (:func:`_node_values`).
    """

    origin: np.ndarray
    V: np.ndarray
    x: np.ndarray
    y: np.ndarray
    values: np.ndarray
    g2: np.ndarray
    frames: np.ndarray

    def replace(self, which, fresh: _LensPatches) -> None:
        """Put ``fresh`` (the patches ``which`` (k,) made again) in place of theirs."""
        self.origin[:, which], self.V[:, which] = fresh.origin, fresh.V
        for name in ("x", "y", "values", "g2", "frames"):
            getattr(self, name)[which] = getattr(fresh, name)


def _lens_patches(lens, base, offs, disc, patches, grad2) -> _LensPatches:
    """The :class:`_LensPatches` of patches about ``base`` (2, m): the pixels of ``disc``
    placed through the lens in each patch's own frame (zero weight where the lens gives no
    position)."""
    V, frames = _node_values(lens, base, offs)
    # Each pixel's position: the polynomial through the nodes (degree four each way), less
    # the middle node's (the base pixel's), by the compiled kernel.
    L = _lagrange(np.linspace(-offs[-1], offs[-1], 5), offs)
    rows, cols = np.nonzero(disc)
    m, n = base.shape[1], rows.size
    x, y, values, g2 = (np.empty((m, n)) for _ in range(4))
    V = np.ascontiguousarray(V)
    lens_disc(V, L, rows.astype(np.intp), cols.astype(np.intp), patches, grad2, x, y, values, g2)
    return _LensPatches(V[:, :, 2, 2], V, x, y, values, g2, frames)


def _fit_through(lens, through, act, half, offset, radius):
    """One round of saddle fits in undistorted pixel coordinates, for :func:`refine_points`.

    ``through`` is every patch's :class:`_LensPatches`, ``act`` (a,) the patches to
    fit, ``offset`` (2, a) their current raw estimates less their bases. Returns the new raw
    estimates (2, a), their pixels in the lens's distortion-free image (2, a), whether each
    fit is a saddle within its patch, and the residuals.
    """
    origin, V, x, y, values, g2, frames = (through.origin, through.V, through.x, through.y, through.values,
                                           through.g2, through.frames)
    origin = origin[:, act]
    # The estimate's undistorted position, about the patch's origin; the kernel weights the
    # pixels by refine_points' window about it, in undistorted pixels (none where it has no
    # undistorted position: a fisheye past 90 degrees).
    c = np.empty((2, act.size))
    lens_centres(V, act, np.ascontiguousarray(offset), float(half), c)
    known = np.all(np.isfinite(c), axis=0)
    pts, saddle, residual = np.empty((2, act.size)), np.zeros(act.size, dtype=np.uint8), np.empty(act.size)
    fit_through_lens(x, y, values, g2, act, c, radius, float(half), pts,
                     saddle, residual)
    saddle = saddle.view(bool)
    found = np.all(np.isfinite(pts), axis=0) & known
    within = found & (np.hypot(*np.where(found, pts - c, 0.0)) < half)
    new, flat = np.full((2, act.size), np.nan), np.full((2, act.size), np.nan)
    if found.any():
        new[:, found], flat[:, found] = _from_frames(lens, frames[act[found]], origin[:, found] + pts[:, found])
    return new, flat, saddle & within & np.all(np.isfinite(new), axis=0), residual


def _node_values(lens, base, offs):
    """The lens's values (2, m, 5, 5) at a 5 x 5 grid of nodes across each patch about
    ``base`` (2, m), [row node, column node], in the patch's own frame, from which
    :func:`_lens_patches` interpolates every pixel's position; and the frames (m, 4, 3).

    A patch's frame is the pinhole camera looking along the ray of its base pixel, with
    axes along the raw image's u and v there and a scale of one raw pixel (its area): the
    board's edges are straight in it, as the saddle model needs, and the raw pixels keep
    about their size, spacing and the window's shape. (The camera's own distortion-free
    image instead stretches a fisheye's rim by ``1 / cos^2`` of the field angle along the
    radius: eight times at 70 degrees, where a window of a few pixels then held a single
    raw pixel across the radius and its fit was off by up to 0.05 px on noise-free renders.)

    The lens is unprojected (an iterative inversion) at the nodes only, and interpolated
    between them by the polynomial through them (degree four in each direction): over a
    patch of a few tens of pixels a lens's map is smooth, and this keeps the interpolation
    within a thousandth of a pixel of the inversion even at a wide-angle lens's corners, at
    a fortieth of its cost.
    """
    h = float(offs[-1])
    nodes = np.linspace(-h, h, 5)
    m, n = base.shape[1], nodes.size
    u = base[0][:, None, None] + nodes[None, None, :] + np.zeros((1, n, 1))
    v = base[1][:, None, None] + nodes[None, :, None] + np.zeros((1, 1, n))
    rays = lens.unproject(np.vstack([u.ravel(), v.ravel()])).reshape(3, m, n, n)
    axis = rays[:, :, 2, 2]
    # The frame's x along the raw u there (the ray a node to the right), y completing it.
    ex = rays[:, :, 2, 3] - axis * np.sum(rays[:, :, 2, 3] * axis, axis=0)
    ex /= np.linalg.norm(ex, axis=0)
    ey = np.cross(axis.T, ex.T).T
    R = np.stack([ex, ey, axis], axis=1).transpose(2, 1, 0)  # (m, 3, 3): rows ex, ey, axis
    with np.errstate(divide="ignore", invalid="ignore"):
        P = np.einsum("mij,jmab->imab", R, rays)
        xy = P[:2] / P[2]
        # One raw pixel's area: the nodes next to the middle one, h / 2 pixels away.
        du, dv = xy[:, :, 2, 3] - xy[:, :, 2, 1], xy[:, :, 3, 2] - xy[:, :, 1, 2]
        scale = h / np.sqrt(np.abs(du[0] * dv[1] - du[1] * dv[0]))
        xy = np.where(P[2] > 0, xy, np.nan) * scale[None, :, None, None]
    frames = np.concatenate([R, scale[:, None, None] * np.ones((1, 1, 3))], axis=1)
    return xy, frames


def _from_frames(lens, frames, xy):
    """Raw pixels (2, a) of positions ``xy`` (2, a) in the patches' frames (a, 4, 3) of
    :func:`_node_values`, and their pixels in the lens's distortion-free image (2, a; NaN for
    a ray at or behind z = 0, as :meth:`Camera.undistort_pixels` gives)."""
    R, scale = frames[:, :3], frames[:, 3, 0]
    local = np.vstack([xy / scale, np.ones(xy.shape[1])])
    rays = np.einsum("aji,ja->ia", R, local)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(rays[2] > 0, rays[2], np.nan)
        flat = lens.K[:2, :2] @ (rays[:2] / z) + lens.K[:2, 2:3]
    return lens.project(rays), flat


def _lagrange(nodes, t) -> np.ndarray:
    """Lagrange basis (n, len(t)) of ``nodes`` at the points ``t``: row ``a`` is the product
    of ``t - nodes[b]`` over ``b != a`` (the products before and after ``a``, by running
    products), over the same product at ``nodes[a]``."""
    t = np.asarray(t, dtype=float).ravel()
    n = nodes.size
    d = t[None, :] - nodes[:, None]
    before = np.ones((n + 1, t.size))
    after = np.ones((n + 1, t.size))
    np.cumprod(d, axis=0, out=before[1:])
    np.cumprod(d[::-1], axis=0, out=after[1:])
    gaps = nodes[:, None] - nodes[None, :] + np.eye(n)
    return before[:n] * after[n - 1::-1] / np.prod(gaps, axis=1)[:, None]


def _patches(image, base, half, kernel, radius):
    """Smoothed patches (m, 2h+1, 2h+1) about ``base`` (2, m) (by the compiled
    :func:`graphpose.detect._refine.smoothed_patches`), squared gradients and an in-image
    mask (m,)."""
    height, width = image.shape
    m, size = base.shape[1], 2 * half + 1
    patches, grad2 = np.empty((m, size, size)), np.empty((m, size, size), dtype=np.float32)
    smoothed_patches(image, np.ascontiguousarray(base, dtype=np.intp), half, kernel, patches, grad2)
    inside = (base[0] - radius >= 0) & (base[0] + radius <= width - 1) & \
        (base[1] - radius >= 0) & (base[1] + radius <= height - 1)
    return patches, grad2, inside


def _gaussian_kernel(sigma: float) -> np.ndarray:
    """Normalised Gaussian taps out to 4 sigma (a single 1 for sigma = 0)."""
    if sigma == 0:
        return np.ones(1)
    t = int(np.ceil(4.0 * sigma))
    k = np.exp(-0.5 * (np.arange(-t, t + 1) / sigma) ** 2)
    return k / k.sum()

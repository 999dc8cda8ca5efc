"""Harder scenes for the detector, with exact truth: occluders, clutter, any orientation.

:func:`random_scene` renders a board (:func:`graphpose.synth.render.render`) at a random
pose, any in-plane rotation included (portrait and upside down), then paints on top of
it what real images hold: occluders (a bar, a blob, a bright specular reflection, or the
image edge cutting the board), and clutter beside the board (strokes like text, and a
small second grid of squares that is not the board). Every painted shape is known, so the
truth says which junctions can be seen: a junction is visible when no occluder comes
within a third of its local square and it lies that far inside the image.

Occluders are painted with anti-aliased edges (coverage from 4 x 4 supersampling), so the
image stays as smooth as a camera's; the board's own rendering keeps its exact truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import check_K, check_number, check_size
from ..board import check_board
from ..board import Board
from ..geometry import project
from ..errors import InputError
from .poses import random_pose
from .render import Rendering, render

#: Occluder kinds :func:`random_scene` draws from.
OCCLUDERS = ("bar", "blob", "reflection", "edge")


@dataclass(frozen=True)
class Scene:
    """A rendered scene and what of the board can be seen.

    Attributes
    ----------
    image : (H, W) ndarray of uint8
        The picture.
    rendering : Rendering
        The board's rendering before occluders and clutter (its ``junctions`` are exact).
    visible : (n,) ndarray of bool
        Junctions that can be seen: inside the image and not under an occluder.
    occluders : list of str
        Kinds painted on the board.
    clutter : list of str
        Kinds painted beside it.
    """

    image: np.ndarray
    rendering: Rendering
    visible: np.ndarray
    occluders: list
    clutter: list


def random_scene(K, board: Board = Board(), size=(640, 480), *, rng=None, occluders=(), clutter=(),
                 max_roll_deg: float = 180.0, max_tilt_deg: float = 50.0, distance=(0.7, 2.2),
                 noise_sigma: float = 2.0, blur_sigma: float = 1.0, margin: float = 0.5,
                 contrast: float = 1.0, vignetting: float = 0.0) -> Scene:
    """A random board scene with occluders and clutter, and its truth.

    Parameters
    ----------
    K : (3, 3) array_like
        Intrinsics, pixels.
    board : Board
        The target.
    size : (int, int)
        ``(width, height)``, pixels.
    rng : numpy.random.Generator, int or None, keyword
        Source of randomness (None: fresh entropy).
    occluders : sequence of str
        Kinds from :data:`OCCLUDERS`, painted in order; ``"edge"`` shifts the pose so that
        the image edge cuts the board.
    clutter : sequence of str
        ``"text"`` (dark strokes) and ``"grid"`` (a small 3 x 3-square pattern), beside the
        board.
    max_roll_deg, max_tilt_deg : float
        In-plane rotation (up to 180: any orientation) and tilt, degrees.
    distance : (float, float)
        Board centre depth range, metres.
    noise_sigma, blur_sigma : float
        As :func:`graphpose.synth.render.render`.
    margin : float
        White margin of the sheet, squares.
    contrast : float
        Scales the board's grey levels about mid grey (1 = the renderer's; 0.3 is a dim,
        washed-out board).
    vignetting : float
        Fraction of the light lost at the image's corners (``cos^4``-like falloff, 0 for
        none, 0.6 for a cheap wide-angle lens).

    Returns
    -------
    Scene

    Raises
    ------
    InputError
        If a kind is unknown or an argument is invalid.
    """
    K = check_K(K)
    width, height = check_size(size)
    check_board(board)
    for kind in occluders:
        if kind not in OCCLUDERS:
            raise InputError(f"occluder kinds are {OCCLUDERS}, got {kind!r}")
    for kind in clutter:
        if kind not in ("text", "grid"):
            raise InputError(f"clutter kinds are ('text', 'grid'), got {kind!r}")
    rng = np.random.default_rng(rng)
    T = random_pose(K, board, (width, height), rng=rng, distance=distance, max_tilt_deg=max_tilt_deg,
                    max_roll_deg=max_roll_deg, margin=margin)
    if "edge" in occluders:
        T = _push_off_edge(K, T, board, (width, height), rng=rng)
    mid = 125.0
    levels = {"white": mid + contrast * (215.0 - mid), "black": mid + contrast * (35.0 - mid)}
    R = render(K, T, board, (width, height), noise_sigma=0.0, quantize=False, rng=rng,
               blur_sigma=blur_sigma, margin=margin, **levels)
    image = R.image.astype(float)
    square = _square_px(R)
    cover = np.zeros((height, width))
    for kind in occluders:
        if kind == "edge":
            continue
        shape, value = _occluder(kind, R, square, rng=rng)
        image = image * (1 - shape) + value * shape
        cover = np.maximum(cover, shape)
    painted = []
    sheet = _sheet_mask(R)
    for kind in clutter:
        shape, value = _clutter(kind, (height, width), square, sheet, rng=rng)
        image = image * (1 - shape) + value * shape
        painted.append(kind)
    if vignetting:
        yy, xx = np.mgrid[0:height, 0:width]
        r2 = ((xx - (width - 1) / 2) ** 2 + (yy - (height - 1) / 2) ** 2) / ((width / 2) ** 2 + (height / 2) ** 2)
        image = image * (1.0 - check_number("vignetting", vignetting, 0.0, maximum=0.95) * r2 ** 2)
    image = image + rng.normal(0.0, noise_sigma, image.shape)
    image = np.clip(np.rint(image), 0, 255).astype(np.uint8)
    visible = _visible(R, cover, square)
    return Scene(image, R, visible, list(occluders), painted)


def _square_px(R: Rendering) -> np.ndarray:
    """Local square side (pixels) at each junction, from the exact projections of its neighbours."""
    b = R.board
    W = b.world_points()
    du = project(R.K, R.T_WC, W + [[b.square_m / 2], [0], [0]]) - project(R.K, R.T_WC, W - [[b.square_m / 2], [0], [0]])
    dv = project(R.K, R.T_WC, W + [[0], [b.square_m / 2], [0]]) - project(R.K, R.T_WC, W - [[0], [b.square_m / 2], [0]])
    return np.minimum(np.hypot(*du), np.hypot(*dv))


def _visible(R: Rendering, cover: np.ndarray, square: np.ndarray) -> np.ndarray:
    """Junctions inside the image, and with no occluder within a third of their square."""
    width, height = R.size
    u, v = R.junctions
    reach = np.maximum(square / 3.0, 2.0)
    inside = (u >= reach) & (v >= reach) & (u <= width - 1 - reach) & (v <= height - 1 - reach)
    yy, xx = np.mgrid[0:height, 0:width]
    visible = inside.copy()
    covered = cover > 0.02
    for k in np.flatnonzero(inside):
        r = int(np.ceil(reach[k]))
        y0, y1 = int(v[k]) - r, int(v[k]) + r + 2
        x0, x1 = int(u[k]) - r, int(u[k]) + r + 2
        near = (xx[y0:y1, x0:x1] - u[k]) ** 2 + (yy[y0:y1, x0:x1] - v[k]) ** 2 <= reach[k] ** 2
        visible[k] = not np.any(covered[y0:y1, x0:x1] & near)
    return visible


def _coverage(inside, height: int, width: int, S: int = 4) -> np.ndarray:
    """Anti-aliased coverage (H, W) of a shape given as a predicate on pixel coordinates."""
    off = (np.arange(S) + 0.5) / S - 0.5
    yy, xx = np.mgrid[0:height, 0:width].astype(float)
    acc = np.zeros((height, width))
    for dy in off:
        for dx in off:
            acc += inside(xx + dx, yy + dy)
    return acc / (S * S)


def _occluder(kind: str, R: Rendering, square: np.ndarray, *, rng):
    """(coverage (H, W), grey value) of one occluder over the board."""
    width, height = R.size
    J = R.junctions
    centre = J[:, rng.integers(J.shape[1])]
    s = float(np.median(square))
    if kind == "bar":
        angle = rng.uniform(0, np.pi)
        half = rng.uniform(0.3, 0.8) * s
        n = np.array([-np.sin(angle), np.cos(angle)])
        shape = _coverage(lambda x, y: np.abs((x - centre[0]) * n[0] + (y - centre[1]) * n[1]) <= half, height, width)
        return shape, rng.uniform(60.0, 160.0)
    if kind == "blob":
        a, b = rng.uniform(0.8, 2.0, 2) * s
        angle = rng.uniform(0, np.pi)
        c, sn = np.cos(angle), np.sin(angle)

        def inside(x, y):
            xr = (x - centre[0]) * c + (y - centre[1]) * sn
            yr = -(x - centre[0]) * sn + (y - centre[1]) * c
            return (xr / a) ** 2 + (yr / b) ** 2 <= 1.0

        return _coverage(inside, height, width), rng.uniform(20.0, 200.0)
    # A specular reflection: a bright, soft-edged ellipse that washes out the squares.
    a, b = rng.uniform(0.8, 1.8, 2) * s
    yy, xx = np.mgrid[0:height, 0:width].astype(float)
    r2 = ((xx - centre[0]) / a) ** 2 + ((yy - centre[1]) / b) ** 2
    return np.clip(1.5 * np.exp(-0.5 * r2 * 2.0), 0.0, 1.0), 250.0


def _sheet_mask(R: Rendering) -> np.ndarray:
    """Pixels within the sheet's outline grown by a square (clutter keeps away from them)."""
    from skimage.draw import polygon

    width, height = R.size
    o = R.outline
    c = o.mean(axis=1, keepdims=True)
    grown = c + 1.3 * (o - c)
    mask = np.zeros((height, width), dtype=bool)
    rr, cc = polygon(grown[1], grown[0], (height, width))
    mask[rr, cc] = True
    return mask


def _clutter(kind: str, shape, square: np.ndarray, sheet: np.ndarray, *, rng):
    """(coverage, grey value) of clutter placed away from the sheet (nothing if no room)."""
    height, width = shape
    s = float(np.clip(np.median(square), 8.0, 40.0))
    free = np.argwhere(~sheet)
    if free.size == 0:
        return np.zeros(shape), 0.0
    y0, x0 = free[rng.integers(len(free))]
    if kind == "text":
        strokes = []
        for _ in range(int(rng.integers(4, 9))):
            angle = rng.choice([0.0, np.pi / 2, rng.uniform(0, np.pi)])
            length = rng.uniform(0.5, 1.2) * s
            ox, oy = x0 + rng.uniform(-2, 2) * s, y0 + rng.uniform(-1, 1) * s
            strokes.append((ox, oy, np.cos(angle), np.sin(angle), length))

        def inside(x, y):
            hit = np.zeros_like(x, dtype=bool)
            for ox, oy, c, sn, length in strokes:
                t = (x - ox) * c + (y - oy) * sn
                d = np.abs(-(x - ox) * sn + (y - oy) * c)
                hit |= (t >= 0) & (t <= length) & (d <= 0.08 * s)
            return hit & ~sheet[np.clip(y.astype(int), 0, height - 1), np.clip(x.astype(int), 0, width - 1)]

        return _coverage(inside, height, width), 30.0
    # A small grid of 3 x 3 squares: a pattern with a few cross-junctions that is not the board.
    cell = 0.6 * s
    angle = rng.uniform(0, np.pi / 2)
    c, sn = np.cos(angle), np.sin(angle)

    def inside(x, y):
        xr = ((x - x0) * c + (y - y0) * sn) / cell
        yr = (-(x - x0) * sn + (y - y0) * c) / cell
        box = (xr >= 0) & (xr < 3) & (yr >= 0) & (yr < 3)
        dark = (np.floor(xr) + np.floor(yr)) % 2 == 0
        return box & dark & ~sheet[np.clip(y.astype(int), 0, height - 1), np.clip(x.astype(int), 0, width - 1)]

    return _coverage(inside, height, width), 25.0


def _push_off_edge(K, T_WC, board: Board, size, *, rng) -> np.ndarray:
    """Slide the camera sideways so that the image edge cuts off part of the board."""
    width, height = size
    T = T_WC.copy()
    W = board.world_points()
    uv = project(K, T, W)
    depth = float(np.median((np.linalg.inv(T) @ np.vstack([W, np.ones(W.shape[1])]))[2]))
    side = rng.integers(4)
    span = (uv[0].max() - uv[0].min()) if side < 2 else (uv[1].max() - uv[1].min())
    shift_px = rng.uniform(0.2, 0.45) * span
    # Moving the camera by d along its own x moves the image by -f d / z along u.
    axis = T[:3, 0] if side < 2 else T[:3, 1]
    f = K[0, 0] if side < 2 else K[1, 1]
    to_edge = (uv[0].min() if side == 0 else width - 1 - uv[0].max()) if side < 2 else \
        (uv[1].min() if side == 2 else height - 1 - uv[1].max())
    shift = (to_edge + shift_px) * depth / f
    T[:3, 3] += axis * shift * (1 if side in (0, 2) else -1)
    return T

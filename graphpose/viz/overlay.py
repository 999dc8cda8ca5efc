"""Overlay pictures: a pose estimate drawn on its image with :mod:`skimage.draw`.

:func:`draw_overlay` marks the measured cross-junctions (trusted: cyan rings, untrusted:
red crosses), the junctions reprojected from the final pose (magenta plus signs, so a good fit
reads as a plus inside a ring) and the board's grid lines through them (thin magenta, drawn
through the camera's lens model, so that on a raw image they bend with the board's edges),
the target's x / y / z axes from its origin (red, green, blue; z points into the board), the
bounding polygon (thin yellow) and the pose in a text box in the corner that hides the least
of the board. scikit-image draws no text: the text is written in the 5 x 9 bitmap font of
:mod:`graphpose.viz.font`.
"""

from __future__ import annotations

import numpy as np

from .._checks import as_polygon
from ..board import Board
from ..geometry import to_camera
from ..camera_models import as_camera, check_image_size
from ..detect.search import in_polygon
from ..image import as_grey
from .font import HEIGHT, WIDTH, glyph

#: Samples per square along the drawn grid lines (enough for a smooth curve under distortion).
GRID_SAMPLES = 8

#: RGB colours of the overlay's marks.
COLOURS = {
    "trusted": (0, 230, 255),
    "untrusted": (255, 40, 40),
    "reprojected": (255, 0, 255),
    "bounds": (255, 210, 0),
    "x": (255, 60, 60),
    "y": (40, 220, 40),
    "z": (70, 140, 255),
    "text": (255, 255, 255),
    "good": (90, 255, 90),
    "bad": (255, 80, 80),
}


def draw_overlay(image, estimate, camera, board: Board = Board(), *, bounds=None, label=None) -> np.ndarray:
    """Draw a pose estimate on its image.

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) array_like
        The image the estimate came from (any dtype :func:`graphpose.image.as_grey` takes),
        raw as the camera took it.
    estimate : PoseEstimate
        Result of :func:`graphpose.estimate.estimate_pose`; uses ``T_WC``, ``params``,
        ``mask`` (the trusted junctions), ``junctions.points`` (none are marked when
        ``junctions`` is None, as from :func:`~graphpose.estimate.estimate_pose_from_points`),
        ``reprojection_rms_px``, ``converged``, ``cross_check.agree`` and, when present,
        ``orientation_ambiguous``.
    camera : Camera or (3, 3) array_like
        The camera the estimate used (:mod:`graphpose.camera_models`), or pinhole intrinsics
        ``K``, pixels: the reprojection, the grid and the axes are drawn through it.
    board : Board
        The target; its junctions are reprojected and its square sets the axes' length
        (two squares).
    bounds : (2, 4) array_like, optional
        The bounding polygon given to the estimator, drawn as a thin outline.
    label : str, optional
        A name (the image's) written above the pose.

    Returns
    -------
    overlay : (H, W, 3) ndarray of uint8
        A new RGB image; the inputs are not modified.

    Raises
    ------
    InputError
        If the image or camera is malformed, the image's size is not the camera's
        calibration's, or ``bounds`` is not a finite (2, m) polygon, m >= 3.
    """
    camera = as_camera(camera)
    grey = as_grey(image)
    check_image_size(camera, grey.shape)
    if bounds is not None:
        bounds = as_polygon(bounds, "bounds")
    # Dimmed grey keeps the board readable while the saturated marks stand out on black and white.
    canvas = np.repeat((40.0 + 170.0 * np.clip(grey, 0.0, 1.0))[..., None], 3, axis=2)
    T = np.asarray(estimate.T_WC, dtype=float)
    size = max(1.0, min(canvas.shape[:2]) / 480.0)

    if bounds is not None:
        for i in range(bounds.shape[1]):
            _line(canvas, bounds[:, i], bounds[:, (i + 1) % bounds.shape[1]], COLOURS["bounds"], 1.0)

    for curve in _grid_lines(camera, T, board):
        for a, b in zip(curve.T[:-1], curve.T[1:]):
            _line(canvas, a, b, COLOURS["reprojected"], 1.0, alpha=0.55)

    Wpts = board.world_points()
    model = _visible(camera, T, Wpts)
    for u, v in model.T:
        _plus(canvas, u, v, 3.5 * size, COLOURS["reprojected"], 1.0)

    trusted = np.asarray(estimate.mask, dtype=bool)
    junctions = estimate.junctions
    points = np.zeros((2, 0)) if junctions is None else np.asarray(junctions.points, dtype=float)
    for (u, v), ok in zip(points.T, trusted):
        if not np.all(np.isfinite([u, v])):
            continue
        if ok:
            _ring(canvas, u, v, 6.0 * size, 2.0 * size, COLOURS["trusted"])
        else:
            _cross(canvas, u, v, 5.0 * size, 2.0 * size, COLOURS["untrusted"])

    tips = _draw_axes(canvas, camera, T, 2.0 * board.square_m, size)

    avoid = np.hstack([p for p in (points, model, tips) if p.size] or [np.zeros((2, 0))])
    scale = max(1, int(round(min(canvas.shape[:2]) / 240.0)))
    _text_box(canvas, _pose_lines(estimate, trusted, label), avoid, bounds, scale)
    return np.clip(np.round(canvas), 0, 255).astype(np.uint8)


# --- what is drawn -----------------------------------------------------------------------


def _draw():
    """:mod:`skimage.draw`, imported by the first picture (an estimate without
    ``--overlay`` needs none of scikit-image)."""
    from skimage import draw

    return draw


def _visible(camera, T, P) -> np.ndarray:
    """Projections (2, m) of the points of P (3, N) that lie in front of the camera and
    that its model images."""
    P_C = to_camera(T, P)
    uv = camera.project(P_C[:, P_C[2] > 1e-6])
    return uv[:, np.all(np.isfinite(uv), axis=0)]


def _grid_lines(camera, T, board) -> list:
    """The board's rows and columns of junctions as curves (2, m) in the image, sampled
    :data:`GRID_SAMPLES` times a square; each cut where a sample is not imaged."""
    s, cols, rows = board.square_m, board.cols, board.rows
    lines = []
    along_x = np.linspace(0.0, (cols - 1) * s, (cols - 1) * GRID_SAMPLES + 1)
    along_y = np.linspace(0.0, (rows - 1) * s, (rows - 1) * GRID_SAMPLES + 1)
    for r in range(rows):
        lines.append(np.vstack([along_x, np.full_like(along_x, r * s), np.zeros_like(along_x)]))
    for c in range(cols):
        lines.append(np.vstack([np.full_like(along_y, c * s), along_y, np.zeros_like(along_y)]))
    curves = []
    for P in lines:
        P_C = to_camera(T, P)
        uv = np.full((2, P.shape[1]), np.nan)
        front = P_C[2] > 1e-6
        uv[:, front] = camera.project(P_C[:, front])
        good = np.all(np.isfinite(uv), axis=0)
        # Runs of consecutive imaged samples.
        for run in np.split(np.arange(good.size), np.flatnonzero(np.diff(good)) + 1):
            if good[run[0]] and run.size > 1:
                curves.append(uv[:, run])
    return curves


def _draw_axes(canvas, camera, T, length, size) -> np.ndarray:
    origin = np.zeros((3, 1))
    o = _visible(camera, T, origin)
    tips = []
    if o.shape[1] == 0:
        return np.zeros((2, 0))
    rr, cc = _draw().disk((o[1, 0], o[0, 0]), 1.2 * size + 2, shape=canvas.shape[:2])
    _blend(canvas, rr, cc, (255, 255, 255), 1.0)
    # z last: it points away from the camera, is drawn short and must stay on top.
    for axis, name in ((0, "x"), (1, "y"), (2, "z")):
        end = origin.copy()
        end[axis] = length
        e = _visible(camera, T, end)
        if e.shape[1] == 0:
            continue
        _arrow(canvas, o[:, 0], e[:, 0], COLOURS[name], 3.0 * size)
        tips.append(e)
    return np.hstack([o] + tips)


def _pose_lines(estimate, trusted, label) -> list:
    x, y, z, roll, pitch, yaw = estimate.params
    # Rounded first, so that -0.000001 is not written as "-0.00".
    x, y, z = (round(float(c), 4) + 0.0 for c in (x, y, z))
    roll, pitch, yaw = (round(float(a), 2) + 0.0 for a in np.degrees([roll, pitch, yaw]))
    white = COLOURS["text"]
    if not estimate.converged:
        status = ("NOT converged", COLOURS["bad"])
    elif not estimate.cross_check.agree:
        status = ("GN/GTSAM disagree", COLOURS["bad"])
    else:
        status = ("converged", COLOURS["good"])
    head = [(f"{label}  ", white)] if label else []
    ambiguous = [[("orientation ambiguous (no bounds)", COLOURS["bounds"])]] \
        if getattr(estimate, "orientation_ambiguous", False) else []
    return [
        head + [status],
        [(f"x {x:+8.4f} m   roll  {roll:+8.2f}\u00b0", white)],
        [(f"y {y:+8.4f} m   pitch {pitch:+8.2f}\u00b0", white)],
        [(f"z {z:+8.4f} m   yaw   {yaw:+8.2f}\u00b0", white)],
        [(f"rms {estimate.rms_px:.2f} px   {int(trusted.sum())}/{trusted.size} trusted", white)],
        [("o", COLOURS["trusted"]), (" trusted  ", white), ("x", COLOURS["untrusted"]),
         (" untrusted  ", white), ("+", COLOURS["reprojected"]), (" model", white)],
        [("axes ", white), ("x", COLOURS["x"]), (" ", white), ("y", COLOURS["y"]), (" ", white),
         ("z", COLOURS["z"]), (" (z: into the board)", white)],
    ] + ambiguous


def _text_box(canvas, lines, avoid, sheet, scale) -> None:
    """Write ``lines`` on a dark box in the image corner that hides the least of the board.

    The corner covering the fewest ``avoid`` points (2, m) wins; ties go to the one covering
    the least of the ``sheet`` polygon (2, k) when given, then to the upper left.
    """
    pad, step = 4 * scale, (HEIGHT + 2) * scale
    w = max(sum(len(t) for t, _ in line) for line in lines) * (WIDTH + 1) * scale + 2 * pad
    h = len(lines) * step + 2 * pad
    H, W = canvas.shape[:2]
    corners = [(0, 0), (W - w, 0), (0, H - h), (W - w, H - h)]

    def covered(corner):
        u0, v0 = corner
        u, v = avoid
        points = int(np.sum((u > u0 - 10) & (u < u0 + w + 10) & (v > v0 - 10) & (v < v0 + h + 10)))
        if sheet is None:
            return points, 0
        gu, gv = np.meshgrid(np.arange(u0, u0 + w, 8.0), np.arange(v0, v0 + h, 8.0))
        inside = in_polygon(np.vstack([gu.ravel(), gv.ravel()]), sheet)
        return points, int(inside.sum())

    u0, v0 = min(corners, key=covered)
    u0, v0 = max(u0, 0), max(v0, 0)
    rr, cc = _draw().rectangle((v0, u0), extent=(h, w), shape=canvas.shape[:2])
    _blend(canvas, rr, cc, (0, 0, 0), 0.65)
    for i, line in enumerate(lines):
        u = u0 + pad
        for text, colour in line:
            _text(canvas, u, v0 + pad + i * step, text, colour, scale)
            u += len(text) * (WIDTH + 1) * scale


# --- primitives ---------------------------------------------------------------------------


def _blend(canvas, rr, cc, colour, alpha) -> None:
    H, W = canvas.shape[:2]
    rr, cc = np.asarray(rr), np.asarray(cc)
    alpha = np.broadcast_to(np.asarray(alpha, dtype=float), rr.shape)
    keep = (rr >= 0) & (rr < H) & (cc >= 0) & (cc < W)
    rr, cc, a = rr[keep], cc[keep], alpha[keep][:, None]
    canvas[rr, cc] = canvas[rr, cc] * (1.0 - a) + np.asarray(colour, dtype=float) * a


def _clip(p0, p1, H, W, margin=20.0):
    """Clip the segment p0-p1 (u, v) to the image grown by ``margin`` (Liang-Barsky); None if outside."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    if not (np.all(np.isfinite(p0)) and np.all(np.isfinite(p1))):
        return None
    d = p1 - p0
    t0, t1 = 0.0, 1.0
    for p, q in ((-d[0], p0[0] + margin), (d[0], W - 1 + margin - p0[0]),
                 (-d[1], p0[1] + margin), (d[1], H - 1 + margin - p0[1])):
        if p == 0:
            if q < 0:
                return None
            continue
        t = q / p
        if p < 0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
    if t0 > t1:
        return None
    return p0 + t0 * d, p0 + t1 * d


def _line(canvas, p0, p1, colour, width, alpha=1.0) -> None:
    seg = _clip(p0, p1, *canvas.shape[:2])
    if seg is None:
        return
    (u0, v0), (u1, v1) = seg
    if width <= 1.0:
        rr, cc, val = _draw().line_aa(int(round(v0)), int(round(u0)), int(round(v1)), int(round(u1)))
        _blend(canvas, rr, cc, colour, alpha * val)
        return
    d = np.array([u1 - u0, v1 - v0])
    n = np.array([-d[1], d[0]]) / max(np.hypot(*d), 1e-9) * width / 2.0
    quad = np.array([[u0, v0] + n, [u1, v1] + n, [u1, v1] - n, [u0, v0] - n])
    rr, cc = _draw().polygon(quad[:, 1], quad[:, 0], shape=canvas.shape[:2])
    _blend(canvas, rr, cc, colour, 1.0)


def _arrow(canvas, p0, p1, colour, width) -> None:
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    length = np.hypot(*d)
    if not np.isfinite(length) or length < 1.0:
        return
    d /= length
    head = min(4.0 * width, 0.4 * length)
    _line(canvas, p0, p1 - d * head * 0.8, colour, width)
    n = np.array([-d[1], d[0]])
    tri = np.array([p1, p1 - d * head + n * head * 0.45, p1 - d * head - n * head * 0.45])
    if np.all(np.abs(tri) < 1e5):
        rr, cc = _draw().polygon(tri[:, 1], tri[:, 0], shape=canvas.shape[:2])
        _blend(canvas, rr, cc, colour, 1.0)


def _ring(canvas, u, v, radius, width, colour) -> None:
    for k in range(max(1, int(round(width)))):
        rr, cc, val = _draw().circle_perimeter_aa(int(round(v)), int(round(u)), int(round(radius)) - k)
        _blend(canvas, rr, cc, colour, val)


def _cross(canvas, u, v, arm, width, colour) -> None:
    _line(canvas, (u - arm, v - arm), (u + arm, v + arm), colour, width)
    _line(canvas, (u - arm, v + arm), (u + arm, v - arm), colour, width)


def _plus(canvas, u, v, arm, colour, width) -> None:
    _line(canvas, (u - arm, v), (u + arm, v), colour, width)
    _line(canvas, (u, v - arm), (u, v + arm), colour, width)


def _text(canvas, u, v, text, colour, scale=1) -> None:
    """Write ``text`` with its upper-left corner at pixel (u, v), glyphs ``scale`` x enlarged."""
    scale = max(1, int(scale))
    u, v = int(round(u)), int(round(v))
    for i, ch in enumerate(text):
        rows, cols = np.nonzero(np.kron(glyph(ch), np.ones((scale, scale), bool)))
        _blend(canvas, rows + v, cols + u + i * (WIDTH + 1) * scale, colour, 1.0)

"""Choosing a calibration's views from a recording: sharp, spread over the image, varied, few.

People calibrate from a clip of the board waved in front of the camera. :func:`choose_views`
scans it (every frame, or every ``scan_every``-th of a long one: the frames between are decoded
but not searched) and keeps, up to ``max_views``:

1. **Frames with the board**: the board search of the calibration (no camera yet,
   :func:`graphpose.detect.find_board`), whole or partly in view (at least
   :data:`MIN_VIEW_JUNCTIONS` junctions).
2. **Still and sharp ones**: the board's junctions may move at most :data:`MAX_SPEED_PX` pixels a
   frame (their 90th percentile, from the scanned frames before and after): a faster frame is
   smeared over its exposure and, from a rolling shutter, skewed; a frame neither of whose
   neighbours shows the board has no measured motion and is left out too. And a frame's blur is the edge width at its junctions, ``sigma = C^2 L /
   (2 sqrt(pi) sum |g|^2)`` for a patch of side ``L`` with contrast ``C`` (an edge blurred by a
   Gaussian of ``sigma`` pixels has ``integral g^2 = C^2 / (2 sqrt(pi) sigma)`` across it), the
   noise's share of ``sum |g|^2`` taken off, the median over the junctions. A frame whose blur
   exceeds :data:`BLUR_TOLERANCE` times the recording's sharp frames' (its 20th percentile)
   is left out: motion blur moves the edges along the motion and biases the junctions.
3. **Spread and varied**, greedily: each next view is the one that covers most cells of a 8 x 6
   grid over the image that fewer than two chosen views cover (the corners and edges count as
   any other cell, so a view reaching them is taken early), plus its distance to the nearest
   chosen view in a descriptor of its place in the image, its apparent size (distance) and its
   foreshortening along both board axes (tilt).
4. **No near-duplicates**: a view whose junctions lie within ``duplicate_px`` (RMS over the
   junctions both see) of a chosen view's is left out as a copy of it. Views of one pose a few
   pixels apart are kept (their noise averages out); the spread term (weight
   :data:`SPREAD_WEIGHT`, against :data:`COVER_WEIGHT` for a new cell) takes distinct poses
   first.

:class:`ViewChoice` says for every frame of the recording why it was used or not.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..board import Board, check_board
from ..errors import BoardNotFoundError, InputError

#: Fewest junctions a view must show to be a candidate: more than a calibration's images need
#: (:data:`graphpose.calibrate.run.MIN_CALIBRATION_JUNCTIONS`), because a view is also judged by
#: its junctions' motion (the 90th percentile of those it shares with a neighbour) and blur.
MIN_VIEW_JUNCTIONS = 12
#: A frame is blurred when its blur exceeds this many times the recording's sharp frames'.
BLUR_TOLERANCE = 1.6
#: Fastest junction motion of a view, pixels a frame (half of it is the smear over an exposure of
#: half a frame interval).
MAX_SPEED_PX = 2.0
#: Frames a long recording is scanned for, at most (``scan_every`` is sized from it).
SCAN_FRAMES = 400
#: Weights of a candidate's score: new grid cells it covers, and its descriptor distance to the
#: nearest chosen view.
COVER_WEIGHT, SPREAD_WEIGHT = 1.0, 12.0
#: The coverage grid, cells across and down.
GRID = (8, 6)

#: Most bytes of candidate frames :func:`choose_views` keeps in memory with ``keep_images``
#: (beyond it, the chosen frames are not kept and the caller reads them again).
KEEP_BYTES = 256 * 2**20

#: Reasons a frame is not used.
USED = "used"
NOT_SCANNED = "not scanned"
NO_BOARD = "no board"
TOO_FEW = "too few junctions"
BLURRED = "blurred"
MOVING = "moving fast"
DUPLICATE = "near-duplicate"
BEYOND_CAP = "beyond max_views"
UNREADABLE = "unreadable"


@dataclass(frozen=True)
class ViewChoice:
    """The views chosen from a recording, and why every other frame was not.

    Attributes
    ----------
    frames : (m,) ndarray of int
        The chosen frames' indices, in recording order.
    status : tuple of str
        Per frame of the recording: ``"used"``, or one of ``"not scanned"``, ``"no board"``,
        ``"too few junctions"``, ``"blurred"``, ``"near-duplicate"``, ``"beyond max_views"``,
        ``"unreadable"``.
    detail : tuple of str
        Per frame, the reason in words with its numbers ("blur 2.31 px, the sharp frames' 1.02
        px", "of frame 120", ...), "" for a used or unscanned frame.
    blur_px : (N,) ndarray
        Each scanned frame's blur (edge sigma, pixels); NaN where not measured.
    speed_px : (N,) ndarray
        Each scanned frame's junction motion, pixels a frame; NaN where not measured.
    junctions : (N,) ndarray of int
        Junctions found in each scanned frame (0 where none or not scanned).
    timestamps : (N,) ndarray or None
        The recording's frame times, seconds.
    scan_every : int
        Every how many frames one was searched.
    sharp_blur_px : float
        The blur of the recording's sharp frames (the 20th percentile), pixels.
    images : tuple of (H, W) ndarray, or None
        The chosen frames' images, in ``frames`` order, when asked for (``keep_images``) and
        they fitted in :data:`KEEP_BYTES`; else None.
    """

    frames: np.ndarray
    status: tuple
    detail: tuple
    blur_px: np.ndarray
    speed_px: np.ndarray
    junctions: np.ndarray
    timestamps: np.ndarray | None
    scan_every: int
    sharp_blur_px: float
    images: tuple | None = None

    def counts(self) -> dict:
        """How many frames have each status, most first."""
        values, counts = np.unique(np.array(self.status), return_counts=True)
        order = np.argsort(-counts)
        return {str(values[i]): int(counts[i]) for i in order}


def choose_views(recording, board: Board = Board(), *, max_views: int = 40, scan_every: int | None = None,
                 duplicate_px: float | None = None, keep_images: bool = False, progress=None) -> ViewChoice:
    """Choose a calibration's views from a recording (see the module docstring).

    Parameters
    ----------
    recording : Recording
        An open :class:`graphpose.io.sources.base.Recording` (a video, a bag's topic, image files).
    board : Board
        The board.
    max_views : int
        Most views kept, >= 3.
    scan_every : int, optional
        Search every this many-th frame; default ``ceil(N / SCAN_FRAMES)`` (every frame of a
        short recording).
    duplicate_px : float, optional
        RMS junction distance under which a view is a copy of a chosen one; default 0.5 % of
        the image's diagonal (3.2 px at 640 x 480: a hand held still).
    keep_images : bool
        Keep the candidate frames' images while scanning (up to :data:`KEEP_BYTES`), and give
        the chosen ones in ``ViewChoice.images``: the caller need not decode the recording a
        second time to calibrate from them.
    progress : callable, optional
        Called as ``progress(done, total)`` after each frame decoded.

    Returns
    -------
    ViewChoice

    Raises
    ------
    InputError
        If ``max_views`` < 3 or ``scan_every`` < 1, or the recording breaks (the message names
        where: :class:`graphpose.io.sources.base.BrokenRecordingError`).
    """
    board = check_board(board)
    if isinstance(max_views, bool) or not isinstance(max_views, (int, np.integer)) or max_views < 3:
        raise InputError(f"max_views must be an integer >= 3, got {max_views!r}")
    n = len(recording)
    step = int(np.ceil(n / SCAN_FRAMES)) if scan_every is None else int(scan_every)
    if step < 1:
        raise InputError(f"scan_every must be >= 1, got {scan_every!r}")
    status, detail = [NOT_SCANNED] * n, [""] * n
    blur, count = np.full(n, np.nan), np.zeros(n, dtype=int)
    seen, size = {}, None  # frame -> (points (2, J) NaN unseen)
    kept, kept_bytes = ({} if keep_images else None), 0  # frame -> image of the candidates
    for k in range(n):
        frame = recording.read(k)  # every frame is decoded (a video decodes in order anyway)
        if k % step == 0:
            size = frame.image.shape[::-1]
            status[k], detail[k], points, blur[k] = _scan(frame.image, board)
            if points is not None:
                count[k] = int(np.sum(np.isfinite(points[0])))
                seen[k] = points
                if kept is not None:
                    kept[k] = frame.image
                    kept_bytes += frame.image.nbytes
                    if kept_bytes > KEEP_BYTES:
                        kept = None  # too many to hold: the caller reads the chosen ones again
        if progress is not None:
            progress(k + 1, n)
    speed = _speed(seen, step, n)
    for k in list(seen):
        if speed[k] > MAX_SPEED_PX:
            status[k], detail[k] = MOVING, f"{speed[k]:.1f} px a frame (smeared, skewed), more than {MAX_SPEED_PX:g}"
            del seen[k]
        elif not np.isfinite(speed[k]):  # its neighbours lost the board: most often a fast move
            status[k], detail[k] = MOVING, "its motion unknown: neither scanned neighbour shows the board"
            del seen[k]
    sharp = _sharp_blur(blur, seen)
    for k in list(seen):
        if blur[k] > BLUR_TOLERANCE * sharp:
            status[k], detail[k] = BLURRED, f"blur {blur[k]:.2f} px, the sharp frames' {sharp:.2f} px"
            del seen[k]
    if size is not None:
        diagonal = float(np.hypot(*size))
        _greedy(seen, blur, size, board, max_views, 0.005 * diagonal if duplicate_px is None else duplicate_px,
                status, detail)
    frames = np.array(sorted(k for k in range(n) if status[k] == USED), dtype=int)
    images = None if kept is None else tuple(kept[int(k)] for k in frames)
    return ViewChoice(frames, tuple(status), tuple(detail), blur, speed, count, recording.timestamps, step, sharp,
                      images)


def _scan(image, board):
    """``(status, detail, points (2, J) or None, blur px)`` of one frame."""
    from ..detect import find_board

    grey = np.asarray(image)
    # The frame's own grey levels, as the scan has always searched them: 8-bit as it is, a
    # 16-bit frame as float64 of its integer levels (find_board keeps float grey as it is;
    # scaled to [0, 1] the search's float32 roundings would move its junctions by 1e-6 px).
    levels = grey if grey.dtype == np.uint8 else grey.astype(float)
    try:
        found = find_board(levels, board)
    except BoardNotFoundError as exc:
        return NO_BOARD, " ".join(str(exc).split())[:160], None, np.nan
    points = np.where(found.seen, found.points, np.nan)
    m = int(found.seen.sum())
    if m < MIN_VIEW_JUNCTIONS:
        return TOO_FEW, f"{m} junctions, fewer than {MIN_VIEW_JUNCTIONS}", None, np.nan
    return USED, "", points, _blur(grey, points[:, found.seen], np.nanmedian(found.step_px))


def _blur(grey, points, step) -> float:
    """The median edge sigma (pixels) at ``points`` (2, m): see the module docstring."""
    from ..detect import estimate_noise

    I = np.asarray(grey, dtype=float)
    noise = estimate_noise(I)
    r = int(np.clip(0.35 * step, 3, 25))
    H, W = I.shape
    u, v = np.round(points).astype(int)
    inside = (r <= u) & (u < W - r - 1) & (r <= v) & (v < H - r - 1)
    if not inside.any():
        return np.nan
    # Every junction's patch at once, (m, 2r + 1, 2r + 1): the same sums as patch by patch.
    offsets = np.arange(-r, r + 1)
    patches = I[(v[inside][:, None] + offsets)[:, :, None], (u[inside][:, None] + offsets)[:, None, :]]
    gy, gx = np.gradient(patches, axis=(1, 2))
    energy = np.sum(gx * gx + gy * gy, axis=(1, 2)) - patches[0].size * noise * noise
    lo, hi = np.percentile(patches, (5, 95), axis=(1, 2))
    contrast = hi - lo
    good = (energy > 0) & (contrast > 4 * noise)
    if not good.any():
        return np.nan
    # Two edges cross the patch, each of length 2r + 1.
    sigmas = contrast[good] ** 2 * 2 * (2 * r + 1) / (2 * np.sqrt(np.pi) * energy[good])
    return float(np.median(sigmas))


def _speed(seen, step, n) -> np.ndarray:
    """Junction motion (pixels a frame, 90th percentile over the junctions) of each frame of
    ``seen``, the mean over the scanned frames before and after that show the board too."""
    speed = np.full(n, np.nan)
    for k, P in seen.items():
        rates = []
        for j in (k - step, k + step):
            if j in seen:
                both = np.isfinite(P[0]) & np.isfinite(seen[j][0])
                if both.sum() >= MIN_VIEW_JUNCTIONS:
                    d = np.hypot(*(P[:, both] - seen[j][:, both]))
                    rates.append(float(np.percentile(d, 90)) / step)
        if rates:
            speed[k] = float(np.mean(rates))
    return speed


def _sharp_blur(blur, seen) -> float:
    values = np.array([blur[k] for k in seen if np.isfinite(blur[k])])
    return float(np.percentile(values, 20)) if values.size else np.nan


def _descriptor(points, size) -> np.ndarray:
    """Where the view is (centre / image size), its apparent size (log of the junction spacing)
    and its foreshortening along both board axes (log ratios of opposite edges of the seen
    part), each scaled to about 1 over a calibration's range."""
    W, H = size
    P = points  # (2, rows, cols), NaN unseen
    centre = np.nanmean(P, axis=(1, 2))
    rows = [r for r in range(P.shape[1]) if np.sum(np.isfinite(P[0, r])) >= 2]
    cols = [c for c in range(P.shape[2]) if np.sum(np.isfinite(P[0, :, c])) >= 2]

    def span(line):
        good = line[:, np.isfinite(line[0])]
        return float(np.hypot(*(good[:, -1] - good[:, 0]))) / max(good.shape[1] - 1, 1)

    top, bottom = span(P[:, rows[0]]), span(P[:, rows[-1]])
    left, right = span(P[:, :, cols[0]]), span(P[:, :, cols[-1]])
    scale = np.log(max(0.25 * (top + bottom + left + right), 1e-6))
    return np.array([centre[0] / W, centre[1] / H, scale / 0.7, 4 * np.log(max(top, 1e-6) / max(bottom, 1e-6)),
                     4 * np.log(max(left, 1e-6) / max(right, 1e-6))])


def _greedy(seen, blur, size, board, cap, duplicate_px, status, detail) -> None:
    """Pick up to ``cap`` views of ``seen`` (see the module docstring); mark the others."""
    W, H = size
    cols, rows = GRID
    cells, desc = {}, {}
    for k, P in seen.items():
        good = np.isfinite(P[0])
        cu = np.clip((P[0, good] / W * cols).astype(int), 0, cols - 1)
        cv = np.clip((P[1, good] / H * rows).astype(int), 0, rows - 1)
        cells[k] = set(zip(cu.tolist(), cv.tolist()))
        desc[k] = _descriptor(P.reshape(2, board.rows, board.cols), size)  # the junctions are row-major
    covered = np.zeros((cols, rows), dtype=int)
    chosen = []
    left = set(seen)
    # Each candidate's descriptor distance to its nearest chosen view (1 before any is chosen),
    # kept up to date as views are chosen: the minimum over the chosen ones, without a pass
    # over them for every candidate at every pick.
    spread = dict.fromkeys(seen, 1.0)
    while left and len(chosen) < cap:
        best, best_score = None, -np.inf
        for k in left:
            new = sum(1 for c in cells[k] if covered[c] < 2)
            score = COVER_WEIGHT * new + SPREAD_WEIGHT * spread[k] - 0.1 * blur[k]
            if score > best_score:
                best, best_score = k, score
        left.discard(best)
        copy = _duplicate_of(seen[best], seen, chosen, duplicate_px)
        if copy is not None:
            status[best], detail[best] = DUPLICATE, f"of frame {copy}"
            continue
        first = not chosen
        chosen.append(best)
        status[best] = USED
        for c in cells[best]:
            covered[c] += 1
        for k in left:
            d = float(np.linalg.norm(desc[k] - desc[best]))
            spread[k] = d if first else min(spread[k], d)
    for k in left:
        status[k], detail[k] = BEYOND_CAP, f"{cap} views chosen before it"


def _duplicate_of(P, seen, chosen, limit):
    for j in chosen:
        both = np.isfinite(P[0]) & np.isfinite(seen[j][0])
        if both.sum() >= MIN_VIEW_JUNCTIONS:
            d = P[:, both] - seen[j][:, both]
            if np.sqrt(np.mean(np.sum(d * d, axis=0))) < limit:
                return j
    return None

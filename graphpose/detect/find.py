"""Find the board in an image and label its junctions: candidates, lattices, identity.

:func:`find_board` searches the whole image (or, given bounds, starts inside them), grows
lattices of cross-junctions from the strongest candidates (:mod:`.lattice`), and labels
each with board indices from the evidence of its edges (:mod:`.identify`). The largest
lattice that can be labelled is the board. Without bounds, a second lattice that can be
labelled as a board of its own (half the board's junctions or more, away from the first)
makes the image ambiguous and is refused: bounds must say which board is meant.

The search runs its fast path first (:func:`graphpose.detect.search.search_levels`, with
candidates relative to the strongest peaks). Where that finds no whole board in an image
whose noise (:func:`graphpose.detect.noise.estimate_noise`) is at least :data:`NOISY` of
its grey range, the noise-aware search follows (:func:`noise_levels`): coarser levels,
where a large square's junction is judged at its square's scale, and candidates above a
floor set by the measured noise (:func:`graphpose.detect.search.noise_floor`). Both grow
and label lattices the same way, from the same evidence; the most complete board is kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..board import Board
from ..errors import BoardMismatchError, BoardNotFoundError, InputError
from .identify import identify
from .lattice import grow_lattices
from .noise import bounding_window, estimate_noise, grey_range
from .search import find_candidates, median, search_levels

#: Bounds are grown by this fraction of their size (and 4 px) before they select seeds.
BOUNDS_SLACK = 0.1
#: Once a board is labelled, seeds are tried on for another (a second board, or the larger
#: part of one a bar splits) while their response is at least this fraction of its seed's:
#: a board of a third of the first's contrast still seeds (the response goes as contrast^2).
SECOND_BOARD_FRACTION = 0.05
#: The noise-aware search's coarsest level is at least this many pixels on its shorter side.
MIN_LEVEL_SIDE = 48
#: The noise-aware search runs when the image's noise is at least this fraction of its grey
#: range (:func:`graphpose.detect.noise.grey_range`): 2 grey levels of noise on a board's
#: black (35) to white (215) is about 0.011, real images of the course's camera 0.006.
NOISY = 0.015


@dataclass(frozen=True)
class FoundBoard:
    """A board found and labelled in an image, before sub-pixel refinement.

    What :func:`graphpose.detect.find_board` returns and :func:`graphpose.detect.refine`
    takes: the search's coarse junctions, each labelled with its board index (row-major from
    junction 0), from the image alone: no camera is needed (the labels come from the board's
    edges). Coordinates follow :mod:`graphpose.geometry`: ``(u, v)`` pixels, 0-based.

    Attributes
    ----------
    points : (2, n) ndarray of float64
        Coarse positions (u, v) of the board's n junctions, pixels, row-major (column
        ``k`` is junction ``k``); NaN where unseen. Within a pixel or two of the junctions:
        :func:`graphpose.detect.refine` makes them sub-pixel.
    seen : (n,) ndarray of bool
        Junctions on the lattice found (the others are hidden or off the image).
    step_px : (n,) ndarray of float64
        Local lattice step (pixels) at each seen junction; NaN elsewhere.
    orientation_ambiguous : bool
        True when the board's pattern is unchanged by a half (or quarter) turn and no
        bounds said which corner is junction 0 (see :class:`graphpose.detect.Junctions`).
    junction0_square : str or None
        ``"dark"`` or ``"light"``: the colour of junction 0's outer corner square (see
        :class:`graphpose.detect.Junctions`).
    board : Board or None
        The board spec searched for (n is its ``board.n``); None only for one made by hand.
    noise : float or None
        The image's pixel noise, grey units of the image as given (0-255 for 8-bit grey,
        else [0, 1] as :func:`graphpose.image.as_grey`), as the search measured it
        (:func:`graphpose.detect.estimate_noise`); the refinement's smoothing reads it.
        None when it was not measured (the refinement then measures it).
    """

    points: np.ndarray
    seen: np.ndarray
    step_px: np.ndarray
    orientation_ambiguous: bool
    junction0_square: str | None = None
    board: Board | None = None
    noise: float | None = None

    @property
    def labels(self) -> np.ndarray:
        """(m,) ndarray of int: the board indices (row-major) of the junctions seen, ascending;
        ``points[:, labels]`` are their coarse positions."""
        return np.flatnonzero(self.seen)


def find_board(image: np.ndarray, board: Board, bounds=None, *, noise: float | None = None) -> FoundBoard:
    """Find and label the board's junctions in a grey image: the search behind
    :func:`graphpose.detect.find_board` (which checks the image and bounds, and measures the
    noise), on a grey image and checked bounds.

    Parameters
    ----------
    image : (H, W) ndarray
        Grey image (uint8 or float).
    board : Board
        The board spec.
    bounds : (2, 4) ndarray, optional
        Checked outline of the board, clockwise from the corner nearest junction 0: seeds
        are taken inside it (grown by :data:`BOUNDS_SLACK`) and its first vertex fixes the
        orientation. Growth and labels come from the image, so bounds a little off change
        nothing.
    noise : float, optional
        The image's pixel noise, grey units, if already measured; else the noise-aware
        search measures it (:func:`graphpose.detect.noise.estimate_noise`) when it runs.

    Returns
    -------
    FoundBoard

    Raises
    ------
    InputError
        If the image is not 2-D, or the board has fewer than 3 junctions along a side.
    BoardNotFoundError
        No lattice of cross-junctions, none that can be labelled (the message of the
        largest says why), or two boards and no bounds to choose.
    """
    if board.cols < 3 or board.rows < 3:
        raise InputError(f"the board search needs at least 3 x 3 inner junctions (every seed is a "
                         f"junction with four neighbours), got {board.cols} x {board.rows}")
    if image.ndim != 2:
        raise InputError(f"find_board takes a grey (H, W) image, got shape {image.shape}")
    region = None if bounds is None else _grow(bounds)
    best, refusals = None, []
    # The fast path: coarsest level first (half resolution for a VGA image, an eighth for
    # 12 MP); squares too small for it (under about 6 of its pixels) hide there: then the
    # next finer level. A partial board found above half resolution may have its far,
    # small squares hidden there: the levels down to half resolution are searched too.
    searched = []
    for level in search_levels(image.shape):
        searched.append(level)
        best = _keep(best, refusals, image, board, bounds, region, level, None)
        if best is not None and (best.seen.all() or level <= 1):
            break
    if best is not None and best.seen.all():
        return _unrivalled(best, refusals, bounds)
    # The noise-aware search, where the fast path found no board or part of one in an
    # image whose noise is at least NOISY of the grey range where the board is searched for
    # (inside the bounds when given): every level from the coarsest
    # a board fits (where a large square's junction is judged at the scale of its square,
    # and block means average the noise away) to half resolution, its candidates above the
    # response's noise floor (search.noise_floor) rather than only above a fraction of the
    # strongest peaks, which noise on the board's edges raises. On cleaner images the fast
    # path has seen all there is.
    sigma = estimate_noise(image) if noise is None else float(noise)
    if sigma >= NOISY * grey_range(image if region is None else bounding_window(image, region)):
        searched = set(searched)
        for level in noise_levels(image.shape):
            best = _keep(best, refusals, image, board, bounds, region, level, sigma, level in searched)
            if best is not None and best.seen.all():
                break
    if best is None:
        # Large squares under uneven light: at the fast path's levels a large square's
        # neighbouring junctions lie far beyond the many weak candidates that texture, noise
        # and the light's falloff make around each junction, and no seed finds its cross; at
        # a coarser level the same board's squares are a few pixels, its junctions each
        # other's nearest candidates. Where nothing was found, the coarser levels the fast
        # path skipped are searched too (coarsest first, as the noise-aware search's).
        for level in coarse_levels(image.shape):
            best = _keep(best, refusals, image, board, bounds, region, level, None)
            if best is not None and best.seen.all():
                break
    if best is not None:
        return _unrivalled(best, refusals, bounds)
    raise max(refusals, key=lambda e: e.junctions_seen) from None


def coarse_levels(shape) -> list:
    """Levels coarser than the fast path's first (:func:`graphpose.detect.search.search_levels`)
    where a board of a few squares still fits (:func:`noise_levels`), coarsest first; empty for
    images too small to have any."""
    first = search_levels(shape)[0]
    return [level for level in noise_levels(shape) if level > first]


def _unrivalled(best: FoundBoard, refusals: list, bounds) -> FoundBoard:
    """``best``, unless, without bounds, a grid of another size than the spec larger than it
    was seen at any level (:func:`_rival`): then that grid's refusal."""
    if bounds is None:
        rival = _rival(refusals, _size_px(best.step_px[best.seen], int(best.seen.sum())))
        if rival is not None:
            raise rival
    return best


def _rival(refusals, size_px: float):
    """The largest :class:`graphpose.errors.BoardMismatchError` among ``refusals`` whose grid
    is larger in the image than ``size_px`` (a board's :func:`_size_px`), or None.

    A board of another size than the spec, seen whole and larger than the board that fits
    it, is what the image is of: the one that fits is a picture of a board in the
    background, a smaller pattern, or part of the larger grid (a spec too small), and its
    pose would be another board's. As with two boards, only bounds can say which is meant.
    """
    larger = [e for e in refusals if isinstance(e, BoardMismatchError) and e.size_px > size_px]
    return max(larger, key=lambda e: e.size_px) if larger else None


def _size_px(step_px, count: int) -> float:
    """A grid's size in the image, pixels: its median step times the square root of its
    junction count (as :attr:`graphpose.errors.BoardMismatchError.size_px`)."""
    return median(step_px) * float(np.sqrt(count))


def noise_levels(shape, *, side: int = MIN_LEVEL_SIDE) -> range:
    """Levels of the noise-aware search, coarsest first: from the coarsest whose image is
    at least ``side`` pixels on its shorter side (a board of a few squares of about 6 of its
    pixels fits) down to half resolution (the full image for images too small for that)."""
    short = min(shape[:2])
    coarsest = 0
    while short / 2 ** (coarsest + 1) >= side:
        coarsest += 1
    return range(coarsest, min(coarsest, 1) - 1, -1)


def _keep(best, refusals, image, board, bounds, region, level, noise, again=False):
    """The more complete of ``best`` and the board found at ``level`` (refusals noted);
    ``again``: the level was searched without the noise floor, and is searched again only
    if the floor changes its candidates."""
    try:
        found = _search(image, board, bounds, region, level, noise, again)
    except BoardNotFoundError as exc:
        if exc.two_boards:
            raise  # two boards seen at any level: only bounds can say which is meant
        refusals.append(exc)
        return best
    if found is None or (best is not None and found.seen.sum() <= best.seen.sum()):
        return best
    return found


def _search(image, board, bounds, region, level, noise=None, again=False) -> FoundBoard | None:
    """:func:`find_board` at one search level (with ``noise``, above its floor); ``again``:
    None at once when the floor leaves the candidates as they were (searched already)."""
    cands = find_candidates(image, region, level=level, noise=noise)
    if again and not cands.noise_limited:
        return None
    where = "inside the bounds" if bounds is not None else "in the image"
    if cands.seed.sum() < 1 or cands.points.shape[1] < 4:
        raise BoardNotFoundError(f"no checkerboard {where}: {int(cands.seed.sum())} junction-like points")
    labelled, refused, floor = [], [], 0.0
    for strength, lattice in grow_lattices(cands, max_nodes=8 * board.n):
        if strength < floor:
            break
        if lattice is None or any(_overlaps(lattice, other) for other, _ in labelled):
            continue
        try:
            identity = identify(lattice, cands.view, board, bounds)
        except BoardMismatchError as exc:
            refused.append(exc)  # it counts its junctions and its size itself
            continue
        except BoardNotFoundError as exc:
            refused.append(BoardNotFoundError(str(exc), junctions_seen=len(lattice.keys)))
            continue
        labelled.append((lattice, identity))
        if bounds is not None and len(lattice.keys) == board.n:
            break  # bounds pick the largest board inside them, and none is larger than whole
        floor = max(floor, SECOND_BOARD_FRACTION * strength)
    if not labelled:
        if refused:
            raise max(refused, key=lambda e: e.junctions_seen)
        raise BoardNotFoundError(f"no checkerboard {where}: {int(cands.seed.sum())} junction-like points but "
                                 "no grid of cross-junctions among them")
    labelled.sort(key=lambda li: -len(li[0].keys))
    # Bounds say which board is meant (the largest labelled inside them); without, a second
    # board of half the spec's junctions or more makes the image ambiguous.
    if bounds is None and len(labelled) > 1 and len(labelled[1][0].keys) >= board.n // 2:
        a, b = (li[0].points.mean(axis=1) for li in labelled[:2])
        raise BoardNotFoundError(f"two checkerboards in the image, around ({a[0]:.0f}, {a[1]:.0f}) and "
                                 f"({b[0]:.0f}, {b[1]:.0f}) px; give bounds to say which one",
                                 junctions_seen=board.n, two_boards=True)
    lattice, identity = labelled[0]
    if bounds is None:
        rival = _rival(refused, _size_px(lattice.step_lengths(), len(lattice.keys)))
        if rival is not None:
            raise rival
    return _found(lattice, identity, board)




def _found(lattice, identity, board) -> FoundBoard:
    points = np.full((2, board.n), np.nan)
    step = np.full(board.n, np.nan)
    points[:, identity.index] = lattice.points
    step[identity.index] = lattice.step_lengths()
    seen = np.zeros(board.n, dtype=bool)
    seen[identity.index] = True
    return FoundBoard(points, seen, step, identity.orientation_ambiguous, identity.junction0_square, board)


def _grow(bounds) -> np.ndarray:
    """Bounds pushed out from their centroid by BOUNDS_SLACK of their size plus 4 pixels."""
    P = np.asarray(bounds, dtype=float)
    centre = P.mean(axis=1, keepdims=True)
    d = P - centre
    size = np.hypot(*d)
    return centre + d * (1 + BOUNDS_SLACK + 4.0 / np.maximum(size, 1e-9))


def _overlaps(lattice, other) -> bool:
    """Does ``lattice`` lie mostly within the bounding box of ``other`` (the same board again)?"""
    lo, hi = other.points.min(axis=1), other.points.max(axis=1)
    inside = np.all((lattice.points >= lo[:, None]) & (lattice.points <= hi[:, None]), axis=0)
    return inside.mean() > 0.5

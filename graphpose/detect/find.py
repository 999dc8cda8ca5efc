"""Find the board in an image and label its junctions: candidates, lattices, identity.

:func:`find_board` searches the whole image (or, given bounds, starts inside them), grows
lattices of cross-junctions from the strongest candidates (:mod:`.lattice`), and labels
each with board indices from the evidence of its edges (:mod:`.identify`). The largest
lattice that can be labelled is the board. Without bounds, a second lattice that can be
labelled as a board of its own (half the board's junctions or more, away from the first)
makes the image ambiguous and is refused: bounds must say which board is meant.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..board import Board
from ..errors import BoardNotFoundError, InputError
from .identify import identify
from .lattice import grow_lattices, step_lengths
from .search import find_candidates, search_levels

#: Bounds are grown by this fraction of their size (and 4 px) before they select seeds.
BOUNDS_SLACK = 0.1
#: Once a board is labelled, seeds are tried on for another (a second board, or the larger
#: part of one a bar splits) while their response is at least this fraction of its seed's:
#: a board of a third of the first's contrast still seeds (the response goes as contrast^2).
SECOND_BOARD_FRACTION = 0.05


@dataclass(frozen=True)
class FoundBoard:
    """A board found and labelled, before sub-pixel refinement.

    Attributes
    ----------
    points : (2, n) ndarray of float64
        Coarse positions (u, v) of the board's junctions, row-major; NaN where unseen.
    seen : (n,) ndarray of bool
        Junctions on the lattice.
    step_px : (n,) ndarray of float64
        Local lattice step (pixels) at each seen junction; NaN elsewhere.
    orientation_ambiguous : bool
        See :class:`graphpose.detect.identify.Identity`.
    junction0_square : str or None
        ``"dark"`` or ``"light"``, see :class:`graphpose.detect.identify.Identity`.
    """

    points: np.ndarray
    seen: np.ndarray
    step_px: np.ndarray
    orientation_ambiguous: bool
    junction0_square: str | None = None


def find_board(image: np.ndarray, board: Board, bounds=None) -> FoundBoard:
    """Find and label the board's junctions in a grey image.

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
    # Coarsest level first (half resolution for a VGA image, an eighth for 12 MP); squares
    # too small for it (under about 6 of its pixels) hide there: then the next finer level.
    # A partial board found above half resolution may have its far, small squares hidden
    # there: the levels down to half resolution are searched too, the most complete kept.
    for level in search_levels(image.shape):
        try:
            found = _search(image, board, bounds, region, level)
        except BoardNotFoundError as exc:
            refusals.append(exc)
        else:
            if best is None or found.seen.sum() > best.seen.sum():
                best = found
        if best is not None and (best.seen.all() or level <= 1):
            return best
    raise max(refusals, key=lambda e: getattr(e, "junctions_seen", 0)) from None


def _search(image, board, bounds, region, level) -> FoundBoard:
    """:func:`find_board` at one search level."""
    cands = find_candidates(image, region, level=level)
    where = "inside the bounds" if bounds is not None else "in the image"
    if cands.seed.sum() < 1 or cands.points.shape[1] < 4:
        raise _refusal(f"no checkerboard {where}: {int(cands.seed.sum())} junction-like points", 0)
    labelled, refused, floor = [], [], 0.0
    for strength, lattice in grow_lattices(cands, max_nodes=8 * board.n):
        if strength < floor:
            break
        if lattice is None or any(_overlaps(lattice, other) for other, _ in labelled):
            continue
        try:
            identity = identify(lattice, cands, board, bounds)
        except BoardNotFoundError as exc:
            refused.append(_refusal(str(exc), len(lattice.keys)))
            continue
        labelled.append((lattice, identity))
        if bounds is not None and len(lattice.keys) == board.n:
            break  # bounds pick the largest board inside them, and none is larger than whole
        floor = max(floor, SECOND_BOARD_FRACTION * strength)
    if not labelled:
        if refused:
            raise max(refused, key=lambda e: e.junctions_seen)
        raise _refusal(f"no checkerboard {where}: {int(cands.seed.sum())} junction-like points but no "
                       "grid of cross-junctions among them", 0)
    labelled.sort(key=lambda li: -len(li[0].keys))
    # Bounds say which board is meant (the largest labelled inside them); without, a second
    # board of half the spec's junctions or more makes the image ambiguous.
    if bounds is None and len(labelled) > 1 and len(labelled[1][0].keys) >= board.n // 2:
        a, b = (li[0].points.mean(axis=1) for li in labelled[:2])
        raise _refusal(f"two checkerboards in the image, around ({a[0]:.0f}, {a[1]:.0f}) and "
                       f"({b[0]:.0f}, {b[1]:.0f}) px; give bounds to say which one", board.n)
    lattice, identity = labelled[0]
    return _found(lattice, identity, board)


def _refusal(message: str, seen: int) -> BoardNotFoundError:
    """A BoardNotFoundError that remembers how many junctions its lattice held (the most
    telling refusal is the one about the largest lattice)."""
    exc = BoardNotFoundError(message)
    exc.junctions_seen = seen
    return exc


def _found(lattice, identity, board) -> FoundBoard:
    nodes = lattice.as_dict()
    points = np.full((2, board.n), np.nan)
    step = np.full(board.n, np.nan)
    points[:, identity.index] = lattice.points
    step[identity.index] = step_lengths(nodes, [tuple(k) for k in lattice.keys])
    seen = np.zeros(board.n, dtype=bool)
    seen[identity.index] = True
    return FoundBoard(points, seen, step, identity.orientation_ambiguous, identity.junction0_square)


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

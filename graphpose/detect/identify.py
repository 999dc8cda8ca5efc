"""Which board junction is each lattice node: identity from evidence, or a refusal.

A board of ``cols x rows`` inner junctions is bounded on every side: beyond its outermost
line of junctions lie the outer squares, and beyond them the margin, with no further
cross-junctions. For each of the lattice's four sides this module samples, on the search's
smoothed image, the outer band (a quarter of a square beyond the last line of
nodes, inside the outer squares even where a printer cut them short) and the band beyond
it (1.3 and 1.6 squares out). The side is

- an ``"edge"`` when the outer band alternates dark and light in step with the lattice's
  squares and the band beyond does not (a margin, a table, the wall);
- ``"continues"`` when both bands alternate: the board goes on there, its junctions
  unseen (blurred, or cut by the image edge);
- ``"unknown"`` when the outer band does not alternate (covered, off the image), too
  few samples fall inside the image, or the squares alternate again two or three
  squares out (the plain band was something lying across the board, not its edge).

Labels follow from the edges. Along each board axis the lattice's extent must equal the
board's count when both edges are seen, may be smaller when one is (the labels count from
that edge; the junctions beyond the seen part are not seen), and cannot be fixed when
neither is. The lattice maps to the board by one of four rotations (the keys are right-
handed, as the board seen from its front); each rotation whose extents and edges fit is a
candidate labelling.

Orientation (stated in ``docs/conventions.md`` too): junction 0's outer corner square is
dark. A board whose pattern is unchanged by a half turn (``cols + rows`` even) or by a
quarter turn (square boards with ``cols`` even) cannot be oriented from the image alone.
When all four corner squares share one colour (``cols`` and ``rows`` both even) the
colours are not checked at all (a board printed with light corners is found as well);
otherwise, without bounds, only labellings that put a dark corner square at junction 0 are
kept (on a square board with ``cols`` odd, that rules out the quarter turns). Labellings
that differ only by such a symmetry are the same physical ambiguity: without bounds the one
whose junction 0 lies nearest the image's upper-left corner is chosen and
``orientation_ambiguous`` is set. With bounds, the bounds' first vertex names junction 0's
corner whatever the colours say (the user's convention, e.g. the corner nearest the image's
upper left): the colour rule orders boards found without bounds only, and
``Identity.junction0_square`` says which colour junction 0's outer corner square has, so that
two images naming different physical corners can be told apart. Bounds a quarter turn off
(their first edge along a column of a board that is not square) are refused, and so are
labellings that differ otherwise (a small corner of a board could be any corner) without
bounds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..board import Board
from ..errors import BoardMismatchError, BoardNotFoundError
from . import _identify, _lattice
from .grid import fit_homography
from .lattice import MIN_SCORE, PARITY_COS, RING_FRACTION, KeyGrid, Lattice, _step_lengths
from .search import SearchImage, median

#: Proper rotations M of lattice keys to board (c, r) = M (i, j) + t.
ROTATIONS = (np.array([[1, 0], [0, 1]]), np.array([[0, -1], [1, 0]]),
             np.array([[-1, 0], [0, -1]]), np.array([[0, 1], [-1, 0]]))
#: Depth of the outer-band samples beyond the last line of nodes, squares.
OUTER_DEPTH = 0.25
#: Depths of the beyond-band samples, squares: the band where the next squares would be.
BEYOND_DEPTHS = (1.15, 1.3, 1.45, 1.6, 1.75, 1.9)
#: Depths farther out where a board hidden behind a bar would show its squares again.
RESUME_DEPTHS = (2.15, 2.45, 2.75, 3.15, 3.45, 3.75)
#: The outer band alternates when its agreement with the lattice's colours exceeds this.
ALTERNATES = 0.5
#: The band beyond is plain when its agreement is below this.
PLAIN = 0.35
#: A partly seen board is labelled only when its lattice step is at least this (pixels):
#: on smaller squares the edge evidence, a fraction of a square away, blurs into them.
MIN_PARTIAL_STEP_PX = 12.0
#: Fraction of the lattice's lines that must reach a side for it to be an edge.
FLAT_SIDE = 0.75
#: A side the labels put on the board's border, not seen as its edge, goes on (the grid is
#: part of a larger one) when at least this fraction of the next line's junctions, predicted
#: beyond it, pass the lattice's ring test with the parity their keys demand (at least two).
CONTINUES_FRACTION = 0.5
#: Sides, as (lattice axis, direction).
SIDES = ((0, -1), (0, 1), (1, -1), (1, 1))
#: Every depth a side is sampled at, in squares outwards from it.
_DEPTHS = np.array((OUTER_DEPTH,) + BEYOND_DEPTHS + RESUME_DEPTHS)
#: The square each depth lies in (0 the outer band's).
_DEPTH_SQUARES = np.floor(_DEPTHS).astype(np.int64)
#: The compiled verdicts' names.
_VERDICTS = {_identify.UNKNOWN: "unknown", _identify.CONTINUES: "continues", _identify.EDGE: "edge"}


@dataclass(frozen=True)
class Identity:
    """The board labels of a lattice.

    Attributes
    ----------
    index : (M,) ndarray of int
        Row-major board index ``cols * r + c`` of each lattice node, in lattice order.
    rotation : (2, 2) ndarray of int
        ``M`` of ``(c, r) = M (i, j) + offset``.
    offset : (2,) ndarray of int
    orientation_ambiguous : bool
        True when the labelling was chosen among labellings the board's symmetry makes
        indistinguishable, by the rule that junction 0 is the one nearest the image's
        upper-left corner.
    sides : dict
        Evidence per lattice side ``(axis, direction)``: ``"edge"``, ``"continues"`` or
        ``"unknown"``.
    junction0_square : str
        ``"dark"`` or ``"light"``: the colour, measured in the image, of junction 0's outer
        corner square (the board's corner square diagonally beyond junction 0 from its
        neighbours). Dark under the colour rule; light when bounds named the other corner.
    """

    index: np.ndarray
    rotation: np.ndarray
    offset: np.ndarray
    orientation_ambiguous: bool
    sides: dict
    junction0_square: str


def identify(lattice: Lattice, view: SearchImage, board: Board, bounds=None) -> Identity:
    """Label a lattice with board junction indices, or refuse.

    Parameters
    ----------
    lattice : Lattice
        Grown by :func:`graphpose.detect.lattice.grow_lattices`.
    view : SearchImage
        The images the lattice's candidates were found in (:attr:`Candidates.view
        <graphpose.detect.search.Candidates>`): the evidence is sampled there.
    board : Board
        The spec: ``cols x rows`` inner junctions.
    bounds : (2, 4) ndarray, optional
        The board's outline, clockwise from the corner nearest junction 0, its first edge
        along a row: it names junction 0's corner among the labellings the board's edges
        allow, whatever the square colours say.

    Returns
    -------
    Identity

    Raises
    ------
    BoardNotFoundError
        If the lattice is larger than the board, a board of another size is seen whole,
        the edges that would fix the labels are hidden, the visible part fits several
        places on the board, or the bounds do not run round the board from a corner with
        their first edge along a row (a quarter turn off, or another corner order). The
        message says which.
    """
    keys = np.ascontiguousarray(lattice.keys, dtype=np.int64)  # as the kernels read them
    grid = KeyGrid.of(keys, lattice.points)
    step = float(median(_step_lengths(grid, keys)))  # lattice.step_lengths(), on the grid made here
    if len(lattice.keys) < board.n and step < MIN_PARTIAL_STEP_PX:
        raise BoardNotFoundError(
            f"only part of the board is seen ({len(lattice.keys)} of {board.n} junctions) and its squares "
            f"({step:.0f} px) are too small to tell its edges from something lying across it")
    dark_parity, light = _square_colours(view, grid, keys)
    sides = {side: _side(view, grid, keys, side, dark_parity, light) for side in SIDES}
    lo, hi = keys.min(axis=0), keys.max(axis=0)
    extent = hi - lo + 1
    # Junction 0's outer corner square is dark. When the four corner squares share one
    # colour (cols and rows both even), colours cannot tell the corners apart and are not
    # checked, so a board printed with light corners is found as well. Bounds name junction
    # 0's corner themselves, whatever its colour.
    same_corners = board.cols % 2 == 0 and board.rows % 2 == 0
    found, reasons = [], []
    for M in ROTATIONS:
        t, why = _fit_rotation(M, lo, hi, extent, sides, board)
        if why is not None:
            reasons.append((M, *why))
            continue
        if bounds is None and not same_corners and not _colours_agree(M, t, keys[0], dark_parity):
            reasons.append((M, "colour", None))
            continue
        found.append((M, t))
    if not found:
        message, seen_board = _refusal(reasons, extent, board, sides)
        if seen_board is None:
            raise BoardNotFoundError(message)
        raise BoardMismatchError(message, found=seen_board, size_px=step * np.sqrt(len(keys)),
                                 junctions_seen=len(keys))
    # The growth's fit when it made one (the same fit of the same nodes), else fitted here
    # (collinear nodes: the fit's own refusal).
    H = lattice.homography if lattice.homography is not None else fit_homography(keys.T.astype(float), lattice.points)
    if bounds is not None:
        M, t = min(found, key=lambda f: _bounds_mismatch(f, H, board, bounds))
        _check_bounds_order((M, t), H, board, bounds)
        _check_bounds_fit((M, t), found, H, board, bounds, extent)
        if len(keys) < board.n:  # a part: its labels rest on the edges its sides show
            _check_bounds_enclose((M, t), H, board, bounds, extent)
        ambiguous = False
    else:
        if len(found) > 1 and not all(_symmetric_pair(found[0], f, board) for f in found[1:]):
            raise BoardNotFoundError(
                f"the visible part of the board ({extent[0]} x {extent[1]} junctions) fits "
                f"{len(found)} places on the {board.cols} x {board.rows} board; give the bounds "
                "or show more of the board (two opposite edges of each axis)")
        M, t = min(found, key=lambda f: _corner_distance(f, H, board))
        ambiguous = len(found) > 1
    _check_border(lattice, view, grid, keys, H, M, t, sides, board, step)
    cr = keys @ M.T + t
    return Identity(cr[:, 1] * board.cols + cr[:, 0], M, t, ambiguous, sides, _junction0_square(M, t, dark_parity))


# ------------------------------------------------------------------------------ evidence


def _square_colours(view, grid, keys):
    """(dark parity of ``i + j`` of a square's upper-left key, the board's light), from the
    squares whose four nodes (``keys`` (M, 2), C-contiguous int64, on their :class:`KeyGrid`)
    are seen: the light is a :class:`_Light`, the board's mid grey and dark-light contrast
    (fitted across the board where they vary, :func:`_fit_light`)."""
    # Each key as a square's upper-left corner: its node, the next along i, along j, and both;
    # the squares with all four seen, their centres, first sides and parities in one compiled
    # call (``_identify.whole_squares``).
    n = len(keys)
    centres, steps, parity = np.empty((2, n)), np.empty(n), np.empty(n, dtype=np.int64)
    m = _identify.whole_squares(grid.array, int(grid.origin[0]), int(grid.origin[1]),
                                keys, centres, steps, parity)
    if m == 0:
        raise BoardNotFoundError("the junctions found enclose no whole square of the board")
    centres, parity = centres[:, :m], parity[:m]
    step = median(steps[:m])
    value = _grey(view, centres, step)
    even = median(value[parity == 0]) if np.any(parity == 0) else np.nan
    odd = median(value[parity == 1]) if np.any(parity == 1) else np.nan
    if not np.isfinite(even):
        even = 2 * np.mean(value) - odd
    if not np.isfinite(odd):
        odd = 2 * np.mean(value) - even
    dark_parity = 0 if even < odd else 1
    flat = _Light(0.5 * (even + odd), max(abs(odd - even), 1e-12))
    return dark_parity, _fit_light(centres, value, np.where(parity == dark_parity, -1.0, 1.0), step, flat)


#: The board's light is taken as even (one mid grey and contrast for all of it) unless its
#: contrast, fitted across the board, falls below this fraction of its largest over the whole
#: squares: a lamp to one side, vignetting. Under such light the far squares' light grey can
#: fall below the near ones' mid grey, and a side's outer band would not seem to alternate.
EVEN_LIGHT = 0.6


@dataclass(frozen=True)
class _Light:
    """The board's grey at a point: ``mid + s contrast / 2`` (s = +1 on a light square, -1 on
    a dark one), each of ``mid`` and ``contrast`` a constant or, with ``slope``, affine in the
    image position (u, v) about ``centre``, scaled by ``step``; contrast no smaller than
    ``floor`` (never extrapolated below the darkest square's)."""

    mid: float
    contrast: float
    slope: np.ndarray | None = None  # (2, 2): rows mid, contrast; columns du, dv (per step)
    centre: np.ndarray | None = None
    step: float = 1.0
    floor: float = 1e-12

    def at(self, points) -> tuple:
        """(mid, contrast) at ``points`` (2, ...)."""
        if self.slope is None:
            return self.mid, self.contrast
        d = (np.asarray(points, dtype=float) - self.centre.reshape((2,) + (1,) * (np.ndim(points) - 1))) / self.step
        mid = self.mid + self.slope[0, 0] * d[0] + self.slope[0, 1] * d[1]
        contrast = self.contrast + self.slope[1, 0] * d[0] + self.slope[1, 1] * d[1]
        return mid, np.maximum(contrast, self.floor)


def _fit_light(centres, value, sign, step, flat) -> _Light:
    """The board's light from its whole squares' centres (2, m), grey levels (m,) and colours
    (``sign`` +1 light, -1 dark): ``flat`` (one mid grey and contrast) where the light is even
    (:data:`EVEN_LIGHT`), else the mid grey and the contrast each affine in the position."""
    m = value.size
    if m < 8 or np.sum(sign > 0) < 3 or np.sum(sign < 0) < 3:
        return flat
    centre = centres.mean(axis=1)
    d = (centres - centre[:, None]) / step
    A = np.column_stack([np.ones(m), d[0], d[1], 0.5 * sign, 0.5 * sign * d[0], 0.5 * sign * d[1]])
    coef, _, rank, _ = np.linalg.lstsq(A, value, rcond=None)
    if rank < 6:
        return flat
    contrast = coef[3] + coef[4] * d[0] + coef[5] * d[1]
    if contrast.min() <= 0 or contrast.min() >= EVEN_LIGHT * contrast.max():
        return flat
    return _Light(float(coef[0]), float(coef[3]), np.array([[coef[1], coef[2]], [coef[4], coef[5]]]), centre,
                  float(step), float(contrast.min()))


def _side(view, grid, keys, side, dark_parity, light) -> str:
    """Evidence on one lattice side (see the module docstring); ``keys`` (M, 2) C-contiguous
    int64, as :func:`identify` makes them for the kernels.

    Along the side, every outer square is sampled once (it must have the colour the
    lattice's parity gives it), and every square beyond it at several depths. Beyond the
    outer band, pairs of neighbouring rows are compared: where the board goes on, their
    darkness differs as the pattern says; on a plain margin, a uniform table or a bar lying
    across, it does not. Pairs, not single rows, so that a uniform dark or light ground
    cannot look like half a pattern; the verdict needs every pair to be plain, so that an
    occluder across part of the side cannot hide the rows where the board goes on.
    """
    axis, direction = side
    depths = _DEPTHS
    # An edge is a straight line of junctions: most lattice lines must reach it (a row that
    # stops short has its end hidden, and the side beyond says nothing of the board's edge).
    # Along the side, the outer band's squares (the two nodes on the side, then the two
    # inwards) whose four nodes are seen give a row each: its key across the side, whether
    # its outer square is dark (its upper-left key's parity is the dark parity), one square
    # outwards, and the points at the depths beyond the side. One compiled call
    # (``_identify.side_geometry``).
    n = len(keys)
    P, rows, expect, steps = np.empty((n, 2, depths.size)), np.empty(n, np.int64), np.empty(n), np.empty(n)
    m = _identify.side_geometry(grid.array, int(grid.origin[0]), int(grid.origin[1]),
                                keys, axis, direction, depths, FLAT_SIDE,
                                int(dark_parity), P, rows, expect, steps)
    if m < 2:
        return "unknown"
    P, rows, expect, steps = P[:m], rows[:m], expect[:m], steps[:m]
    height, width = view.shape
    points = P.transpose(1, 0, 2).reshape(2, -1)
    value = _grey(view, points, median(steps)).reshape(m, depths.size)
    if light.slope is not None:
        # Under uneven light each sample is judged against the board's light where it lies:
        # its grey in units of half the local contrast about the local mid grey.
        mid, contrast = (x.reshape(m, depths.size) for x in light.at(points))
        value = (value - mid) / (0.5 * contrast)
        light = _Light(0.0, 2.0)
    # Each sample as +1 for the dark squares' grey, -1 for the light ones' (NaN outside the
    # image); the outer band must alternate with the lattice's colours. Square k beyond the
    # outer one has the outer square's colour times (-1)^k: pairs of neighbouring rows on
    # the side differ in darkness by the pattern where the board goes on, and a pair speaks
    # of square k where two of its depths there lie in the image. An edge is plain across
    # the square beyond it (one pair in four may catch clutter), and the squares do not come
    # back farther out (a bar or a fold lying across the board would show them again, along
    # much of the side). It is plain at each depth of the square beyond too, not only on
    # average over it: a bar narrower than a square lying along the line of junctions beyond
    # the lattice hides that line, and the board's next squares show on one side of it within
    # the square beyond (before the bar, or past it). At each depth, the pairs of neighbouring
    # rows whose darkness differs as the pattern says stay under :data:`PLAIN` on average (a
    # bar lies along the whole side; a real edge's clutter catches a pair or two). One
    # compiled call (``_identify.side_verdict``).
    verdict = _identify.side_verdict(P, value, expect, rows, _DEPTH_SQUARES, float(width), float(height),
                                     float(light.mid), float(light.contrast), ALTERNATES, PLAIN)
    return _VERDICTS[verdict]


def _grey(view, points, step) -> np.ndarray:
    """Grey levels at full-image points: from the search's smoothed image where squares are
    large (its smoothing is then a small part of a square), else from the full image over a
    few pixels (its smoothing would blur a small square into its neighbours)."""
    if step >= 24 * 2 ** (view.level - 1):
        return view.sample(points)
    return view.sample_fine(points, reach=max(0.5, 0.08 * step))


# ----------------------------------------------------------------------------- labelling


def _check_border(lattice, view, grid, keys, H, M, t, sides, board, step) -> None:
    """Refuse a labelling whose board border the image shows the grid going on across.

    A side of the lattice that the labels put on the board's border (its outermost line of
    junctions) is looked at again. Where it was not seen as an edge and its bands alternate
    on (``"continues"``), or the next line of junctions beyond it is there (predicted along
    the lattice lines, :data:`CONTINUES_FRACTION` of them passing the ring test,
    :func:`graphpose.detect.search.ring_test`), the grid is part of a larger one: a bigger
    board, or a spec too small (:class:`graphpose.errors.BoardMismatchError`). Where, on any
    border side, an edge included, junctions of the lattice come back two to
    :data:`BEYOND_LINES` lines out (through the lattice's homography ``H``), something lies
    across the board there and the border is not its edge: the labels cannot be fixed.
    Sides inside the board (the labels count from the opposite edge) may go on, as a partly
    seen board's do.
    """
    lo, hi = keys.min(axis=0), keys.max(axis=0)
    counts = (board.cols, board.rows)
    for axis, direction in SIDES:
        verdict = sides[(axis, direction)]
        row = 0 if M[0, axis] != 0 else 1  # the board axis the lattice axis runs along
        line = hi[axis] if direction > 0 else lo[axis]
        beyond = int(M[row, axis]) * (line + direction) + int(t[row])
        if 0 <= beyond < counts[row]:
            continue  # the board goes on there under these labels
        if verdict != "edge" and (verdict == "continues"
                                  or _line_continues(lattice, view, grid, keys, axis, direction, line, step)):
            extent = hi - lo + 1
            grown = [int(extent[0 if M[k, 0] != 0 else 1]) for k in (0, 1)]
            grown[row] += 1
            raise BoardMismatchError(
                f"found a grid of at least {grown[0]} x {grown[1]} junctions: it goes on beyond the edge of "
                f"the {board.cols} x {board.rows} board spec (a bigger board, or the spec is wrong)",
                found=grown, size_px=step * np.sqrt(len(keys)), junctions_seen=len(keys))
        out = _line_returns(lattice, view, H, keys, axis, line, direction)
        if out:
            raise BoardNotFoundError(
                f"the junctions seen ({hi[0] - lo[0] + 1} x {hi[1] - lo[1] + 1}) end at a line that the "
                f"board's junctions come back beyond, {out} squares out: something lies across the board "
                "there, and its labels cannot be fixed; show the board unobstructed, or more of it")


#: Lines of junctions beyond a border side looked at for the board coming back past something
#: lying across it (:func:`_check_border`).
BEYOND_LINES = 4


def _line_returns(lattice, view, H, keys, axis, line, direction) -> int:
    """The first ``out`` in 2 .. :data:`BEYOND_LINES` at which two neighbouring keys of line
    ``line + out direction`` (parallel to the lattice's ``line`` along ``axis``, over the same
    span) pass the ring test at their positions through ``H``, with the parity their keys
    demand; 0 where none does. One compiled call (``_identify.line_returns``)."""
    height, width = view.shape
    return _identify.line_returns(view.smooth, int(view.level), float(width), float(height),
                                  np.ascontiguousarray(H, dtype=float), keys, int(axis), int(line), int(direction),
                                  2, BEYOND_LINES, float(lattice.theta0), RING_FRACTION, MIN_SCORE, PARITY_COS)


def _line_continues(lattice, view, grid, keys, axis, direction, line, step) -> bool:
    """Do the junctions of the line of keys beyond ``line`` (on side ``(axis, direction)``)
    pass the ring test at their predicted positions, as :data:`CONTINUES_FRACTION` of the
    predictions inside the image (and at least two) must?"""
    on = keys[keys[:, axis] == line]
    points, parity, steps = [], [], []
    for key in on:
        nxt = key.copy()
        nxt[axis] += direction
        guess = _lattice.predict_one(grid.array, int(grid.origin[0]), int(grid.origin[1]), int(nxt[0]), int(nxt[1]))
        if guess is not None:
            points.append(guess[0])
            steps.append(guess[1])
            parity.append(int(nxt[0] + nxt[1]) % 2)
    if len(points) < 2:
        return False
    P = np.array(points, dtype=float).T
    height, width = view.shape
    margin = RING_FRACTION * step + 1.0
    inside = (P[0] >= margin) & (P[1] >= margin) & (P[0] <= width - 1 - margin) & (P[1] <= height - 1 - margin)
    if inside.sum() < 2:
        return False
    score, theta, _ = view.ring_test(P[:, inside], RING_FRACTION * np.array(steps)[inside])
    turn = np.cos(2 * (theta - lattice.theta0))
    parity = np.array(parity)[inside]
    passed = (score > MIN_SCORE) & np.where(parity == 0, turn > PARITY_COS, turn < -PARITY_COS)
    return passed.sum() >= 2 and passed.mean() >= CONTINUES_FRACTION


def _fit_rotation(M, lo, hi, extent, sides, board):
    """Offset t of ``(c, r) = M (i, j) + t`` that the edges fix, or the reason there is none.

    Returns ``(t, None)``, t an int (2,) array, or ``(None, (reason, row))``.
    """
    t = np.zeros(2, dtype=int)
    axes = [0 if M[row, 0] != 0 else 1 for row in (0, 1)]
    counts = (board.cols, board.rows)
    for row in (0, 1):
        if extent[axes[row]] > counts[row]:
            return None, ("too large", row)
    for row in (0, 1):
        axis, count = axes[row], counts[row]
        sign = int(M[row, axis])
        low_side, high_side = (axis, -sign), (axis, sign)  # board coordinate -1 and count
        low_edge, high_edge = sides[low_side] == "edge", sides[high_side] == "edge"
        if low_edge and high_edge and extent[axis] != count:
            return None, ("size", row)
        low_key = lo[axis] if sign > 0 else hi[axis]
        high_key = hi[axis] if sign > 0 else lo[axis]
        if low_edge:
            t[row] = -sign * low_key
        elif high_edge:
            t[row] = count - 1 - sign * high_key
        else:
            return None, ("hidden", row)
    return t, None


def _colours_agree(M, t, key, dark_parity) -> bool:
    """Does the lattice square at ``key`` have the colour the board has there?"""
    i, j = key
    c, r = np.floor(M @ np.array([i + 0.5, j + 0.5]) + t).astype(int)
    return ((i + j) % 2 == dark_parity) == ((c + r) % 2 == 0)


def _junction0_square(M, t, dark_parity) -> str:
    """Colour of junction 0's outer corner square (board square (-1, -1) to (0, 0)) under a labelling."""
    i, j = np.floor(M.T @ (np.array([-0.5, -0.5]) - t)).astype(int)  # its upper-left lattice key
    return "dark" if (i + j) % 2 == dark_parity else "light"


def _symmetric_pair(a, b, board) -> bool:
    """Do labellings a and b differ by a symmetry of the board (a rotation onto itself)?"""
    (Ma, ta), (Mb, tb) = a, b
    # The map is affine (board -> lattice (a) -> board (b)): every junction lands on the board
    # when its four corner junctions do (the board's box holds the image of its corners' hull).
    cr = np.array([[0, board.cols - 1, board.cols - 1, 0], [0, 0, board.rows - 1, board.rows - 1]])
    mapped = Mb @ (Ma.T @ (cr - ta[:, None])) + tb[:, None]
    return bool(np.all((mapped[0] >= 0) & (mapped[0] < board.cols) & (mapped[1] >= 0) & (mapped[1] < board.rows)))


def _corners_in_image(fit, H, board):
    """Image positions (2, 4) of junctions 0, cols-1, n-1 and (rows-1) cols under a labelling."""
    M, t = fit
    cr = np.array([[0, board.cols - 1, board.cols - 1, 0], [0, 0, board.rows - 1, board.rows - 1]])
    ij = M.T @ (cr - t[:, None])
    q = H @ np.vstack([ij, np.ones(4)])
    return q[:2] / q[2]


def _corner_distance(fit, H, board) -> float:
    """Distance of junction 0 from the image's upper-left corner under a labelling."""
    return float(np.hypot(*_corners_in_image(fit, H, board)[:, 0]))


def _bounds_mismatch(fit, H, board, bounds) -> float:
    """Sum of distances between the bounds' vertices and the board's corner junctions."""
    return float(np.sum(np.hypot(*(_corners_in_image(fit, H, board) - np.asarray(bounds, dtype=float)))))


def _check_bounds_order(fit, H, board, bounds) -> None:
    """Refuse bounds whose vertices do not run round the board from junction 0's corner.

    Each vertex must lie nearer its own corner junction (0, cols - 1, n - 1, (rows - 1)
    cols, in that order) than any other: bounds started a corner late (a quarter turn off,
    said so on a board that is not square), or drawn round one corner of the board, would
    otherwise name the wrong corner junction 0.
    """
    corners = _corners_in_image(fit, H, board)
    P = np.asarray(bounds, dtype=float)
    nearest = np.argmin(np.hypot(P[0][:, None] - corners[0][None], P[1][:, None] - corners[1][None]), axis=1).tolist()
    if board.cols != board.rows and nearest in ([3, 0, 1, 2], [1, 2, 3, 0]):  # a quarter turn either way
        raise BoardNotFoundError(
            f"the bounds do not outline the board found: they are a quarter turn off (their first edge "
            f"runs along a column of the {board.cols} x {board.rows} board); start them at junction 0's "
            f"corner with the first edge along a row ({board.cols} junctions)")
    if nearest != [0, 1, 2, 3]:
        k = next(k for k in range(4) if nearest[k] != k)
        raise BoardNotFoundError(
            f"the bounds do not outline the board found: their vertex {k} lies nearest the board's "
            f"corner {int(nearest[k])}; give the board's outline clockwise from the corner nearest "
            "junction 0, its first edge along a row")


def _check_bounds_fit(fit, found, H, board, bounds, extent) -> None:
    """Refuse bounds that choose between labellings the visible part cannot tell apart, unless
    they outline the board under the chosen one and under no other.

    Where the visible part of a board fits several labellings that no symmetry of the grid
    relates (a quarter turn of a board that is not square, a shift), the bounds alone choose.
    Bounds started at the wrong corner (rolled by a vertex) then choose a labelling a quarter
    turn off, and a pose 90 degrees off would follow. So the bounds must outline the board
    under the chosen labelling (:func:`_outlines`), and not under any other: else the
    refusal says to show more of the board or to start the bounds at junction 0's corner.
    """
    others = [f for f in found if f is not fit and not _symmetric_pair(fit, f, board)]
    if not others:
        return
    if _outlines(fit, H, board, bounds) and not any(_outlines(f, H, board, bounds) for f in others):
        return
    raise BoardNotFoundError(
        f"the visible part of the board ({extent[0]} x {extent[1]} junctions) fits {len(others) + 1} places "
        f"on the {board.cols} x {board.rows} board, and the bounds do not outline it under one of them alone "
        "(are they started at junction 0's corner, their first edge along a row?); show more of the board "
        "(two opposite edges of each axis)")


#: Bounds given with a partly seen board may cut into the board the labels place by at most this
#: (squares, on either board axis, at any vertex): bounds round the board, however rough, leave
#: every junction inside; a vertex a whole line of junctions inside says the labels are wrong.
_ENCLOSE_INSIDE = -1.0


def _check_bounds_enclose(fit, H, board, bounds, extent) -> None:
    """Refuse the labels of a partly seen board when the bounds leave out junctions they place.

    The labels of a part of a board come from the edges its sides show. Something bright or
    plain beside the part (a specular highlight over the rest of the board, a bar) can pass
    for the board's margin, and would put the part at the board's corner. The bounds, given
    round the whole board, are a check independent of that evidence: under the right labels
    every corner junction lies inside them (within :data:`_ENCLOSE_INSIDE`).
    """
    excess = _bounds_excess(fit, H, board, bounds)
    if excess is None:
        return  # a vertex beyond the part's horizon: the homography says nothing there
    out_c, out_r = excess
    worst = min(out_c.min(), out_r.min())
    if worst < _ENCLOSE_INSIDE:
        raise BoardNotFoundError(
            f"the part of the board seen ({extent[0]} x {extent[1]} junctions) and the bounds disagree: "
            f"labelled from the edges its sides show, the board would reach {-worst:.1f} squares beyond "
            "the bounds (something bright or plain beside the part, such as a highlight, may pass for "
            "the board's margin); show more of the board")


#: Bounds outline a board under a labelling when each vertex lies beyond its corner junction by
#: more than this (squares, on both board axes: bounds clicked on the corner junctions pass) ...
_OUTLINE_INSIDE = -0.5
#: ... and the bounds' margins on opposite sides differ by at most this (squares): a quarter turn of a
#: board one junction longer than wide makes them differ by one square; a loose outline (a few
#: pixels) or one clicked inside the margin, by less than half a square.
_OUTLINE_SKEW = 0.75


def _bounds_excess(fit, H, board, bounds):
    """How far each vertex of ``bounds`` lies beyond its corner junction under labelling ``fit``,
    in squares through the lattice's homography ``H``: ``(out_c, out_r)``, each (4,), along the
    board's c and r axes (negative: inside the board); None when a vertex lies beyond the
    homography's horizon."""
    M, t = fit
    q = np.linalg.solve(H, np.vstack([np.asarray(bounds, dtype=float), np.ones(4)]))
    if np.any(q[2] * np.sign(q[2, 0]) <= 0):
        return None
    c, r = M @ (q[:2] / q[2]) + t[:, None]
    right, low = board.cols - 1, board.rows - 1
    return (np.array([-c[0], c[1] - right, c[2] - right, -c[3]]),
            np.array([-r[0], -r[1], r[2] - low, r[3] - low]))


def _outlines(fit, H, board, bounds) -> bool:
    """Do ``bounds`` outline the board under labelling ``fit``: in board coordinates (squares,
    through the lattice's homography ``H``), each vertex beyond its corner junction on both
    axes, by margins that agree on opposite sides (a margin of the sheet is about even)?"""
    excess = _bounds_excess(fit, H, board, bounds)
    if excess is None:  # a vertex beyond the board's horizon
        return False
    out_c, out_r = excess
    if min(out_c.min(), out_r.min()) <= _OUTLINE_INSIDE:
        return False
    skew_c = abs((out_c[0] + out_c[3]) - (out_c[1] + out_c[2])) / 2
    skew_r = abs((out_r[0] + out_r[1]) - (out_r[2] + out_r[3])) / 2
    return max(skew_c, skew_r) <= _OUTLINE_SKEW


def _refusal(reasons, extent, board, sides) -> tuple:
    """The most telling reason no rotation fits, in words, and the board seen ``(cols, rows)``
    in the spec's orientation where the reason is a board (or a grid) of another size (else
    None).

    ``reasons`` holds ``(M, kind, board axis)`` per rotation: a lattice larger than the
    board along an axis (``"too large"``), edges seen on both sides of an axis at the wrong
    distance (``"size"``), no edge seen on either side (``"hidden"``) or square colours
    that do not fit (``"colour"``).
    """
    spec = f"{board.cols} x {board.rows}"
    a, b = int(extent[0]), int(extent[1])
    if (a > b) != (board.cols > board.rows):
        a, b = b, a  # say it in the spec's orientation
    if all(sides[s] == "edge" for s in SIDES):
        return f"found a {a} x {b} board of junctions; the board spec says {spec}", (a, b)
    fitting = [r for r in reasons if r[1] != "too large"]
    if not fitting:
        return (f"found a grid of {a} x {b} junctions, larger than the {spec} board spec "
                "(a bigger board, or the spec is wrong)"), (a, b)
    for kind in ("size", "hidden", "colour"):
        hit = [r for r in fitting if r[1] == kind]
        if not hit:
            continue
        def along(r):  # the lattice's extents along the board's c and r under rotation r[0]
            return [int(extent[0 if r[0][k, 0] != 0 else 1]) for k in (0, 1)]

        M, _, row = min(hit, key=lambda r: abs(along(r)[0] - board.cols) + abs(along(r)[1] - board.rows))
        along = along((M,))
        if kind == "size":
            return (f"found a board of {along[0]} x {along[1]} junctions between its edges; "
                    f"the board spec says {spec}"), (along[0], along[1])
        if kind == "hidden":
            name = "columns" if row == 0 else "rows"
            return (f"two opposite edges of the board are hidden: its {name} cannot be labelled "
                    f"({along[0]} x {along[1]} junctions seen)"), None
        return "the board's square colours do not fit the spec's pattern at any orientation", None
    return f"the junctions seen cannot be placed on the {spec} board", None

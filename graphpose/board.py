"""The checkerboard target: its grid of inner cross-junctions and their target-frame points.

The target frame is stated in :mod:`graphpose.geometry`. Junction ``j = cols * r + c``
(row-major from the upper left) lies at ``(square_m * c, square_m * r, 0)``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from ._checks import as_float_array, as_points, check_count, check_number
from .errors import InputError


@dataclass(frozen=True)
class Board:
    """A planar checkerboard described by its inner cross-junctions.

    Parameters
    ----------
    cols : int
        Junctions along a row (the target's x axis); 8 by default.
    rows : int
        Junctions along a column (the target's y axis); 6 by default.
    square_m : float
        Side of one square in metres; 0.0635 by default. Over :data:`MAX_SQUARE_M` (1 m) it is
        refused as a length in millimetres typed as metres ("did you mean 25 mm (0.025)?"),
        unless ``allow_large``.
    allow_large : bool, keyword
        Accept squares over 1 m (a board painted on a wall or a floor). Not part of the board's
        identity: it compares, hashes and prints as the board without it.

    Raises
    ------
    InputError
        If ``cols`` or ``rows`` is not an integer >= 2, ``square_m`` not a finite number > 0,
        or over 1 m without ``allow_large``.
    """

    cols: int = 8
    rows: int = 6
    square_m: float = 0.0635
    allow_large: bool = field(default=False, compare=False, repr=False, kw_only=True)

    def __post_init__(self):
        for name in ("cols", "rows"):
            check_count(f"Board {name}", getattr(self, name), 2)
        check_number("Board square_m (metres)", self.square_m, 0.0, strict=True)
        if self.square_m > MAX_SQUARE_M and not self.allow_large:
            raise InputError(f"Board square_m is {self.square_m:g} m, over {MAX_SQUARE_M:g} m: "
                             f"{millimetre_hint(self.square_m)} (for squares over {MAX_SQUARE_M:g} m "
                             f"give Board(..., allow_large=True))")

    @property
    def n(self) -> int:
        """Number of junctions, ``cols * rows``."""
        return self.cols * self.rows

    def world_points(self) -> np.ndarray:
        """Junction positions in the target frame.

        Returns
        -------
        Wpts : (3, n) ndarray of float64
            Metres, row-major from the upper-left junction; z = 0.
        """
        r, c = np.divmod(np.arange(self.n), self.cols)
        return np.vstack([c * self.square_m, r * self.square_m, np.zeros(self.n)])

    def sheet_corners(self, margin=0.5) -> np.ndarray:
        """Corners of the white sheet that carries the squares, in the target frame.

        The squares cover ``[-s, cols * s] x [-s, rows * s]`` (``s = square_m``): one square
        beyond the outer junctions on every side. The sheet adds a white border of ``margin``
        squares to that.

        Parameters
        ----------
        margin : float or (4,) array_like
            Width of the white border in squares (>= 0): one value for all corners, or one
            per corner in the order returned.

        Returns
        -------
        corners : (3, 4) ndarray of float64
            Metres, z = 0; upper-left, upper-right, lower-right, lower-left (clockwise in an
            image of the board's front, starting with the corner nearest junction 0).

        Raises
        ------
        InputError
            If ``margin`` is not one or four finite non-negative numbers.
        """
        m = as_float_array(margin, "margin")
        if m.shape not in ((), (4,)) or not np.all(np.isfinite(m)) or np.any(m < 0):
            raise InputError(f"margin must be one or four finite numbers >= 0 squares, got {margin!r}")
        s = self.square_m
        m = np.broadcast_to(m, (4,)) * s
        x0, x1 = -s - m, self.cols * s + m
        y0, y1 = -s - m, self.rows * s + m
        return np.array([[x0[0], x1[1], x1[2], x0[3]], [y0[0], y0[1], y1[2], y1[3]], np.zeros(4)])

    def warp_basis(self, points) -> np.ndarray:
        """The board warp's two shapes at target points: mrcal's parabolic board deflection.

        A board bends out of its plane by ``z = w_x b_x + w_y b_y`` (metres, along the target
        frame's z), with ``b_x = 1 - d_x^2`` and ``b_y = 1 - d_y^2``, where ``d_x, d_y`` run
        from -1 at the first junction of a row (column) to +1 at the last: one parabola along
        each axis, zero at the outer junctions' rows and columns' ends, 1 at the middle
        (mrcal's ``calobject_warp``, whose ``4 x_r (1 - x_r)`` with ``x_r`` from 0 to 1 is
        the same). At the board's centre the deflection is ``w_x + w_y`` from its corners:
        the sag.

        Parameters
        ----------
        points : (2, m) or (3, m) array_like
            Target points, metres (x, y used); beyond the outer junctions the parabolas
            go on (negative).

        Returns
        -------
        basis : (2, m) ndarray
            ``(b_x, b_y)`` per point, unitless.
        """
        P = np.asarray(points, dtype=float)
        dx = 2.0 * P[0] / ((self.cols - 1) * self.square_m) - 1.0
        dy = 2.0 * P[1] / ((self.rows - 1) * self.square_m) - 1.0
        return np.stack([1.0 - dx * dx, 1.0 - dy * dy])

    def warped(self, points, warp) -> np.ndarray:
        """Target points (3, m) on the bent board: ``z += w . warp_basis`` (:meth:`warp_basis`).

        Parameters
        ----------
        points : (3, m) array_like
            Metres.
        warp : (2,) array_like or None
            ``(w_x, w_y)``, metres; None or zeros: the flat board.

        Returns
        -------
        (3, m) ndarray
        """
        P = np.array(points, dtype=float)
        if warp is None:
            return P
        w = as_float_array(warp, "warp")
        if w.shape != (2,) or not np.all(np.isfinite(w)):
            raise InputError(f"warp must be two finite numbers (w_x, w_y) in metres, got {warp!r}")
        P[2] = P[2] + w @ self.warp_basis(P)
        return P

    def grid_indices(self) -> np.ndarray:
        """Column and row index of every junction, shape (2, n) int, row-major."""
        r, c = np.divmod(np.arange(self.n), self.cols)
        return np.vstack([c, r])

    @classmethod
    def parse(cls, text: str, *, allow_large: bool = False) -> "Board":
        """Read a board from ``"COLSxROWSxSQUARE"``.

        The square's side is in metres, or in the unit written after it: ``mm``, ``cm`` or
        ``m``. ``"9x6x0.025"``, ``"9x6x25mm"``, ``"9x6x2.5cm"`` and ``"9x6x0.025m"`` are the
        same board.

        Parameters
        ----------
        text : str
            ``COLSxROWSxSQUARE[mm|cm|m]``, e.g. ``"8x6x0.0635"`` or ``"8x6x63.5mm"``.
        allow_large : bool, keyword
            Accept squares over 1 m (see :class:`Board`).

        Raises
        ------
        InputError
            If ``text`` is malformed, or a side over 1 m is given without ``allow_large``
            (the message asks "did you mean 25 mm (0.025)?").
        """
        match = _BOARD_TEXT.fullmatch(str(text).strip().lower())
        try:
            if match is None:
                raise ValueError
            cols, rows, value, unit = match.groups()
            square = float(value) / _UNITS[unit]
            board = (int(cols), int(rows), square)
        except ValueError:
            raise InputError(
                f"board must look like COLSxROWSxSQUARE_M, the square's side in metres or in mm or cm "
                f"written after it (e.g. 8x6x0.0635 or 8x6x63.5mm), got {text!r}"
            ) from None
        if square > MAX_SQUARE_M and not allow_large:
            raise InputError(f"board {text!r}: a square of {value} m is over {MAX_SQUARE_M:g} m; "
                             f"{millimetre_hint(square)} (write {cols}x{rows}x{value}mm or "
                             f"{cols}x{rows}x{float(value) / 1000:g})")
        return cls(*board, allow_large=allow_large)

    @classmethod
    def from_world_points(cls, Wpts) -> "Board":
        """Recover the board from its junction points.

        Parameters
        ----------
        Wpts : (3, n) array_like
            Metres; must be a full grid ``(s * c, s * r, 0)`` in row-major order, as made
            by :meth:`world_points`.

        Raises
        ------
        InputError
            If the points are not such a grid.
        """
        W = as_points(Wpts, 3, "Wpts", min_count=4)
        steps = np.diff(W[0])
        square = float(np.max(steps)) if steps.size else 0.0
        if square <= 0:
            raise InputError("Wpts is not a row-major grid: x never increases")
        cols = int(np.argmax(steps < -square / 2) + 1) if np.any(steps < -square / 2) else W.shape[1]
        rows = W.shape[1] // cols
        if cols < 2 or rows < 2 or cols * rows != W.shape[1]:
            raise InputError(f"Wpts with {W.shape[1]} points is not a full row-major grid")
        board = cls(cols, rows, square)
        if not np.allclose(W, board.world_points(), atol=1e-6 * max(1.0, square)):
            raise InputError(
                "Wpts is not a row-major grid (s*c, s*r, 0) starting at the upper-left junction"
            )
        return board


#: The largest square side (metres) a :class:`Board` takes without ``allow_large``: a bigger
#: one is almost always millimetres typed as metres.
MAX_SQUARE_M = 1.0

#: ``COLSxROWSxSQUARE`` with an optional unit; how many of each unit make a metre (a division
#: is exact where a product is not: 63.5 / 1000 is 0.0635, 63.5 * 0.001 is not).
_BOARD_TEXT = re.compile(r"(\d+)x(\d+)x([0-9.eE+-]+)\s*(mm|cm|m)?")
_UNITS = {None: 1.0, "m": 1.0, "cm": 100.0, "mm": 1000.0}


def millimetre_hint(square_m: float) -> str:
    """``"did you mean 25 mm (0.025)?"`` for a square side ``square_m`` given in metres."""
    return f"did you mean {square_m:g} mm ({square_m / 1000:g})?"


def check_board(board):
    """A :class:`graphpose.board.Board`, returned as it is.

    Raises
    ------
    InputError
        If ``board`` is anything else.
    """
    if not isinstance(board, Board):
        raise InputError(f"board must be a graphpose.Board, got {type(board).__name__}")
    return board

"""The exceptions graphpose raises.

Every error a user can cause derives from :class:`GraphposeError`, so a caller (the
command line, for one) can turn them into a message and an exit code in one place;
anything else that escapes is a bug and keeps its traceback.
"""


class GraphposeError(Exception):
    """Base class of every error graphpose raises on purpose."""


class InputError(GraphposeError, ValueError):
    """An argument has the wrong shape, type or value (NaN, a singular K, ...)."""


class SaddleError(GraphposeError, ValueError):
    """A patch's fitted quadric is not a saddle, or its saddle lies outside the patch."""


class BoardNotFoundError(GraphposeError):
    """The checkerboard's junction grid could not be found inside the bounding polygon.

    Attributes
    ----------
    junctions_seen : int
        Junctions on the largest lattice the refusal is about (0: none formed); of several
        refusals, the one about the largest lattice tells the most.
    two_boards : bool
        Two boards were seen and no bounds said which one is meant: final, whatever else a
        search might find.
    """

    def __init__(self, message: str = "", *, junctions_seen: int = 0, two_boards: bool = False):
        super().__init__(message)
        self.junctions_seen = int(junctions_seen)
        self.two_boards = bool(two_boards)


class BoardMismatchError(BoardNotFoundError):
    """A board was seen, but of another size than the spec: the spec is wrong, or the grid
    found is part of a larger one.

    A :class:`BoardNotFoundError` (callers that skip a view without a board skip this one
    too, and the command line exits 1), told apart so that a caller can say what was seen
    over several views (``graphpose calibrate`` refuses a spec that its views contradict).

    Attributes
    ----------
    found : (int, int) or None
        Inner junctions ``(cols, rows)`` of the board seen, in the spec's orientation, when
        the board was seen whole; else the extent of the grid seen (at least that large).
    size_px : float
        The grid's size in the image, pixels: its median step times the square root of its
        junction count (so that it can be compared with another grid's).
    """

    def __init__(self, message: str = "", *, found=None, size_px: float = 0.0, junctions_seen: int = 0):
        super().__init__(message, junctions_seen=junctions_seen)
        self.found = None if found is None else (int(found[0]), int(found[1]))
        self.size_px = float(size_px)


class DegenerateGeometryError(GraphposeError, ValueError):
    """Valid input whose geometry admits no answer: a failed result, not bad usage (exit 1).

    Points that fix no homography (collinear, repeated, coincident), a homography with no pose
    that puts the board in front of the camera, image points where the lens model has no ray
    in front of the camera. The detector, the tracker and the calibration catch it as "this
    view gives no pose"; the command line turns it into exit code 1, as a failed estimate,
    never 2 (:class:`InputError` is for arguments the caller must change). A ``ValueError``
    too, as numbers that admit no answer are in Python's own terms, so that a caller catching
    ``ValueError`` catches it.
    """


class ConvergenceError(GraphposeError):
    """An iterative solver did not converge, or converged to a pose that fails its checks."""

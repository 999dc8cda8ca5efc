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


class DegenerateGeometryError(GraphposeError, ValueError):
    """Valid input whose geometry admits no answer: a failed result, not bad usage (exit 1).

    Points that fix no homography (collinear, repeated, coincident), a homography with no pose
    that puts the board in front of the camera, image points where the lens model has no ray
    in front of the camera. The detector, the tracker and the calibration catch it as "this
    view gives no pose"; the command line turns it into exit code 1, as a failed estimate,
    never 2 (:class:`InputError` is for arguments the caller must change). A ``ValueError``,
    as the :class:`InputError` it used to be, so that callers catching that still do.
    """


class ConvergenceError(GraphposeError):
    """An iterative solver did not converge, or converged to a pose that fails its checks."""

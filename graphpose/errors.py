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
    """The checkerboard's junction grid could not be found inside the bounding polygon."""


class ConvergenceError(GraphposeError):
    """An iterative solver did not converge, or converged to a pose that fails its checks."""

"""Image -> cross-junctions, in two stages a caller can stop between.

:func:`find_board` finds the board and labels its junctions, with no camera (a coarse grid
search, :mod:`.find`), as a :class:`FoundBoard`; :func:`refine` makes them sub-pixel (the
saddle fit of :mod:`.saddle` in :mod:`.refine`, through the lens when a camera is given) and
decides which to trust (:mod:`.junctions`), as :class:`Junctions`.
:func:`extract_junctions` is the two in a row.

The names below are detection's public seam: the rest of graphpose (the estimate,
calibration, tracking) uses only these, never the modules' internals
(``tests/test_layers.py`` holds that).

``graphpose.detect.refine`` is the function; its module keeps the name too, and is reached by
``from graphpose.detect.refine import ...`` (or ``sys.modules``), not as an attribute.
"""

from .find import FoundBoard
from .junctions import Junctions, board_smoothing, extract_junctions, find_board, refine
from .noise import estimate_noise
from .refine import MAX_RADIUS, SMOOTH_SIGMA, WINDOW_FRACTION, refine_junctions

__all__ = [
    "FoundBoard",
    "Junctions",
    "MAX_RADIUS",
    "SMOOTH_SIGMA",
    "WINDOW_FRACTION",
    "board_smoothing",
    "estimate_noise",
    "extract_junctions",
    "find_board",
    "refine",
    "refine_junctions",
]

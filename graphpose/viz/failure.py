"""The picture of an image without a pose: what the search saw, and why it gave up.

When the board is not found there is no pose to draw (:mod:`graphpose.viz.overlay`), but
there is still something to debug with. :func:`failure_evidence` runs the first stages of
the board search again (:func:`graphpose.detect.search.find_candidates` at the search's
first level and :func:`graphpose.detect.lattice.grow_lattices`) and keeps what they found:
the junction-like candidates and the largest lattice of cross-junctions grown from them
(a partial grid, or a grid of another size than the board's). :func:`draw_failure` draws
them on the dimmed image with the bounding polygon, and the reason in the corner's box:
small orange dots for the candidates, cyan rings for the lattice, the bounds thin yellow.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import as_polygon
from ..board import Board
from ..image import as_grey
from .overlay import COLOURS, _line, _plus, _ring, _text_box

#: Colour of the candidates (orange: neither trusted nor refused, only seen).
CANDIDATE = (255, 150, 30)


@dataclass(frozen=True)
class FailureEvidence:
    """What the board search found in an image where it found no board.

    Attributes
    ----------
    candidates : (2, N) ndarray of float64
        Junction-like points (u, v), pixels, strongest first (at most 400).
    lattice : (2, M) ndarray of float64
        Nodes of the largest lattice of cross-junctions, pixels; (2, 0) when none grew.
    """

    candidates: np.ndarray
    lattice: np.ndarray


def failure_evidence(image, bounds=None, board: Board = Board(), seen: int = 0) -> FailureEvidence:
    """The candidates and the largest lattice the board search finds in ``image``.

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) array_like
        The image (any dtype :func:`graphpose.image.as_grey` takes; uint8 grey as it is).
    bounds : (2, 4) array_like, optional
        The polygon the search was given: candidates inside it seed the lattices.
    board : Board
        The board searched for (bounds the lattices' size, as the search does).
    seen : int
        Junctions on the lattice the refusal was about
        (:attr:`graphpose.errors.BoardNotFoundError.junctions_seen`): the search's levels
        (the fast path's, then the noise-aware ones) are tried until one grows a lattice as
        large, so that the rings drawn are the grid the reason counts, not a smaller one of
        the first level. The candidates drawn are the first level's.
    """
    from ..detect.lattice import grow_lattices
    from ..detect.noise import estimate_noise
    from ..detect.find import noise_levels
    from ..detect.search import find_candidates, search_levels

    grey = image if isinstance(image, np.ndarray) and image.ndim == 2 else as_grey(image)
    region = None if bounds is None else as_polygon(bounds, "bounds")
    levels = [(level, None) for level in search_levels(grey.shape)]
    first = None
    largest = np.zeros((2, 0))
    for k, (level, noise) in enumerate(levels):
        cands = find_candidates(grey, region, level=level, noise=noise)
        first = cands if first is None else first
        for _, lattice in grow_lattices(cands, max_nodes=8 * board.n):
            if lattice is not None and lattice.points.shape[1] > largest.shape[1]:
                largest = lattice.points
        if largest.shape[1] >= max(int(seen), 1) or (not seen and k == 0):
            break
        if k == len(levels) - 1 and noise is None:  # then the noise-aware levels, as the search
            levels += [(lv, estimate_noise(grey)) for lv in noise_levels(grey.shape)]
    order = np.argsort(first.strength)[::-1][:400]
    return FailureEvidence(first.points[:, order], largest)


def draw_failure(image, reason: str, *, bounds=None, found: FailureEvidence | None = None,
                 board: Board = Board(), label=None, seen: int = 0) -> np.ndarray:
    """Draw an image without a pose: bounds, candidates, partial grid and the reason.

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) array_like
        The image, raw as the camera took it.
    reason : str
        Why there is no pose (the one-line message), written in the box.
    bounds : (2, 4) array_like, optional
        The bounding polygon given to the search, drawn as a thin outline.
    found : FailureEvidence, optional
        What the search found; :func:`failure_evidence` of the image when None.
    board : Board
        The board searched for (for :func:`failure_evidence`).
    label : str, optional
        A name (the image's) written above the reason.
    seen : int
        Junctions the reason counts (:attr:`graphpose.errors.BoardNotFoundError.junctions_seen`),
        for :func:`failure_evidence`.

    Returns
    -------
    overlay : (H, W, 3) ndarray of uint8
        A new RGB image.
    """
    grey = as_grey(image)
    if bounds is not None:
        bounds = as_polygon(bounds, "bounds")
    if found is None:
        found = failure_evidence(image, bounds, board, seen)
    canvas = np.repeat((40.0 + 170.0 * np.clip(grey, 0.0, 1.0))[..., None], 3, axis=2)
    size = max(1.0, min(canvas.shape[:2]) / 480.0)
    if bounds is not None:
        for i in range(bounds.shape[1]):
            _line(canvas, bounds[:, i], bounds[:, (i + 1) % bounds.shape[1]], COLOURS["bounds"], 1.0)
    for u, v in found.candidates.T:
        _plus(canvas, u, v, 1.5 * size, CANDIDATE, 1.0)
    for u, v in found.lattice.T:
        _ring(canvas, u, v, 6.0 * size, 2.0 * size, COLOURS["trusted"])
    white = COLOURS["text"]
    scale = max(1, int(round(min(canvas.shape[:2]) / 240.0)))
    width = max(20, (canvas.shape[1] - 12 * scale) // (6 * scale))  # characters a line: 5 + 1 px each, scaled
    lines = [([(f"{label}  ", white)] if label else []) + [("no pose", COLOURS["bad"])]]
    lines += [[(text, white)] for text in _wrap(reason, width)]
    lines += [[("+", CANDIDATE), (f" {found.candidates.shape[1]} candidates  ", white),
               ("o", COLOURS["trusted"]), (f" largest grid: {found.lattice.shape[1]} junctions", white)]]
    avoid = np.hstack([found.candidates, found.lattice])
    _text_box(canvas, lines, avoid, bounds, scale)
    return np.clip(np.round(canvas), 0, 255).astype(np.uint8)


def _wrap(text: str, width: int) -> list:
    """``text`` in lines of at most ``width`` characters, broken at spaces (the overlay's
    font has no semicolon: a comma stands for it)."""
    import textwrap

    return textwrap.wrap(" ".join(text.replace(";", ",").split()), width) or [""]

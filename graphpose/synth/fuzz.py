"""Random hard inputs for the detector and the pose, each with its truth: the project's fuzz.

:func:`fuzz_case` draws one case from an ``rng``: a board (symmetric and not) at a random pose
of any in-plane rotation (:func:`graphpose.synth.scenes.random_scene`), seen whole or only in
part (the image edge cutting it, a bar, a blob or a specular highlight over it), with clutter
beside it, contrast from a washed-out 0.25 to full, noise, blur and vignetting; and an input
as a user would give it: to :func:`graphpose.extract_junctions` or to
:func:`graphpose.estimate_pose`, without a polygon, with the board's outline (exact, a few
pixels loose, or clicked inside the margin), or with the outline *rolled* by one or two
vertices (it names another corner as junction 0: a user's mistake, which on a board seen only
in part the visible junctions may not show). Every case keeps its truth: the pose, the true
junctions, which of them can be seen, and the polygon's roll.

A right answer is a refusal, or junctions each within 1 px of the truth of their label (labels
that a symmetry of the board's pattern relates count as right) and a pose within 5 of its
sigmas of the truth (or of the truth turned by that symmetry). The runner and that verdict
are the benchmark's (``benchmarks/fuzz.py``), which the tests run on a fixed seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..board import Board
from .poses import loose_polygon
from .scenes import random_scene

#: Boards drawn from: not symmetric (cols + rows odd), half-turn symmetric, and square.
BOARDS = (Board(8, 6, 0.0635), Board(9, 6, 0.03), Board(7, 5, 0.04), Board(5, 4, 0.05), Board(11, 8, 0.025),
          Board(6, 6, 0.04), Board(7, 7, 0.04))
#: Polygons given with a case: none, the exact outline, a loose one, one clicked inside the
#: margin, and the outline rolled by one or two vertices (another corner named junction 0).
POLYGONS = ("none", "exact", "loose", "inset", "rolled")
#: Entry points: ``"junctions"`` (:func:`graphpose.extract_junctions`) and ``"pose"``
#: (:func:`graphpose.estimate_pose`).
ENTRIES = ("junctions", "pose")
#: The camera of the real images (f ~ 565 px, 640 x 480).
K_FUZZ = np.array([[564.9, 0.0, 337.3], [0.0, 564.3, 226.5], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class FuzzCase:
    """One fuzz input and its truth.

    Attributes
    ----------
    image : (H, W) ndarray of uint8
        The picture.
    K : (3, 3) ndarray
        The camera's intrinsics, pixels (no distortion).
    board : Board
        The spec given with the image (the board rendered).
    T_WC : (4, 4) ndarray
        The true camera pose in the target frame.
    truth : (2, n) ndarray
        The true junctions (u, v), pixels, row-major.
    visible : (n,) ndarray of bool
        Junctions that can be seen (in the image, no occluder over them).
    bounds : (2, 4) ndarray or None
        The polygon given, pixels (clockwise; rolled by ``roll`` vertices), or None.
    polygon : str
        Its kind, one of :data:`POLYGONS`.
    roll : int
        Vertices the polygon is rolled by (0, 1, 2 or 3; a roll of 1 or 3 is a quarter turn).
    entry : str
        One of :data:`ENTRIES`.
    settings : dict
        What was drawn (occluders, clutter, contrast, noise, blur, vignetting), for reports.
    """

    image: np.ndarray
    K: np.ndarray
    board: Board
    T_WC: np.ndarray
    truth: np.ndarray
    visible: np.ndarray
    bounds: np.ndarray | None
    polygon: str
    roll: int
    entry: str
    settings: dict


def fuzz_case(rng, *, entry: str | None = None, polygon: str | None = None, partial: bool | None = None,
              size=(640, 480)) -> FuzzCase:
    """Draw one fuzz case.

    Parameters
    ----------
    rng : numpy.random.Generator or int
        Source of randomness (an int seeds a new generator).
    entry : str, optional
        Fix the entry point (:data:`ENTRIES`); drawn when None.
    polygon : str, optional
        Fix the polygon's kind (:data:`POLYGONS`); drawn when None.
    partial : bool, optional
        True: an occluder or the image edge hides part of the board; False: no occluder;
        None: drawn (about two cases in three partial).
    size : (int, int)
        ``(width, height)``, pixels.

    Returns
    -------
    FuzzCase
    """
    rng = np.random.default_rng(rng)
    board = BOARDS[int(rng.integers(len(BOARDS)))]
    entry = ENTRIES[int(rng.integers(2))] if entry is None else entry
    polygon = POLYGONS[int(rng.integers(len(POLYGONS)))] if polygon is None else polygon
    partial = bool(rng.random() < 0.65) if partial is None else partial
    occluders = ()
    if partial:
        kinds = ("edge", "bar", "blob", "reflection")
        occluders = tuple(kinds[int(k)] for k in rng.choice(4, size=int(rng.integers(1, 3)), replace=False))
    clutter = tuple(c for c in ("text", "grid") if rng.random() < 0.25)
    f = K_FUZZ[0, 0] * size[0] / 640
    K = K_FUZZ * np.array([[size[0] / 640], [size[1] / 480], [1.0]])
    K[2] = (0.0, 0.0, 1.0)
    extent = max(board.cols, board.rows) + 2
    near = max(board.square_m * f / 90.0, extent * board.square_m * f / (0.9 * size[1]))
    far = max(board.square_m * f / 12.0, 1.2 * near)
    settings = {"occluders": occluders, "clutter": clutter, "contrast": float(rng.uniform(0.25, 1.0)),
                "noise": float(rng.uniform(0.5, 7.0)), "blur": float(rng.uniform(0.4, 2.5)),
                "vignetting": float(rng.uniform(0.0, 0.6)), "margin": float(rng.choice([0.15, 0.5, 1.0]))}
    scene = random_scene(K, board, size, occluders=occluders, clutter=clutter, distance=(near, far),
                         max_tilt_deg=float(rng.uniform(15, 60)), noise_sigma=settings["noise"],
                         blur_sigma=settings["blur"], contrast=settings["contrast"],
                         vignetting=settings["vignetting"], margin=settings["margin"], rng=int(rng.integers(2**31)))
    R = scene.rendering
    roll, bounds = 0, None
    if polygon == "exact":
        bounds = R.outline.copy()
    elif polygon in ("loose", "inset"):
        bounds = loose_polygon(R, rng=rng, inset=polygon == "inset")
    elif polygon == "rolled":
        roll = int(rng.choice([1, 1, 2, 3]))
        bounds = np.roll(loose_polygon(R, rng=rng), roll, axis=1)
    return FuzzCase(scene.image, K, board, R.T_WC, R.junctions, scene.visible, bounds, polygon, roll, entry,
                    settings)

"""Grid homographies: board grid ``(c, r)`` to image ``(u, v)``, and what they say.

A homography fitted to a board's junctions is the exact grid-to-image map of a pinhole
camera: :mod:`graphpose.detect.junctions` uses it to size the refinement windows and to
judge which refined junctions agree with a planar grid.

Coordinates follow :mod:`graphpose.geometry`.
"""

from __future__ import annotations

import numpy as np

from ..errors import BoardNotFoundError, DegenerateGeometryError
from ..geometry import apply_homography, homography_dlt


def square_sides(H: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Smaller height of the parallelogram spanned by the local grid steps, pixels."""
    du = apply_homography(H, grid + [[0.5], [0.0]]) - apply_homography(H, grid - [[0.5], [0.0]])
    dv = apply_homography(H, grid + [[0.0], [0.5]]) - apply_homography(H, grid - [[0.0], [0.5]])
    area = np.abs(du[0] * dv[1] - du[1] * dv[0])
    return area / np.maximum(np.hypot(*du), np.hypot(*dv))


def fit_homography(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Homography mapping src (2, N) to dst (2, N), scaled so ``H[2, 2] = 1``.

    Junctions that do not fix one (collinear, coincident) mean no board was found.
    """
    try:
        H = homography_dlt(src, dst)
    except DegenerateGeometryError as exc:
        raise BoardNotFoundError(f"the junctions found do not fix a homography: {exc}") from None
    return H / H[2, 2]

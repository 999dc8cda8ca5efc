"""The image-to-pose pipeline: cross-junctions from the image, then the cross-checked pose.

:func:`estimate_pose` is the one function that knows both steps: the junctions
(:func:`graphpose.detect.extract_junctions`: the board found, labelled and refined)
and the pose from the trusted ones (:mod:`graphpose.pose.estimate`: Gauss-Newton and the GTSAM
graph, held against each other). The detector knows nothing of poses and the solvers nothing
of images; this module, above both, joins them, and checks its inputs once, at its edge, before
the slow step.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ._checks import check_transform
from .board import Board, check_board
from .camera_models import as_camera
from .detect import extract_junctions
from .errors import BoardNotFoundError
from .observations import MIN_JUNCTIONS
from .pose.estimate import PoseEstimate, estimate_pose_unchecked


def estimate_pose(image, bounds, camera, board: Board = Board(), guess=None, *,
                  robust: bool = False) -> PoseEstimate:
    """Camera pose from an image of the checkerboard.

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) array_like
        The image as the camera took it (see :func:`graphpose.image.as_grey`): raw, with the
        lens distortion ``camera`` describes.
    bounds : (2, 4) array_like or None
        Bounding polygon of the board, pixels, clockwise from the corner nearest junction 0
        (see :func:`graphpose.detect.extract_junctions`): it only narrows the
        search and names junction 0's corner. None searches the whole image.
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`, e.g. from
        :func:`graphpose.io.calibration.read_camera`), or pinhole intrinsics ``K``, pixels,
        for an image without distortion.
    board : Board
        The target.
    guess : (4, 4) array_like, optional
        Starting pose T_WC; the homography initialiser when None.
    robust : bool
        Use a Huber kernel (threshold 1.345 robust sigmas) in both solvers.

    Returns
    -------
    PoseEstimate
        Check ``ok`` (or ``converged`` and ``cross_check.agree``) before using the pose, and
        ``orientation_ambiguous`` for a symmetric board found without bounds.

    Raises
    ------
    InputError
        On a malformed image, polygon, camera or guess, an image of another size than the
        camera's calibration (:func:`graphpose.camera_models.check_image_size`), or a guess with
        junctions behind the camera.
    BoardNotFoundError
        If the junction grid is not found, or fewer than six junctions not all on one line
        are trusted.
    """
    # The camera and the guess are checked before the extraction, so bad ones fail before
    # the slow step.
    camera = as_camera(camera)
    board = check_board(board)
    guess = None if guess is None else check_transform(guess, "guess")
    junctions = extract_junctions(image, bounds, board, camera=camera)
    _check_geometry(junctions.trusted, board)
    # Unseen junctions are NaN and untrusted: the solvers use the trusted ones only.
    estimate = estimate_pose_unchecked(camera, junctions.points, board.world_points(), guess, junctions.trusted, robust)
    return dataclasses.replace(estimate, junctions=junctions,
                               orientation_ambiguous=bool(junctions.orientation_ambiguous))


def _check_geometry(trusted, board) -> None:
    """Refuse fewer than :data:`graphpose.observations.MIN_JUNCTIONS` trusted junctions, or ones all on one line."""
    m = int(np.count_nonzero(trusted))
    if m < MIN_JUNCTIONS:
        raise BoardNotFoundError(f"only {m} junctions are trusted; a pose needs {MIN_JUNCTIONS}, not all on one line")
    grid = board.grid_indices()[:, trusted].astype(float)
    grid -= grid.mean(axis=1, keepdims=True)
    if np.linalg.matrix_rank(grid) < 2:
        raise BoardNotFoundError(
            f"the {m} trusted junctions all lie on one line of the board; a pose needs junctions "
            "off that line (more of the board in view)")

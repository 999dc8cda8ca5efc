"""A rig's pose from its images: each camera's junctions, then the rig's pose from them all.

:func:`estimate_rig_pose` is the rig's twin of :func:`graphpose.estimate.estimate_pose`: it finds
each camera's junctions (:func:`graphpose.detect.extract_junctions`, through that
camera's lens) and hands them to :func:`graphpose.pose.rig.estimate_rig_pose_from_points`
(Gauss-Newton and GTSAM over camera 0's pose, ``docs/rigs.md``).
"""

from __future__ import annotations

import numpy as np

from .board import Board, check_board
from .errors import BoardNotFoundError, InputError
from .pose.rig import RigPoseEstimate, estimate_rig_pose_from_points


def estimate_rig_pose(images, rig, *, board: Board = Board(), robust: bool = False) -> RigPoseEstimate:
    """The rig's pose (camera 0's, in the target frame) from one image per camera.

    Parameters
    ----------
    images : sequence
        One raw image per camera of ``rig``, taken together: arrays, image files, or None
        for a camera without one.
    rig : Rig
        The calibrated rig (:class:`graphpose.rig.Rig`, e.g. from
        :func:`graphpose.io.cameras.read_camera` of a rig file).
    board : Board
    robust : bool
        A Huber kernel (1.345 robust sigmas) in both solvers.

    Returns
    -------
    RigPoseEstimate

    Raises
    ------
    InputError
        If ``rig`` is not a Rig, the images are not one per camera, or an image's size is not
        its camera's.
    BoardNotFoundError
        If no camera sees the board.
    """
    from .camera_models import check_image_size
    from .detect import extract_junctions
    from .image import read_image
    from .rig import Rig

    if not isinstance(rig, Rig):
        raise InputError(f"rig must be a graphpose Rig (a rig file read by read_camera), got {type(rig).__name__}")
    check_board(board)
    images = list(images)
    if len(images) != len(rig):
        raise InputError(f"images must give one image per camera of the rig: {len(rig)} cameras, {len(images)} images")
    found, status, messages = [], [], []
    W_all = board.world_points()
    for c, image in enumerate(images):
        if image is None:
            found.append(None), status.append("no board"), messages.append("no image")
            continue
        name = str(image) if isinstance(image, (str,)) or hasattr(image, "suffix") else f"camera {c}'s image"
        if not isinstance(image, np.ndarray):
            image = read_image(image, as_float=False)
        check_image_size(rig.cameras[c], image, name)
        try:
            J = extract_junctions(image, bounds=None, board=board, camera=rig.cameras[c])
            if np.count_nonzero(J.trusted) < 6:
                raise BoardNotFoundError(f"only {np.count_nonzero(J.trusted)} trusted junctions")
        except BoardNotFoundError as exc:
            found.append(None), status.append("no board"), messages.append(str(exc))
            continue
        found.append(J), status.append("used"), messages.append("")
    if not any(s == "used" for s in status):
        raise BoardNotFoundError("no camera of the rig sees the board: " + "; ".join(
            f"camera {c}: {m}" for c, m in enumerate(messages)))
    obs = [(c, J.points[:, J.trusted], W_all[:, J.trusted]) if J is not None else None for c, J in enumerate(found)]
    return estimate_rig_pose_from_points(rig, [None if o is None else o[1:] for o in obs], board, robust=robust,
                                         junctions=found, messages=messages)

"""Calibration sets: many raw views of one camera, with exact truth.

:func:`calibration_set` renders ``n_views`` images of the board (:func:`graphpose.synth.render.render`)
through one camera at poses that cover the image and vary in tilt, so that a calibration
(:func:`graphpose.calibrate`) can be judged against the camera that took them. Two cameras
come ready (:func:`radtan_camera`, :func:`fisheye_camera`): a radial-tangential lens with
``k1 = -0.3`` at 640 x 480, and a fisheye of about 185 degrees across 1280 x 960.

Poses: the board's centre lies near the ray of a pixel drawn on a grid of cells over the image
(one cell per view, visited in a shuffled order, so the views cover the image; for a
fisheye the first ``centre_views`` near the image's centre instead), at a distance
drawn from ``distance``, tilted by ``min_tilt_deg``-``max_tilt_deg`` about a random in-plane
axis (a calibration needs the board seen at different angles: parallel views leave the
focal length and the distance indistinguishable), and the whole sheet is in the image
(:func:`graphpose.synth.poses.random_pose`). For the fisheye every junction stays within
``max_angle_deg`` of the optical axis (88 degrees by default: in front of the camera, where
GTSAM's ``Cal3Fisheye`` projects).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import check_count, check_number
from ..board import check_board
from ..board import Board
from ..geometry import to_camera
from ..camera_models import FisheyeCamera, RadTanCamera, as_camera
from ..errors import InputError
from .poses import random_pose
from .render import Rendering, render


def radtan_camera() -> RadTanCamera:
    """A radial-tangential camera with strong barrel distortion (k1 = -0.3), 640 x 480."""
    return RadTanCamera([[530.0, 0.0, 322.5], [0.0, 528.0, 241.0], [0.0, 0.0, 1.0]],
                        [-0.3, 0.11, 0.0008, -0.0005, -0.02], size=(640, 480))


def fisheye_camera() -> FisheyeCamera:
    """An equidistant fisheye of about 185 degrees across its 1280 x 960 image."""
    return FisheyeCamera([[378.0, 0.0, 641.5], [0.0, 377.0, 478.5], [0.0, 0.0, 1.0]],
                         [0.02, -0.004, 0.0006, -0.00005], size=(1280, 960))


@dataclass(frozen=True)
class CalibrationSet:
    """Views of one camera and their truth.

    Attributes
    ----------
    camera : Camera
        The camera that took them (the truth).
    renderings : list of Rendering
        One per view: ``image`` (uint8), exact ``junctions`` (2, n) and ``T_WC``.
    board : Board
        The target.
    """

    camera: object
    renderings: list
    board: Board

    @property
    def images(self) -> list:
        """The images, (H, W) uint8 each."""
        return [r.image for r in self.renderings]

    @property
    def poses(self) -> list:
        """The true ``T_WC`` of each view, (4, 4) each."""
        return [r.T_WC for r in self.renderings]


def calibration_set(camera, n_views: int = 30, *, rng=None, board: Board = Board(), distance=None,
                    min_tilt_deg: float = 15.0, max_tilt_deg: float = 50.0, max_roll_deg: float = 30.0,
                    max_angle_deg: float = 88.0, centre_views=None, noise_sigma: float = 2.0,
                    blur_sigma: float = 1.0, warp=None) -> CalibrationSet:
    """Render a calibration set: ``n_views`` raw images of the board through ``camera``.

    Parameters
    ----------
    camera : Camera
        The camera, with its ``size`` (width, height).
    n_views : int
        Number of views (>= 1).
    rng : numpy.random.Generator, int or None
        Source of the poses and the noise.
    board : Board
        The target.
    distance : (float, float), optional
        Range of the board centre's distance along its ray, metres; by default one that makes
        the board span about a third to two thirds of the image's smaller side.
    min_tilt_deg, max_tilt_deg : float
        Range of the board's tilt out of the plane facing the camera, degrees.
    max_roll_deg : float
        Largest in-plane rotation, degrees (below 45: junction 0 stays unambiguous).
    max_angle_deg : float
        Largest angle of a junction off the optical axis, degrees.
    centre_views : int, optional
        How many of the views (the first ones) have the board near the image's centre
        (default: 3 for a fisheye, 0 for the other models), at
        the far end of ``distance`` and beyond (to 1.5 times it) and tilted by at most 30
        degrees, as a user is told to take them: a fisheye's raw boards are found without a
        camera only where they are little distorted (:func:`graphpose.calibrate`'s first
        pass).
    noise_sigma, blur_sigma : float
        As :func:`graphpose.synth.render.render` (grey levels of 255; pixels).
    warp : (2,) array_like, optional
        A bent board, the same in every view: mrcal's board warp ``(w_x, w_y)``, metres
        (:meth:`graphpose.board.Board.warp_basis`); None: flat.

    Returns
    -------
    CalibrationSet

    Raises
    ------
    InputError
        If an argument is invalid, the camera has no size, or no pose fits the board in the
        image.
    """
    camera = as_camera(camera)
    if camera.size is None:
        raise InputError("calibration_set needs a camera with its image size")
    check_board(board)
    n_views = check_count("n_views", n_views, 1)
    lo_tilt = check_number("min_tilt_deg", min_tilt_deg, 0.0)
    hi_tilt = check_number("max_tilt_deg", max_tilt_deg, lo_tilt)
    max_angle = np.radians(check_number("max_angle_deg", max_angle_deg, 0.0, strict=True))
    rng = np.random.default_rng(rng)
    width, height = camera.size
    if distance is None:
        extent = (board.cols + 1) * board.square_m
        near_px = min(width, height) * (0.6 if camera.model == "fisheye" else 0.75)
        distance = (camera.fx * extent / near_px, camera.fx * extent / (0.4 * near_px))
    W = board.world_points()
    # One cell per view on a grid over the image, visited in a shuffled order.
    cols = int(np.ceil(np.sqrt(n_views * width / height)))
    rows = int(np.ceil(n_views / cols))
    cells = rng.permutation(cols * rows)[:n_views]
    if centre_views is None:
        centre_views = 3 if camera.model == "fisheye" else 0
    centre_views = check_count("centre_views", centre_views, 0)
    renderings = []
    for k, cell in enumerate(cells):
        r, c = divmod(int(cell), cols)
        d, tilts = distance, (lo_tilt, hi_tilt)
        if k < centre_views:  # smaller and less tilted: little distortion across the board
            near, reach = (0.5 * (width - 1), 0.5 * (height - 1)), (0.1 * width, 0.1 * height)
            d, tilts = (distance[1], 1.5 * distance[1]), (lo_tilt, max(lo_tilt, min(hi_tilt, 30.0)))
        else:
            near = ((c + 0.5) / cols * width, (r + 0.5) / rows * height)
            reach = (max(0.5 * width / cols, 0.1 * width), max(0.5 * height / rows, 0.1 * height))
        T = None
        for attempt in range(200):  # the reach widens where the cell is hard to fill (a rim)
            grow = 1.0 + attempt / 20.0
            T = _pose(camera, board, d, *tilts, max_roll_deg, near, (grow * reach[0], grow * reach[1]), rng=rng)
            if T is None:
                continue
            P_C = to_camera(T, W)
            if np.all(np.arctan2(np.hypot(P_C[0], P_C[1]), P_C[2]) < max_angle):
                break
            T = None
        if T is None:
            raise InputError(f"no pose puts the board near cell {cell} of the image with every "
                             f"junction within {max_angle_deg} degrees of the axis")
        renderings.append(render(camera, T, board, noise_sigma=noise_sigma, blur_sigma=blur_sigma, rng=rng,
                                 warp=warp))
    return CalibrationSet(camera, renderings, board)


def _pose(camera, board, distance, lo_tilt, hi_tilt, max_roll, near_px, reach, *, rng):
    """A :func:`random_pose` with the tilt in range and the board's centre within ``reach``
    (pixels, along u and v) of ``near_px``."""
    # random_pose draws the centre's pixel uniformly: retry until it lands near the wanted
    # pixel, and the tilt is at least the minimum.
    for _ in range(50):
        try:
            T = random_pose(camera, board, rng=rng, distance=distance, max_tilt_deg=hi_tilt,
                            max_roll_deg=max_roll, max_tries=50)
        except InputError:
            continue
        centre = np.array([(board.cols - 1) / 2, (board.rows - 1) / 2, 0.0]) * board.square_m
        uv = camera.project(to_camera(T, centre[:, None]))[:, 0]
        normal_C = T[:3, :3].T @ np.array([0.0, 0.0, 1.0])  # the board's z in the camera frame
        ray = to_camera(T, centre[:, None])[:, 0]
        tilt = np.degrees(np.arccos(abs(normal_C @ ray) / np.linalg.norm(ray)))
        close = abs(uv[0] - near_px[0]) < reach[0] and abs(uv[1] - near_px[1]) < reach[1]
        if tilt >= lo_tilt and close:
            return T
    return None


__all__ = ["CalibrationSet", "Rendering", "calibration_set", "fisheye_camera", "radtan_camera"]

"""Rendered views of a rig of cameras, with exact truth: for rig calibration and the rig's pose.

:func:`rig_views` renders ``n_views`` views of the board through every camera of a
:class:`graphpose.rig.Rig`. View k is drawn for its *anchor* camera (``k mod n_cameras``): the
board near the anchor's image centre (within 10 % of the image for a fisheye, whose raw boards are found without a camera there only, 30 % otherwise), at a distance that makes it
span a third to two thirds of the image (as :func:`graphpose.synth.calibration.calibration_set`),
tilted by 15-50 degrees. The rig's pose follows (``T_WC0 = T_WCa T_C0_Ca^-1``) and every other
camera renders the board where the whole sheet lies in its image (and within 88 degrees of a
fisheye's axis); where it does not, and in every ``solo_every``-th view (the board hidden
from the others, as by an occluder), that camera's image is blank (grey noise): a view that
only some cameras see.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..board import Board
from ..geometry import to_camera
from .calibration import _pose
from .render import render


@dataclass(frozen=True)
class RigViews:
    """Rendered rig views and their truth.

    Attributes
    ----------
    rig : Rig
        The rig that took them (the truth).
    images : list of list of ndarray
        Per view, per camera: the image (uint8), blank where the board is not seen.
    seen : (n_views, n_cameras) ndarray of bool
        Whether each camera's image shows the board.
    poses : list of (4, 4) ndarray
        The true rig pose ``T_WC0`` per view.
    board : Board
    """

    rig: object
    images: list
    seen: np.ndarray
    poses: list
    board: Board


def _inside(camera, T_WC, board) -> bool:
    """The whole sheet in the image, 8 px inside, in front (fisheye: within 88 degrees)."""
    corners = board.sheet_corners()
    edges = np.hstack([corners[:, i:i + 1] + np.linspace(0, 1, 16) * (corners[:, (i + 1) % 4:(i + 1) % 4 + 1]
                                                                       - corners[:, i:i + 1]) for i in range(4)])
    P = to_camera(T_WC, edges)
    if camera.model == "fisheye":
        if np.any(np.degrees(np.arctan2(np.hypot(P[0], P[1]), P[2])) > 88.0):
            return False
    elif np.any(P[2] <= 0.05):
        return False
    uv = camera.project(P)
    w, h = camera.size
    return bool(np.all(np.isfinite(uv)) and np.all((uv[0] > 8) & (uv[0] < w - 9) & (uv[1] > 8) & (uv[1] < h - 9)))


def rig_views(rig, n_views: int, *, rng=None, board: Board = Board(), solo_every: int = 5, noise_sigma: float = 2.0,
              blur_sigma: float = 1.0) -> RigViews:
    """Render ``n_views`` views of the board through every camera of ``rig`` (see the module
    docstring).

    Parameters
    ----------
    rig : Rig
        Cameras with their sizes, and ``T_C0_C``.
    n_views : int
    rng : numpy.random.Generator, int or None
    board : Board
    solo_every : int
        Every this-many-th view (view 0 included) shows the board to its anchor camera only
        (0: never).
    noise_sigma, blur_sigma : float
        As :func:`graphpose.synth.render.render`.

    Returns
    -------
    RigViews
    """
    rng = np.random.default_rng(rng)
    C = len(rig)
    images, seen, poses = [], np.zeros((n_views, C), bool), []
    for k in range(n_views):
        a = k % C
        cam = rig.cameras[a]
        width, height = cam.size
        extent = (board.cols + 1) * board.square_m
        near_px = min(width, height) * (0.6 if cam.model == "fisheye" else 0.75)
        distance = (cam.fx * extent / near_px, cam.fx * extent / (0.4 * near_px))
        reach = 0.1 if cam.model == "fisheye" else 0.3
        T_a = None
        while T_a is None:
            T_a = _pose(cam, board, distance, 15.0, 50.0, 30.0, (0.5 * (width - 1), 0.5 * (height - 1)),
                        (reach * width, reach * height), rng=rng)
        T_WC0 = T_a @ np.linalg.inv(rig.T_C0_C[a])
        poses.append(T_WC0)
        row = []
        for c, camera in enumerate(rig.cameras):
            T = T_WC0 @ rig.T_C0_C[c]
            show = c == a or (not (solo_every and k % solo_every == 0) and _inside(camera, T, board))
            if show:
                row.append(render(camera, T, board, noise_sigma=noise_sigma, blur_sigma=blur_sigma, rng=rng).image)
            else:
                w, h = camera.size
                row.append(np.clip(np.rint(128.0 + noise_sigma * rng.standard_normal((h, w))), 0, 255).astype(np.uint8))
            seen[k, c] = show
        images.append(row)
    return RigViews(rig, images, seen, poses, board)

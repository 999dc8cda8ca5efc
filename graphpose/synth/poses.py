"""Random poses and polygons for synthetic images: :func:`random_pose` (a camera pose like those
of the real images, with the whole sheet in view, pinhole or through a lens),
:func:`perturb_pose` (a pose guess some degrees and centimetres off, like the real case
files') and :func:`loose_polygon` (a hand-clicked-like bounding polygon of a
:class:`~graphpose.synth.render.Rendering`).
"""

from __future__ import annotations

import numpy as np

from .._checks import check_count, check_number, check_range, check_transform
from ..board import check_board
from ..board import Board
from ..geometry import hat, project, rot_x, rot_z, to_camera
from ..camera_models import as_camera
from ..errors import InputError
from .lens import in_view, view_limit
from .render import Rendering, image_points, image_size


def random_pose(
    camera,
    board: Board = Board(),
    size=None,
    *,
    rng=None,
    distance=(0.8, 1.4),
    max_tilt_deg: float = 35.0,
    max_roll_deg: float = 40.0,
    margin: float = 0.5,
    border_px: float = 8.0,
    max_tries: int = 1000,
) -> np.ndarray:
    """A random camera pose like those of the real images, with the whole sheet in view.

    The board's centre is placed at a depth drawn uniformly from ``distance`` on the ray of
    a uniformly drawn image point; the board is tilted by up to ``max_tilt_deg`` about a
    random in-plane axis and rotated in the image plane by up to ``max_roll_deg`` either
    way. Draws are repeated until every sheet corner lies at least ``border_px`` inside the
    image. With the real camera (f ~ 565 px) the default distances make the sheet about
    250-450 px wide.

    With a distorting camera (:class:`~graphpose.RadTanCamera`,
    :class:`~graphpose.FisheyeCamera`) the image point's ray comes from
    ``camera.unproject``, ``distance`` is measured along it (a fisheye's ray may point
    sideways or backwards), the untilted board faces the camera across that ray rather
    than along the optical axis, and the whole sheet, its curved edges included (32 points
    per edge), must lie inside the model's cone (:func:`graphpose.synth.lens.view_limit`)
    and ``border_px`` inside the distorted image.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        A :mod:`graphpose.camera_models` camera or the intrinsics ``K`` of a pinhole camera,
        pixels.
    board : Board
        The target.
    size : (int, int), optional
        Image ``(width, height)`` in pixels; default ``camera.size``, else (640, 480).
    rng : numpy.random.Generator, int or None, keyword
        Source of randomness (None: fresh entropy).
    distance : (float, float)
        Range of the board centre's depth (distance along the ray for a distorting camera),
        metres.
    max_tilt_deg, max_roll_deg : float
        Largest out-of-plane tilt and in-plane rotation, degrees. Keep the roll below 45
        degrees so that "the upper-left junction" stays unambiguous.
    margin : float
        White margin of the sheet in squares (as in :func:`graphpose.synth.render.render`).
    border_px : float
        Smallest distance of a sheet corner (any point of the sheet's outline, with
        distortion) from the image border, pixels.
    max_tries : int
        Draws before giving up.

    Returns
    -------
    T_WC : (4, 4) ndarray
        Camera pose in the target frame.

    Raises
    ------
    InputError
        If an argument is invalid, or no draw fits the sheet in the image.
    """
    camera = as_camera(camera)
    K = camera.K
    width, height = image_size(camera, size)
    check_board(board)
    lo, hi = check_range("distance", distance, "(near, far) metres", minimum=0.0, strict=True)
    tilt_max = np.deg2rad(check_number("max_tilt_deg", max_tilt_deg, 0.0))
    roll_max = np.deg2rad(check_number("max_roll_deg", max_roll_deg, 0.0))
    if tilt_max >= np.pi / 2:
        raise InputError(f"max_tilt_deg must be below 90, got {max_tilt_deg!r}")
    check_number("margin", margin, 0.0)
    check_number("border_px", border_px)
    check_count("max_tries", max_tries, 1)
    rng = np.random.default_rng(rng)
    sheet = board.sheet_corners(margin)
    centre_W = np.array([(board.cols - 1) / 2, (board.rows - 1) / 2, 0.0]) * board.square_m
    pinhole = camera.model == "pinhole"
    if not pinhole:
        n = 32
        step = np.roll(sheet, -1, axis=1) - sheet
        outline = (sheet[:, :, None] + step[:, :, None] * (np.arange(n) / n)).reshape(3, -1)
        limit = view_limit(camera, (width, height))
    for _ in range(max_tries):
        axis_angle = rng.uniform(-np.pi, np.pi)
        tilt = rot_z(axis_angle) @ rot_x(rng.uniform(0.0, tilt_max)) @ rot_z(-axis_angle)
        R_CW = rot_z(rng.uniform(-roll_max, roll_max)) @ tilt  # target axes seen from the camera
        pixel = rng.uniform([0.0, 0.0], [width - 1.0, height - 1.0])
        if pinhole:
            ray = np.linalg.solve(K, np.append(pixel, 1.0))
            centre_C = rng.uniform(lo, hi) * ray / ray[2]
        else:
            ray = camera.unproject(pixel[:, None])[:, 0]
            centre_C = rng.uniform(lo, hi) * ray
            if not np.all(np.isfinite(ray)):
                continue
            R_CW = _turn_towards(ray) @ R_CW
        T_WC = np.eye(4)
        T_WC[:3, :3] = R_CW.T
        T_WC[:3, 3] = centre_W - R_CW.T @ centre_C
        if pinhole:
            if not np.all(to_camera(T_WC, sheet)[2] > 0):
                continue
            uv = project(K, T_WC, sheet)
        else:
            P_C = to_camera(T_WC, outline)
            if not np.all(in_view(P_C, limit)):
                continue
            uv = camera.project(P_C)
        inside = (uv[0] >= border_px) & (uv[0] <= width - 1 - border_px)
        inside &= (uv[1] >= border_px) & (uv[1] <= height - 1 - border_px)
        if np.all(inside):
            return T_WC
    raise InputError(
        f"no pose in {max_tries} draws puts the whole sheet inside the {width}x{height} image; "
        "use a larger distance or a smaller board"
    )


def loose_polygon(rendering: Rendering, *, rng=None, offset_px=(-4.0, 4.0), inset: bool = False) -> np.ndarray:
    """A hand-clicked-like bounding polygon of a rendered board.

    Parameters
    ----------
    rendering : Rendering
        The image whose board to bound.
    rng : numpy.random.Generator, int or None, keyword
        Source of randomness (None: fresh entropy).
    offset_px : (float, float)
        Range of the uniform perturbation added to each coordinate of each vertex, pixels.
    inset : bool
        If True, put the vertices inside the white margin instead (at a random 25-75 % of
        the margin's width, before the perturbation), as a polygon clicked on the board's
        squares area rather than its sheet would be.

    Returns
    -------
    bounds : (2, 4) ndarray
        Vertices in pixels, clockwise from the one nearest the upper-left junction. Not
        clipped to the image. Under lens distortion the vertices are still moved corners,
        while the sheet's edges between them are curves (barrel distortion bows them
        outwards, beyond the polygon's straight sides).

    Raises
    ------
    InputError
        If ``offset_px`` is not an ordered pair of finite numbers.
    """
    lo, hi = check_range("offset_px", offset_px, "(low, high) pixels")
    rng = np.random.default_rng(rng)
    outline = rendering.outline
    if inset:
        fraction = rng.uniform(0.25, 0.75, 4)
        sheet = rendering.board.sheet_corners(rendering.margin * fraction)
        outline = image_points(rendering.camera, rendering.T_WC, sheet, rendering.size)
    return outline + rng.uniform(lo, hi, (2, 4))


def perturb_pose(T_WC, *, rng=None, angle_deg=(8.0, 12.0), offset_m=(0.15, 0.25)) -> np.ndarray:
    """A pose guess: ``T_WC`` rotated and moved by random amounts, like the real case files.

    Parameters
    ----------
    T_WC : (4, 4) array_like
        The true pose.
    rng : numpy.random.Generator, int or None, keyword
        Source of randomness (None: fresh entropy).
    angle_deg : (float, float)
        Range of the rotation angle (about a uniformly random axis, applied in the camera
        frame), degrees.
    offset_m : (float, float)
        Range of the length of the translation offset (uniformly random direction), metres.

    Returns
    -------
    guess : (4, 4) ndarray
        Perturbed pose.

    Raises
    ------
    InputError
        If ``T_WC`` is not a rigid transform, or ``angle_deg`` or ``offset_m`` is not an
        ordered pair of finite numbers >= 0.
    """
    T = check_transform(T_WC).copy()
    angle_range = check_range("angle_deg", angle_deg, "(low, high) degrees", minimum=0.0)
    offset_range = check_range("offset_m", offset_m, "(low, high) metres", minimum=0.0)
    rng = np.random.default_rng(rng)
    axis, direction = (v / np.linalg.norm(v) for v in rng.normal(size=(2, 3)))
    angle = np.deg2rad(rng.uniform(*angle_range))
    cross = hat(axis)
    R = np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross
    T[:3, :3] = T[:3, :3] @ R
    T[:3, 3] += rng.uniform(*offset_range) * direction
    return T


def _turn_towards(ray: np.ndarray) -> np.ndarray:
    """The rotation about the axis ``z x ray`` that turns the optical axis z onto a unit ray."""
    x, y, z = ray
    s2 = x * x + y * y
    if s2 == 0.0:
        return np.eye(3) if z > 0 else np.diag([1.0, -1.0, -1.0])
    A = np.array([[0.0, 0.0, x], [0.0, 0.0, y], [-x, -y, 0.0]])  # [z x ray]_x
    return np.eye(3) + A + A @ A * (1.0 - z) / s2

"""Synthetic images of the checkerboard target with exact ground truth.

Everything else in graphpose (sub-pixel junctions, poses) is measured against these
images, so the renderer is built to be more exact than any detector.

Image model
-----------
The scene is a grey background, a white sheet (the squares area plus a white margin of
``margin`` squares on every side) and ``(cols + 1) x (rows + 1)`` black squares, the
upper-left one black, as on the real target. Every square and the sheet are planar
quadrilaterals, so under a pinhole camera their images are exactly the quadrilaterals of
their projected corners. The radiance is multiplied by a smooth illumination field
``L(u, v) = 1 + gradient * d(u, v)``, ``d`` linear in the pixel position and spanning
[-1, 1] over the image along the direction ``light_angle_deg``. The optics blur the
continuous image with an isotropic Gaussian of ``blur_sigma`` pixels, each pixel
integrates the blurred image over its square ``[u - 0.5, u + 0.5] x [v - 0.5, v + 0.5]``,
then :func:`render` adds Gaussian noise and quantises to 8 bits.

How it is computed
------------------
1. Exact area: the fraction of every cell of a fine grid (``supersample`` x
   ``supersample`` cells per pixel) covered by the sheet and by the black squares, in
   closed form by Green's theorem over the polygon edges (:func:`polygon_coverage`).
   Regular point supersampling would bias edges that run nearly along the grid by up to
   ~0.1 px; exact areas have no such bias.
2. The fine image (cell averages times the illumination) is treated as piecewise constant
   and convolved with the Gaussian and integrated over each pixel in one step, using the
   closed-form kernel ``k = box(1 px) * Gaussian(blur_sigma) * box(1/S px)``. Blurring the
   continuous image before pixel integration is the physical order; the only residual of
   the fine grid is the symmetric ``1/S``-px cell (no position bias; S = 2 and S = 8 give
   junction positions that agree to well under 0.002 px, see ``tests/synth/test_render.py``).
   With ``blur_sigma == 0`` the image is the exact pixel area at S = 1.
3. Speed: only the sheet's bounding box (plus the kernel's reach) is treated; the rest of
   the image is background times illumination. The coverage is kept sparse (one entry per
   edge piece and cell crossed, plus one per piece to be summed up its column), the blur
   along u is applied to those entries directly, and only then are columns summed and the
   blur along v applied, on an array S times smaller than the fine grid.

Lens distortion
---------------
:func:`render` also takes a :mod:`graphpose.cameras` camera with lens distortion
(:class:`~graphpose.RadTanCamera`, :class:`~graphpose.FisheyeCamera`) and renders the raw,
distorted image. The squares and the sheet are then regions with curved outlines, traced as
polylines whose chords lie within ``edge_tol_px`` of the true curves
(:func:`graphpose.synth.lens.region_edges`), and clipped to the cone of rays the model can
image (:func:`graphpose.synth.lens.view_limit`): a board partly behind the camera, or
beyond a fisheye's range, is drawn where the model images it. Steps 1-3 are unchanged:
exact areas of the polylines, blur before pixel integration, the sheet's bounding box. A
pinhole camera (``K``, or a :class:`~graphpose.PinholeCamera`) takes the path above, with
straight edges and the same results as before cameras existed.

Ground truth: the junctions are ``camera.project(to_camera(T_WC, board.world_points()))``
(``graphpose.camera.project(K, T_WC, ...)`` for a pinhole); NaN for a junction outside the
model's cone.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.ndimage import correlate1d
from scipy.special import ndtr

from .._checks import (
    as_polygon,
    check_board,
    check_count,
    check_number,
    check_range,
    check_size,
    check_transform,
)
from ..board import Board
from ..camera import project, rot_x, rot_z, to_camera
from ..cameras import Camera, as_camera, check_image_size
from ..errors import InputError
from .lens import in_view, region_edges, view_limit

#: The Gaussian kernel reaches this many sigmas; the tail beyond holds < 3e-7 of the mass.
_TRUNCATE = 5.0


@dataclass(frozen=True)
class Rendering:
    """A synthetic image and its exact ground truth.

    Attributes
    ----------
    image : (H, W) ndarray
        uint8 grey levels when quantised, else float64 grey levels (0..255 scale).
    junctions : (2, n) ndarray
        Exact pixel positions (u, v) of the board's inner cross-junctions, row-major
        (``camera.project`` of the board's points; NaN for a junction outside the cone of
        rays the camera model images, :func:`graphpose.synth.lens.view_limit`).
    outline : (2, 4) ndarray
        Corners of the white sheet in pixels, clockwise from the one nearest the
        upper-left junction (NaN as for ``junctions``). Under lens distortion the sheet's
        edges between them are curves.
    K : (3, 3) ndarray
        Intrinsics, pixels (``camera.K``).
    T_WC : (4, 4) ndarray
        Camera pose in the target frame.
    board : Board
        The target.
    size : tuple of int
        ``(width, height)`` in pixels.
    margin : float
        White margin of the sheet, in squares.
    blur_sigma : float
        Optical Gaussian blur, pixels.
    noise_sigma : float
        Additive Gaussian noise, grey levels of 255.
    camera : Camera
        The camera (:mod:`graphpose.cameras`); a :class:`~graphpose.PinholeCamera` when
        rendered from ``K``.
    """

    image: np.ndarray
    junctions: np.ndarray
    outline: np.ndarray
    K: np.ndarray
    T_WC: np.ndarray
    board: Board
    size: tuple
    margin: float
    blur_sigma: float
    noise_sigma: float
    camera: Camera


# --------------------------------------------------------------------------- public API


def render_ideal(
    camera,
    T_WC,
    board: Board = Board(),
    size=None,
    *,
    margin: float = 0.5,
    blur_sigma: float = 1.0,
    gradient: float = 0.15,
    light_angle_deg: float = 30.0,
    supersample: int = 4,
    background: float = 60.0,
    white: float = 215.0,
    black: float = 35.0,
    edge_tol_px: float = 1e-4,
) -> np.ndarray:
    """Noise-free image of the board, before quantisation.

    Pure and deterministic, so callers may average it over sub-frame poses for motion blur.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        A :mod:`graphpose.cameras` camera (the raw, distorted image is rendered), or the
        intrinsics ``K`` of a pinhole camera, pixels.
    T_WC : (4, 4) array_like
        Camera pose in the target frame (see :mod:`graphpose.camera`).
    board : Board
        The target; its squares area spans ``[-s, cols * s] x [-s, rows * s]`` metres.
    size : (int, int), optional
        Image ``(width, height)`` in pixels; default ``camera.size``, else (640, 480).
    margin : float
        White margin around the squares, in squares (the real target has ~0.3-0.5).
    blur_sigma : float
        Standard deviation of the optical Gaussian blur, pixels (0: none).
    gradient : float
        Illumination field amplitude in [0, 1): the field runs from ``1 - gradient`` to
        ``1 + gradient`` across the image.
    light_angle_deg : float
        Direction in which the illumination increases, degrees from +u towards +v.
    supersample : int
        Fine cells per pixel along each axis used under blur (ignored, i.e. 1, when
        ``blur_sigma == 0``, where the exact pixel area needs no fine grid). Junction
        positions are within ~0.0005 px of the continuous model when
        ``supersample * blur_sigma >= 4`` (0.002 px at 2, 0.006 px at 1.2); the default
        4 suits ``blur_sigma`` near 1, sharper blurs want more.
    background, white, black : float
        Grey levels (0..255 scale) of the background, the sheet and the squares under
        unit illumination.
    edge_tol_px : float
        Lens distortion only: the largest distance, pixels, between a curved edge of the
        board's image and the polyline that draws it (its chords' sagitta), near the image.
        The default 1e-4 px moves edges, and so junctions, by about that much at most:
        far below any detector's error. Ignored by a pinhole camera, whose edges are
        straight.

    Returns
    -------
    image : (H, W) ndarray of float64
        Grey levels, not clipped.

    Raises
    ------
    InputError
        If the camera or T_WC is invalid, ``size`` is not two positive integers or not the
        camera's size, a setting is out of range, or, for a pinhole camera, a corner of the
        sheet is not in front of the camera (a distorting camera draws what its model
        images instead).
    """
    camera = as_camera(camera)
    T_WC = check_transform(T_WC)
    width, height = _image_size(camera, size)
    check_board(board)
    check_number("margin", margin, 0.0)
    check_number("blur_sigma", blur_sigma, 0.0)
    check_number("light_angle_deg", light_angle_deg)
    for name, level in (("background", background), ("white", white), ("black", black)):
        check_number(name, level)
    gradient = check_number("gradient", gradient, 0.0)
    if gradient >= 1.0:
        raise InputError(f"gradient must be in [0, 1), got {gradient!r}")
    check_count("supersample", supersample, 1)
    edge_tol_px = check_number("edge_tol_px", edge_tol_px, 0.0, strict=True)
    sheet = board.sheet_corners(margin)
    if camera.model == "pinhole" and np.any(to_camera(T_WC, sheet)[2] <= 0):
        raise InputError("the board sheet is not entirely in front of the camera (a corner has depth <= 0)")
    S = int(supersample) if blur_sigma > 0 else 1
    light = _Light(width, height, gradient, np.deg2rad(light_angle_deg))
    image = background * light(*np.meshgrid(np.arange(width), np.arange(height)))
    _add_board(image, camera, T_WC, board, margin, blur_sigma, S, light, background, white, black, edge_tol_px)
    return image


def render(
    camera,
    T_WC,
    board: Board = Board(),
    size=None,
    *,
    noise_sigma: float = 2.0,
    rng=None,
    quantize: bool = True,
    **ideal,
) -> Rendering:
    """Synthetic camera image of the board with its exact ground truth.

    Parameters
    ----------
    camera, T_WC, board, size
        As in :func:`render_ideal`: a :mod:`graphpose.cameras` camera renders the raw
        (distorted) image, a ``K`` the pinhole one.
    noise_sigma : float
        Standard deviation of the additive Gaussian noise, grey levels of 255 (0: none).
    rng : numpy.random.Generator, int or None
        Source of the noise (an int seeds a new generator; None draws fresh entropy).
    quantize : bool
        Clip to [0, 255] and round to uint8 (True), or return float64 grey levels.
    **ideal
        Keyword settings of :func:`render_ideal` (margin, blur_sigma, gradient, ...).

    Returns
    -------
    Rendering
        Image, exact junctions (2, n), sheet outline (2, 4), the camera and the settings.

    Raises
    ------
    InputError
        As :func:`render_ideal`, or if ``noise_sigma`` is negative or not finite.
    """
    noise_sigma = check_number("noise_sigma", noise_sigma, 0.0)
    rng = np.random.default_rng(rng)
    image = render_ideal(camera, T_WC, board, size, **ideal)
    if noise_sigma > 0:
        image = image + rng.normal(0.0, noise_sigma, image.shape)
    if quantize:
        image = np.clip(np.rint(image), 0, 255).astype(np.uint8)
    camera = as_camera(camera)
    T_WC = np.asarray(T_WC, dtype=float)
    margin = float(ideal.get("margin", 0.5))
    return Rendering(
        image=image,
        junctions=image_points(camera, T_WC, board.world_points(), image.shape[::-1]),
        outline=image_points(camera, T_WC, board.sheet_corners(margin), image.shape[::-1]),
        K=camera.K.copy(),
        T_WC=T_WC.copy(),
        board=board,
        size=(image.shape[1], image.shape[0]),
        margin=margin,
        blur_sigma=float(ideal.get("blur_sigma", 1.0)),
        noise_sigma=noise_sigma,
        camera=camera,
    )


def image_points(camera, T_WC, P_W, size=None) -> np.ndarray:
    """Exact pixels of target points as :func:`render` draws them.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        A :mod:`graphpose.cameras` camera or a pinhole ``K``.
    T_WC : (4, 4) array_like
        Camera pose in the target frame.
    P_W : (3, N) array_like
        Target points, metres.
    size : (int, int), optional
        Image ``(width, height)``; default ``camera.size``, else (640, 480) (it sets how far
        a radial-tangential model that never folds is followed, see
        :func:`graphpose.synth.lens.view_limit`).

    Returns
    -------
    uv : (2, N) ndarray
        Pixels: ``graphpose.camera.project(K, T_WC, P_W)`` for a pinhole camera, else
        ``camera.project(to_camera(T_WC, P_W))`` with NaN columns for points outside the
        cone of rays the model images (where ``project`` folds back).
    """
    camera = as_camera(camera)
    if camera.model == "pinhole":
        return project(camera.K, T_WC, P_W)
    P_C = to_camera(T_WC, P_W)
    uv = camera.project(P_C)
    uv[:, ~in_view(P_C, view_limit(camera, _image_size(camera, size)))] = np.nan
    return uv


def random_pose(
    rng,
    camera,
    board: Board = Board(),
    size=None,
    *,
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
    rng : numpy.random.Generator or int
        Source of randomness.
    camera : Camera or (3, 3) array_like
        A :mod:`graphpose.cameras` camera or the intrinsics ``K`` of a pinhole camera,
        pixels.
    board : Board
        The target.
    size : (int, int), optional
        Image ``(width, height)`` in pixels; default ``camera.size``, else (640, 480).
    distance : (float, float)
        Range of the board centre's depth (distance along the ray for a distorting camera),
        metres.
    max_tilt_deg, max_roll_deg : float
        Largest out-of-plane tilt and in-plane rotation, degrees. Keep the roll below 45
        degrees so that "the upper-left junction" stays unambiguous.
    margin : float
        White margin of the sheet in squares (as in :func:`render`).
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
    width, height = _image_size(camera, size)
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


def loose_polygon(rendering: Rendering, rng, *, offset_px=(-4.0, 4.0), inset: bool = False) -> np.ndarray:
    """A hand-clicked-like bounding polygon of a rendered board.

    Parameters
    ----------
    rendering : Rendering
        The image whose board to bound.
    rng : numpy.random.Generator or int
        Source of randomness.
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


def perturb_pose(rng, T_WC, *, angle_deg=(8.0, 12.0), offset_m=(0.15, 0.25)) -> np.ndarray:
    """A pose guess: ``T_WC`` rotated and moved by random amounts, like the real case files.

    Parameters
    ----------
    rng : numpy.random.Generator or int
        Source of randomness.
    T_WC : (4, 4) array_like
        The true pose.
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
    cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    R = np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross
    T[:3, :3] = T[:3, :3] @ R
    T[:3, 3] += rng.uniform(*offset_range) * direction
    return T


def junction_information(
    camera,
    T_WC,
    board: Board = Board(),
    size=None,
    *,
    half_width: int = 7,
    noise_sigma: float = 2.0,
    delta: float | None = None,
    **ideal,
) -> np.ndarray:
    """Fisher information of each junction's image position, from the noise-free image.

    With independent Gaussian noise of ``noise_sigma`` on every pixel, a window of
    ``(2 * half_width + 1)^2`` pixels centred on the rounded junction carries
    ``FIM = sum_p g_p g_p^T / noise_sigma^2`` about the junction's position, where
    ``g_p = dI_p / d(u, v)`` is the change of pixel p as the local pattern translates.
    ``inv(FIM)`` is the Cramer-Rao bound: the smallest covariance (px^2) of any unbiased
    estimate of the junction from that window. Quantisation adds about 1/12 grey level^2
    of variance; pass ``noise_sigma = sqrt(s^2 + 1/12)`` to include it.

    ``g`` comes from :func:`image_gradients`: a central difference of two renders with the
    principal point shifted by ``+-delta`` px (shifting ``cx`` or ``cy`` translates the
    board's whole image by the same amount, exactly, while the illumination stays put; with
    lens distortion too, since the models distort normalised coordinates before ``K``).
    The rendered image is piecewise linear in the board's position, with kinks every
    ``1 / supersample`` px, so ``delta`` defaults to half that: the difference then spans
    one fine cell and the gradient is within ~1 % (S = 4) of the continuous model's.

    Parameters
    ----------
    camera, T_WC, board, size
        As in :func:`render_ideal` (a camera with lens distortion, or a pinhole ``K``).
    half_width : int
        Half the window side, pixels; windows are clipped to the image.
    noise_sigma : float
        Noise standard deviation, grey levels (> 0).
    delta : float, optional
        Principal point shift for the central difference, pixels; default
        ``0.5 / supersample``.
    **ideal
        Keyword settings of :func:`render_ideal`.

    Returns
    -------
    fim : (n, 2, 2) ndarray
        Information matrices in 1/px^2, row-major junction order, (u, v) order.

    Raises
    ------
    InputError
        As :func:`render_ideal`, or if ``half_width`` or ``noise_sigma`` or ``delta`` is
        not positive.
    """
    check_count("half_width", half_width, 1)
    noise_sigma = check_number("noise_sigma", noise_sigma, 0.0, strict=True)
    if delta is not None:
        check_number("delta", delta, 0.0, strict=True)
    camera = as_camera(camera)
    gu, gv = image_gradients(camera, T_WC, board, size, delta=delta, **ideal)
    height, width = gu.shape
    uv = image_points(camera, check_transform(T_WC), board.world_points(), (width, height))
    centres = np.rint(np.nan_to_num(uv, nan=-1e6)).astype(int)  # out of view: an empty window
    fim = np.zeros((board.n, 2, 2))
    for j, (u, v) in enumerate(centres.T):
        rows = slice(max(v - half_width, 0), max(min(v + half_width + 1, height), 0))
        cols = slice(max(u - half_width, 0), max(min(u + half_width + 1, width), 0))
        g = np.stack([gu[rows, cols].ravel(), gv[rows, cols].ravel()])
        fim[j] = g @ g.T
    return fim / noise_sigma**2


def image_gradients(camera, T_WC, board: Board = Board(), size=None, *, delta: float | None = None, **ideal):
    """Derivatives of the noise-free image with respect to a translation of the board's image.

    Parameters
    ----------
    camera, T_WC, board, size, **ideal
        As in :func:`render_ideal`.
    delta : float, optional
        Principal point shift of the central difference, pixels; default
        ``0.5 / supersample`` (see :func:`junction_information`).

    Returns
    -------
    du, dv : (H, W) ndarray of float64
        Grey levels per pixel of translation along u and along v.

    Raises
    ------
    InputError
        As :func:`render_ideal`.
    """
    camera = as_camera(camera)
    size = _image_size(camera, size)
    K = camera.K
    if delta is None:
        delta = 0.5 / (ideal.get("supersample", 4) if ideal.get("blur_sigma", 1.0) > 0 else 1)
    out = []
    for axis in (0, 1):
        shifted = [K.copy(), K.copy()]
        shifted[0][axis, 2] += delta
        shifted[1][axis, 2] -= delta
        if camera.model != "pinhole":  # the same lens, moved across the sensor
            shifted = [replace(camera, K=Ks) for Ks in shifted]
        plus, minus = (render_ideal(Ks, T_WC, board, size, **ideal) for Ks in shifted)
        out.append((plus - minus) / (2 * delta))
    return tuple(out)


def polygon_coverage(polygons, size) -> np.ndarray:
    """Exact fraction of every pixel covered by polygons.

    Parameters
    ----------
    polygons : (2, m) array_like or sequence of them
        Simple polygons in pixel coordinates (either orientation). Pixel ``(u, v)``
        covers ``[u - 0.5, u + 0.5] x [v - 0.5, v + 0.5]``. Several polygons must not
        overlap (their coverages add).
    size : (int, int)
        Image ``(width, height)``.

    Returns
    -------
    coverage : (H, W) ndarray of float64
        Covered area of each pixel, px^2 (0..1); parts outside the image are dropped.

    Raises
    ------
    InputError
        If a polygon is not a finite (2, m) array with m >= 3, or size is invalid.
    """

    width, height = check_size(size)
    if isinstance(polygons, np.ndarray) and polygons.ndim == 2:
        polygons = [polygons]
    polys = [as_polygon(P, "polygon") + 0.5 for P in polygons]
    return _coverage(polys, height, width)


# --------------------------------------------------------------------------- rasterisation


def _coverage(polys, h: int, w: int, weights=None) -> np.ndarray:
    """Covered area of each unit cell ``[i, i+1] x [j, j+1]`` (array entry [j, i]), (h, w).

    With ``weights`` (one per polygon) the result is the weighted sum of the coverages.
    """
    (full_row, full_col, full_w), (row, col, part_w) = _coverage_entries(polys, h, w, weights)
    area = np.bincount(full_row * w + full_col, full_w, h * w).reshape(h, w)
    _sum_upwards(area)
    area += np.bincount(row * w + col, part_w, h * w).reshape(h, w)
    return area


def _coverage_entries(polys, h: int, w: int, weights=None):
    """Sparse form of :func:`_coverage`: ``(full, partial)`` triplets ``(row, col, value)``.

    The coverage is ``sum_upwards(full) + partial``, where ``sum_upwards`` adds each
    entry into every cell of its column at or above its row.

    Green's theorem with ``F = 1[i <= x <= i+1] clamp(y - j, 0, 1)`` (so dF/dy is the
    cell's indicator) gives ``area(P ∩ cell) = -∮_P F dx`` for a positively oriented P.
    Each edge is cut at integer x; on a piece of width ``dx`` the integrand's mean is the
    mean of ``clamp`` of a linear function, in closed form (the partial entries). Cells the
    piece passes entirely below (``y >= j + 1``) get the full ``dx``: one full entry per
    piece, spread upwards later; cells it passes above get nothing. Cells outside the grid
    are dropped, which clips the polygons to it exactly.
    """
    edges, gains = [], []
    for P, gain in zip(polys, np.ones(len(polys)) if weights is None else weights):
        x, y = P
        if np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) < 0:  # make it positive
            x, y = x[::-1], y[::-1]
        edges.append(np.stack([x, y, np.roll(x, -1), np.roll(y, -1)]))
        gains.append(np.full(x.size, float(gain)))
    return _segment_entries(np.concatenate(edges, axis=1), np.concatenate(gains), h, w)


def _segment_entries(segments, gains, h: int, w: int):
    """:func:`_coverage_entries` of oriented segments ``(x0, y0, x1, y1)`` (4, n) with a gain
    each, which together form positively oriented closed outlines (in any order)."""
    x0, y0, x1, y1 = segments
    keep = x0 != x1
    x0, y0, x1, y1 = x0[keep], y0[keep], x1[keep], y1[keep]
    slope = (y1 - y0) / (x1 - x0)
    sign = np.sign(x1 - x0) * gains[keep]
    xl, xr = np.minimum(x0, x1), np.maximum(x0, x1)
    c_lo = np.maximum(np.floor(xl), 0).astype(np.int64)
    c_hi = np.minimum(np.ceil(xr) - 1, w - 1).astype(np.int64)
    count = np.maximum(c_hi - c_lo + 1, 0)
    edge = np.repeat(np.arange(x0.size), count)
    col = c_lo[edge] + np.arange(edge.size) - np.repeat(np.cumsum(count) - count, count)
    xa = np.maximum(xl[edge], col)
    xb = np.minimum(xr[edge], col + 1)
    ya = y0[edge] + (xa - x0[edge]) * slope[edge]
    yb = y0[edge] + (xb - x0[edge]) * slope[edge]
    weight = -sign[edge] * (xb - xa)
    lo, hi = np.minimum(ya, yb), np.maximum(ya, yb)
    k0 = np.floor(lo).astype(np.int64)
    k1 = np.ceil(hi).astype(np.int64) - 1

    # Full entries: rows j < k0, recorded at row min(k0 - 1, h - 1).
    full_row = np.minimum(k0 - 1, h - 1)
    ok = full_row >= 0
    full = full_row[ok], col[ok], weight[ok]

    # Partial entries: rows k0..k1 that the piece crosses, the mean of clamp(y - k, 0, 1).
    r_lo = np.maximum(k0, 0)
    r_hi = np.minimum(k1, h - 1)
    n_rows = np.maximum(r_hi - r_lo + 1, 0)
    piece = np.repeat(np.arange(col.size), n_rows)
    row = r_lo[piece] + np.arange(piece.size) - np.repeat(np.cumsum(n_rows) - n_rows, n_rows)
    mean = _mean_clamp(lo[piece] - row, hi[piece] - row)
    return full, (row, col[piece], weight[piece] * mean)


def _sum_upwards(a: np.ndarray) -> None:
    """In place, ``a[j] = sum(a[j:])`` along axis 0.

    A row loop: numpy's cumsum along axis 0 is several times slower on large arrays.
    """
    for j in range(a.shape[0] - 2, -1, -1):
        np.add(a[j], a[j + 1], out=a[j])


def _mean_clamp(t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """Mean of ``clamp(t, 0, 1)`` over ``t`` in ``[t0, t1]`` (``t0 <= t1``), stable as t1 -> t0."""
    span = t1 - t0
    a, b = np.clip(t0, 0.0, 1.0), np.clip(t1, 0.0, 1.0)
    above = np.maximum(t1, 1.0) - np.maximum(t0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = ((b - a) * (a + b) / 2 + above) / span
    return np.where(span > 0, mean, a)


class _Light:
    """The illumination field ``1 + gradient * d(u, v)``, d linear, in [-1, 1] on the image."""

    def __init__(self, width: int, height: int, gradient: float, angle: float):
        cu, cv = (width - 1) / 2, (height - 1) / 2
        reach = max(cu * abs(np.cos(angle)) + cv * abs(np.sin(angle)), 1.0)
        self.a = gradient * np.cos(angle) / reach
        self.b = gradient * np.sin(angle) / reach
        self.c = 1.0 - self.a * cu - self.b * cv

    def __call__(self, u, v):
        return self.c + self.a * u + self.b * v


def _turn_towards(ray: np.ndarray) -> np.ndarray:
    """The rotation about the axis ``z x ray`` that turns the optical axis z onto a unit ray."""
    x, y, z = ray
    s2 = x * x + y * y
    if s2 == 0.0:
        return np.eye(3) if z > 0 else np.diag([1.0, -1.0, -1.0])
    A = np.array([[0.0, 0.0, x], [0.0, 0.0, y], [-x, -y, 0.0]])  # [z x ray]_x
    return np.eye(3) + A + A @ A * (1.0 - z) / s2


def _black_squares_world(board: Board) -> np.ndarray:
    """Corners of the black squares, (k, 3, 4) metres; square (0, 0) is the upper-left one."""
    i, j = np.meshgrid(np.arange(board.cols + 1), np.arange(board.rows + 1))
    keep = (i + j) % 2 == 0
    x = (i[keep] - 1.0) * board.square_m
    y = (j[keep] - 1.0) * board.square_m
    s = board.square_m
    corners_x = np.stack([x, x + s, x + s, x], axis=1)
    corners_y = np.stack([y, y, y + s, y + s], axis=1)
    return np.stack([corners_x, corners_y, np.zeros_like(corners_x)], axis=1)


def _image_size(camera, size) -> tuple:
    """``(width, height)``: ``size``, else the camera's, else (640, 480); InputError if the
    camera's size is another."""
    if size is None:
        return camera.size if camera.size is not None else (640, 480)
    width, height = check_size(size)
    check_image_size(camera, (height, width), what="the rendered image (size)")
    return width, height


def _add_board(image, camera, T_WC, board, margin, sigma, S, light, background, white, black, tol):
    """Add the board's departure from the background into ``image`` (H, W), in place."""
    height, width = image.shape
    reach = int(np.ceil(_TRUNCATE * sigma)) + 1  # kernel reach in pixels
    squares = _black_squares_world(board)
    gains = [white - background] + [black - white] * len(squares)
    if camera.model == "pinhole":
        K = camera.K
        sheet = project(K, T_WC, board.sheet_corners(margin))
    else:  # curved outlines: polyline segments in pixels
        window = (-reach - 1.0, -reach - 1.0, width + reach, height + reach)
        limit = view_limit(camera, (width, height))
        segments, weights = region_edges(camera, T_WC, [board.sheet_corners(margin), *squares], gains, window,
                                         tol, limit)
        if segments.shape[1] == 0:
            return
        sheet = np.hstack([segments[:2], segments[2:]])  # every end point, for the bounding box
    u0 = max(int(np.floor(sheet[0].min())) - reach - 1, -reach)
    u1 = min(int(np.ceil(sheet[0].max())) + reach + 2, width + reach)
    v0 = max(int(np.floor(sheet[1].min())) - reach - 1, -reach)
    v1 = min(int(np.ceil(sheet[1].max())) + reach + 2, height + reach)
    cu0, cv0 = max(u0, 0), max(v0, 0)
    cu1, cv1 = min(u1, width), min(v1, height)
    if cu1 <= cu0 or cv1 <= cv0:
        return  # the sheet and its blur lie wholly outside the image
    # Fine grid: cell (i, j) spans u in u0 - 0.5 + [i, i + 1] / S, likewise v.
    origin = np.array([[u0 - 0.5], [v0 - 0.5]])
    fine = lambda P: (P - origin) * S  # noqa: E731
    h, w = (v1 - v0) * S, (u1 - u0) * S
    if camera.model == "pinhole":
        polys = [fine(sheet)] + [fine(project(K, T_WC, Q)) for Q in squares]
        full, partial = _coverage_entries(polys, h, w, gains)
    else:
        full, partial = _segment_entries(np.vstack([fine(segments[:2]), fine(segments[2:])]), weights, h, w)
    # The fine image is light * coverage. Its x-pass (blur and integration along u, down to
    # pixel columns) is applied to the sparse entries directly; full entries still have to
    # be summed upwards, which commutes with the x-pass for the u-part of the light,
    # c + a u, while its v-part, b v, is constant along each row and applied afterwards.
    k = _kernel(sigma, S, reach)
    u_fine = lambda col: (col + 0.5) / S + u0 - 0.5  # noqa: E731
    v_fine = (np.arange(h) + 0.5) / S + v0 - 0.5
    row, col, value = full
    rows, vertical = _x_pass(row, col, [value * (light.c + light.a * u_fine(col)), value], k, S, h, u1 - u0)
    _sum_upwards(rows)
    if light.b != 0:
        _sum_upwards(vertical)
        rows += (light.b * v_fine)[:, None] * vertical
    row, col, value = partial
    rows += _x_pass(row, col, [value * light(u_fine(col), v_fine[row])], k, S, h, u1 - u0)[0]
    blurred = sum(correlate1d(rows[b::S, :], k[:, b], axis=0, mode="constant") for b in range(S))
    image[cv0:cv1, cu0:cu1] += blurred[cv0 - v0 : cv1 - v0, cu0 - u0 : cu1 - u0]


def _kernel(sigma: float, S: int, reach: int) -> np.ndarray:
    """Weights ``k[a, b]`` of fine cell ``(p + a) * S + b`` in pixel p, ``a = -reach..reach``.

    ``k = ∫_{x in [0, 1]} ∫_{y in [d/S, (d+1)/S]} G(x - y) dy dx`` with ``d = a * S + b``:
    the Gaussian blur and the pixel's integration of a piecewise constant fine image.
    """
    d = np.arange(-reach * S, (reach + 1) * S).reshape(2 * reach + 1, S)
    c, e = d / S, (d + 1) / S
    if sigma == 0:
        return np.clip(np.minimum(e, 1.0) - np.maximum(c, 0.0), 0.0, None)

    def H(z):  # antiderivative of Phi(z / sigma)
        return z * ndtr(z / sigma) + sigma * np.exp(-0.5 * (z / sigma) ** 2) / np.sqrt(2 * np.pi)

    return (H(1 - c) - H(-c)) - (H(1 - e) - H(-e))


def _x_pass(row, col, values, k, S: int, h: int, w: int) -> list:
    """Blur and integrate along u a sparse fine image given as entries, giving (h, w) arrays.

    Entry ``(row, col, value)`` sits in fine column ``col = p * S + b``; pixel column
    ``p - a`` receives ``value * k[a + reach, b]`` for ``a = -reach..reach``. ``values`` is
    a list of value arrays sharing the positions; one output per value array.
    """
    reach = (k.shape[0] - 1) // 2
    p, b = np.divmod(col, S)
    wide = w + 2 * reach  # room for the kernel's reach beyond either side, cut off below
    index = (row * wide + p + 2 * reach)[:, None] - np.arange(2 * reach + 1)
    kernel = k.T[b]
    # astype: with no entries at all, np.bincount returns int64 even with float weights.
    sums = (np.bincount(index.ravel(), (kernel * v[:, None]).ravel(), h * wide).astype(float, copy=False)
            for v in values)
    return [a.reshape(h, wide)[:, reach : reach + w] for a in sums]


# --------------------------------------------------------------------------- validation

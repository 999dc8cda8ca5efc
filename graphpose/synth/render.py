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
   closed form by Green's theorem over the polygon edges
   (:func:`graphpose.synth.raster.polygon_coverage`).
   Regular point supersampling would bias edges that run nearly along the grid by up to
   ~0.1 px; exact areas have no such bias.
2. The fine image (cell averages times the illumination) is treated as piecewise constant
   and convolved with the Gaussian and integrated over each pixel in one step, using the
   closed-form kernel ``k = box(1 px) * Gaussian(blur_sigma) * box(1/S px)``
   (:func:`graphpose.synth.raster.pixel_kernel`). Blurring the
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
:func:`render` also takes a :mod:`graphpose.camera_models` camera with lens distortion
(:class:`~graphpose.RadTanCamera`, :class:`~graphpose.FisheyeCamera`) and renders the raw,
distorted image. The squares and the sheet are then regions with curved outlines, traced as
polylines whose chords lie within ``edge_tol_px`` of the true curves
(:func:`graphpose.synth.lens.region_edges`), and clipped to the cone of rays the model can
image (:func:`graphpose.synth.lens.view_limit`): a board partly behind the camera, or
beyond a fisheye's range, is drawn where the model images it. Steps 1-3 are unchanged:
exact areas of the polylines, blur before pixel integration, the sheet's bounding box. A
pinhole camera (``K``, or a :class:`~graphpose.PinholeCamera`) takes the path above, with
straight edges and the images of the exact polygons (no polyline chords).

Around the rendering: :mod:`graphpose.synth.raster` holds the exact areas and the kernel
(steps 1-2), :mod:`graphpose.synth.poses` the random poses and polygons
(:func:`~graphpose.synth.poses.random_pose`, :func:`~graphpose.synth.poses.perturb_pose`,
:func:`~graphpose.synth.poses.loose_polygon`), :mod:`graphpose.synth.information` the
junctions' Cramer-Rao bound (:func:`~graphpose.synth.information.junction_information`).

Ground truth: the junctions are ``camera.project(to_camera(T_WC, board.world_points()))``
(``graphpose.geometry.project(K, T_WC, ...)`` for a pinhole; on a bent board, ``warp``, the
points ``board.warped(board.world_points(), warp)``); NaN for a junction outside the model's
cone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import correlate1d

from .._checks import check_count, check_number, check_size, check_transform
from ..board import check_board
from ..board import Board
from ..geometry import project, to_camera
from ..camera_models import Camera, as_camera, check_image_size
from ..errors import InputError
from .lens import in_view, region_edges, view_limit
from .raster import coverage_entries, pixel_kernel, segment_entries, sum_upwards, x_pass

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
        The camera (:mod:`graphpose.camera_models`); a :class:`~graphpose.PinholeCamera` when
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
    warp=None,
) -> np.ndarray:
    """Noise-free image of the board, before quantisation.

    Pure and deterministic, so callers may average it over sub-frame poses for motion blur.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        A :mod:`graphpose.camera_models` camera (the raw, distorted image is rendered), or the
        intrinsics ``K`` of a pinhole camera, pixels.
    T_WC : (4, 4) array_like
        Camera pose in the target frame (see :mod:`graphpose.geometry`).
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
    warp : (2,) array_like, optional
        A bent board: mrcal's board warp ``(w_x, w_y)``, metres (:meth:`Board.warp_basis`;
        the sag at the centre is ``w_x + w_y``). Every corner of the squares and the sheet is
        moved out of the plane by it, and each square drawn between its moved corners (its
        edges the chords between them: over a square of a board of ``c`` columns the curve
        departs from the chord by ``sag / c^2`` at most, 0.04 mm for 3 mm over 9 columns).
        None: flat.

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
    width, height = image_size(camera, size)
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
    sheet = board.warped(board.sheet_corners(margin), warp)
    if camera.model == "pinhole" and np.any(to_camera(T_WC, sheet)[2] <= 0):
        raise InputError("the board sheet is not entirely in front of the camera (a corner has depth <= 0)")
    S = int(supersample) if blur_sigma > 0 else 1
    light = _Light(width, height, gradient, np.deg2rad(light_angle_deg))
    image = background * light(*np.meshgrid(np.arange(width), np.arange(height)))
    _add_board(image, camera, T_WC, board, margin, blur_sigma, S, light, background, white, black, edge_tol_px,
               warp)
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
        As in :func:`render_ideal`: a :mod:`graphpose.camera_models` camera renders the raw
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
        junctions=image_points(camera, T_WC, board.warped(board.world_points(), ideal.get("warp")),
                               image.shape[::-1]),
        outline=image_points(camera, T_WC, board.warped(board.sheet_corners(margin), ideal.get("warp")),
                             image.shape[::-1]),
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
        A :mod:`graphpose.camera_models` camera or a pinhole ``K``.
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
        Pixels: ``graphpose.geometry.project(K, T_WC, P_W)`` for a pinhole camera, else
        ``camera.project(to_camera(T_WC, P_W))`` with NaN columns for points outside the
        cone of rays the model images (where ``project`` folds back).
    """
    camera = as_camera(camera)
    if camera.model == "pinhole":
        return project(camera.K, T_WC, P_W)
    P_C = to_camera(T_WC, P_W)
    uv = camera.project(P_C)
    uv[:, ~in_view(P_C, view_limit(camera, image_size(camera, size)))] = np.nan
    return uv


def image_size(camera, size) -> tuple:
    """The size of an image rendered through ``camera``, as the renderer's functions take it.

    Parameters
    ----------
    camera : Camera
        A :mod:`graphpose.camera_models` camera (already checked, :func:`graphpose.camera_models.as_camera`).
    size : (int, int) or None
        Image ``(width, height)`` in pixels, or None for the camera's.

    Returns
    -------
    (width, height) : tuple of int
        ``size``, else ``camera.size``, else (640, 480).

    Raises
    ------
    InputError
        If ``size`` is not two positive integers, or not the camera's size.
    """
    if size is None:
        return camera.size if camera.size is not None else (640, 480)
    width, height = check_size(size)
    check_image_size(camera, (height, width), what="the rendered image (size)")
    return width, height


# --------------------------------------------------------------------------- the board's image


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


def _add_board(image, camera, T_WC, board, margin, sigma, S, light, background, white, black, tol, warp=None):
    """Add the board's departure from the background into ``image`` (H, W), in place."""
    height, width = image.shape
    reach = int(np.ceil(_TRUNCATE * sigma)) + 1  # kernel reach in pixels
    squares = _black_squares_world(board)
    if warp is not None:
        squares = np.stack([board.warped(Q, warp) for Q in squares])
    gains = [white - background] + [black - white] * len(squares)
    if camera.model == "pinhole":
        K = camera.K
        sheet = project(K, T_WC, board.warped(board.sheet_corners(margin), warp))
    else:  # curved outlines: polyline segments in pixels
        window = (-reach - 1.0, -reach - 1.0, width + reach, height + reach)
        limit = view_limit(camera, (width, height))
        segments, weights = region_edges(camera, T_WC, [board.warped(board.sheet_corners(margin), warp), *squares], gains, window,
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
        full, partial = coverage_entries(polys, h, w, gains)
    else:
        full, partial = segment_entries(np.vstack([fine(segments[:2]), fine(segments[2:])]), weights, h, w)
    # The fine image is light * coverage. Its x-pass (blur and integration along u, down to
    # pixel columns) is applied to the sparse entries directly; full entries still have to
    # be summed upwards, which commutes with the x-pass for the u-part of the light,
    # c + a u, while its v-part, b v, is constant along each row and applied afterwards.
    k = pixel_kernel(sigma, S, reach)
    u_fine = lambda col: (col + 0.5) / S + u0 - 0.5  # noqa: E731
    v_fine = (np.arange(h) + 0.5) / S + v0 - 0.5
    row, col, value = full
    rows, vertical = x_pass(row, col, [value * (light.c + light.a * u_fine(col)), value], k, S, h, u1 - u0)
    sum_upwards(rows)
    if light.b != 0:
        sum_upwards(vertical)
        rows += (light.b * v_fine)[:, None] * vertical
    row, col, value = partial
    rows += x_pass(row, col, [value * light(u_fine(col), v_fine[row])], k, S, h, u1 - u0)[0]
    blurred = sum(correlate1d(rows[b::S, :], k[:, b], axis=0, mode="constant") for b in range(S))
    image[cv0:cv1, cu0:cu1] += blurred[cv0 - v0 : cv1 - v0, cu0 - u0 : cu1 - u0]

"""Degraded renders with exact truth: the noise, blur, light and compression of real cameras.

:func:`render_degraded` renders the board as :func:`graphpose.synth.render.render` does and
then passes the image through a camera's imperfections, in the physical order, as set by a
:class:`Degradation`:

1. **Motion blur** (``motion_px``): the average of :func:`~graphpose.synth.render.render_ideal`
   over sub-frame poses along a straight camera translation in its own image plane, sampled
   symmetrically about the mid-exposure pose (midpoint rule, one sub-frame per
   ``subframe_px`` of image motion at the board's centre). Under a pinhole camera every
   point's image then moves along a straight line at constant speed, so each junction's blur
   path is symmetric about its mid-exposure position: **the truth is the mid-exposure pose's
   junctions**, ``Rendering.T_WC`` is that pose.
2. **Defocus** (``defocus_px``): a pillbox (disc) of that radius, applied to the pixel image
   as a kernel whose taps are the exact areas of the disc in each pixel cell (see
   :func:`disc_kernel`), i.e. the disc convolved with the pixel's box, sampled at whole
   pixels. Optical Gaussian blur stays the renderer's own ``blur_sigma`` (before pixel
   integration).
3. **Vignetting** (``vignetting``): the cos^4 law of a lens, ``(1 + r^2 / f^2)^-2`` about
   the image centre, with ``f`` chosen so that the image's corners lose that fraction of the
   light (:func:`vignette`).
4. **Exposure** (``exposure``): the sensor collects that fraction of the normal light.
5. **Sensor noise**: shot noise (Poisson photo-electrons, ``shot_gain`` grey levels each, so
   the variance is ``shot_gain * signal``) plus Gaussian read noise (``noise_sigma``):
   variance ``shot_gain * signal + noise_sigma^2`` grey levels^2 (:func:`sensor_noise`).
6. **Quantisation** to 8 bits (clipped to 0..255), then a digital **gain** (``gain``, by
   default ``1 / exposure``) that brightens a dark image with its noise and its coarse
   levels, quantised again.
7. **JPEG** compression (``jpeg_quality``, Pillow, in memory) and decompression.

Low contrast is a property of the scene: pass ``black``, ``white`` and ``background`` grey
levels to :func:`render_degraded` as to :func:`~graphpose.synth.render.render_ideal`.

Every blur here is point-symmetric, and vignetting, noise, gain and JPEG change grey levels
only, so the junctions' truth is the renderer's: ``Rendering.junctions`` is the projection
of the board's points at ``Rendering.T_WC``. ``tests/synth/test_degrade.py`` measures that a
saddle fit of the noise-free image lands on it: within 0.001 px under a defocus of 4 px or a
Gaussian blur of 4 px, 0.008 px under a motion of 4 px at a tilt (the blur's length varies
with depth across the board), 0.023 px at 60 % vignetting (a slope of the light biases the
fit, as the renderer's own illumination gradient does).
"""

from __future__ import annotations

import io
from dataclasses import dataclass, replace

import numpy as np
from scipy.ndimage import correlate

from .._checks import check_count, check_image, check_number, check_transform
from ..board import Board
from ..camera_models import as_camera
from ..geometry import to_camera
from ..errors import InputError
from .render import Rendering, render, render_ideal

#: Largest pillbox radius and motion length, pixels, the module is built and tested for.
MAX_BLUR_PX = 16.0


@dataclass(frozen=True)
class Degradation:
    """What a camera does to the image after the scene: blur, light, noise, compression.

    The stages run in the order of the module docstring. The default is the renderer's
    plain image without noise.

    Attributes
    ----------
    noise_sigma : float
        Additive Gaussian (read) noise at the sensor, grey levels of 255.
    shot_gain : float
        Grey levels per photo-electron (0: no shot noise); the shot-noise variance is
        ``shot_gain * signal`` grey levels^2, ``signal`` the exposed grey level.
    defocus_px : float
        Radius of the defocus pillbox (disc), pixels (0: none).
    motion_px : float
        Length of the motion blur at the board's centre during the exposure, pixels (0: none).
    motion_angle_deg : float
        Direction of the image motion, degrees from +u towards +v.
    subframe_px : float
        Image motion at the board's centre per sub-frame render, pixels.
    vignetting : float
        Fraction of the light lost at the image's corners, in [0, 1) (cos^4 law).
    exposure : float
        Fraction of the normal exposure the sensor collects, in (0, 1].
    gain : float or None
        Digital gain after 8-bit quantisation; None for ``1 / exposure``.
    jpeg_quality : int or None
        JPEG quality 1..95 of a compression round trip (None: none).
    """

    noise_sigma: float = 0.0
    shot_gain: float = 0.0
    defocus_px: float = 0.0
    motion_px: float = 0.0
    motion_angle_deg: float = 0.0
    subframe_px: float = 0.5
    vignetting: float = 0.0
    exposure: float = 1.0
    gain: float | None = None
    jpeg_quality: int | None = None


def check_degradation(d) -> Degradation:
    """``d`` if it is a valid :class:`Degradation`; :class:`~graphpose.errors.InputError` naming
    the first setting out of range otherwise."""
    if not isinstance(d, Degradation):
        raise InputError(f"degradation must be a graphpose.synth.Degradation, got {type(d).__name__}")
    check_number("noise_sigma", d.noise_sigma, 0.0)
    check_number("shot_gain", d.shot_gain, 0.0)
    check_number("defocus_px", d.defocus_px, 0.0, maximum=MAX_BLUR_PX)
    check_number("motion_px", d.motion_px, 0.0, maximum=MAX_BLUR_PX)
    check_number("motion_angle_deg", d.motion_angle_deg)
    check_number("subframe_px", d.subframe_px, 0.0, strict=True)
    check_number("vignetting", d.vignetting, 0.0)
    if d.vignetting >= 1.0:
        raise InputError(f"vignetting must be in [0, 1), got {d.vignetting!r}")
    check_number("exposure", d.exposure, 0.0, strict=True, maximum=1.0)
    if d.gain is not None:
        check_number("gain", d.gain, 0.0, strict=True)
    if d.jpeg_quality is not None:
        _check_quality(d.jpeg_quality)
    return d


def render_degraded(camera, T_WC, board: Board = Board(), size=None, degradation: Degradation = Degradation(),
                    *, rng=None, **ideal) -> Rendering:
    """A rendered board through a camera's imperfections, with its exact truth.

    Parameters
    ----------
    camera, T_WC, board, size
        As in :func:`graphpose.synth.render.render_ideal`. ``T_WC`` is the mid-exposure
        pose.
    degradation : Degradation
        What happens to the image (module docstring).
    rng : numpy.random.Generator, int or None
        Source of the noise (an int seeds a new generator; None draws fresh entropy).
    **ideal
        Keyword settings of :func:`~graphpose.synth.render.render_ideal` (blur_sigma,
        black, white, background, gradient, ...).

    Returns
    -------
    Rendering
        ``image`` (H, W) uint8; ``junctions`` and ``outline`` at the mid-exposure pose
        ``T_WC``; ``noise_sigma`` the read noise. With the default degradation but
        ``noise_sigma``, the image is :func:`~graphpose.synth.render.render`'s for the same
        ``rng``.

    Raises
    ------
    InputError
        As :func:`~graphpose.synth.render.render_ideal`, or if a setting of the degradation
        is out of range.
    """
    d = check_degradation(degradation)
    rng = np.random.default_rng(rng)
    truth = render(camera, T_WC, board, size, noise_sigma=0.0, quantize=False, **ideal)
    if d.motion_px > 0:
        image = motion_blur_ideal(camera, T_WC, board, size, motion_px=d.motion_px,
                                  angle_deg=d.motion_angle_deg, subframe_px=d.subframe_px, **ideal)
    else:
        image = truth.image
    return replace(truth, image=degrade(image, d, rng=rng), noise_sigma=float(d.noise_sigma))


def degrade(image, degradation: Degradation, *, rng=None) -> np.ndarray:
    """Stages 2-7 of the module docstring (all but motion blur) on an ideal image.

    Parameters
    ----------
    image : (H, W) array_like
        Noise-free grey levels (0..255 scale), e.g. from
        :func:`~graphpose.synth.render.render_ideal`.
    degradation : Degradation
        The settings (its motion blur is ignored: that needs the scene).
    rng : numpy.random.Generator, int or None
        Source of the noise.

    Returns
    -------
    (H, W) ndarray of uint8
    """
    d = check_degradation(degradation)
    image = np.asarray(check_image(image, colour=False), dtype=float)
    rng = np.random.default_rng(rng)
    if d.defocus_px > 0:
        image = defocus(image, d.defocus_px)
    if d.vignetting > 0:
        image = vignette(image, d.vignetting)
    signal = d.exposure * image if d.exposure != 1.0 else image
    out = quantize(sensor_noise(signal, d.noise_sigma, d.shot_gain, rng=rng))
    gain = 1.0 / d.exposure if d.gain is None else d.gain
    if gain != 1.0:
        out = quantize(gain * out)
    if d.jpeg_quality is not None:
        out = jpeg_roundtrip(out, d.jpeg_quality)
    return out


def quantize(image) -> np.ndarray:
    """Grey levels rounded to the nearest integer and clipped to 0..255, as uint8."""
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def sensor_noise(signal, noise_sigma: float = 0.0, shot_gain: float = 0.0, *, rng=None) -> np.ndarray:
    """Shot and read noise of a sensor: variance ``shot_gain * signal + noise_sigma^2``.

    Parameters
    ----------
    signal : (H, W) array_like
        Exposed grey levels (negative values count as 0 for the shot noise).
    noise_sigma : float
        Gaussian read noise, grey levels.
    shot_gain : float
        Grey levels per photo-electron: the signal holds ``signal / shot_gain`` electrons,
        drawn from a Poisson law (0: no shot noise).
    rng : numpy.random.Generator, int or None
        Source of the noise.

    Returns
    -------
    (H, W) ndarray of float64
        Noisy grey levels, not clipped. With ``shot_gain == 0`` exactly
        ``signal + rng.normal(0, noise_sigma, shape)``, the renderer's noise.
    """
    noise_sigma = check_number("noise_sigma", noise_sigma, 0.0)
    shot_gain = check_number("shot_gain", shot_gain, 0.0)
    rng = np.random.default_rng(rng)
    out = np.asarray(signal, dtype=float)
    if shot_gain > 0:
        out = shot_gain * rng.poisson(np.maximum(out, 0.0) / shot_gain).astype(float)
    if noise_sigma > 0:
        out = out + rng.normal(0.0, noise_sigma, out.shape)
    return out


def disc_kernel(radius_px: float, *, normalise: bool = True) -> np.ndarray:
    """A defocus pillbox on the pixel grid: the area of a disc in each pixel cell.

    Parameters
    ----------
    radius_px : float
        The disc's radius, pixels, in (0, :data:`MAX_BLUR_PX`].
    normalise : bool
        Divide by the sum (True), or return the raw areas, pixels^2 (their sum is
        ``pi * radius_px**2``: the areas are in closed form).

    Returns
    -------
    (2h + 1, 2h + 1) ndarray of float64
        Tap ``[h + dv, h + du]`` is the area of the disc centred on pixel (0, 0) inside the
        cell ``[du - 0.5, du + 0.5] x [dv - 0.5, dv + 0.5]``, ``h = ceil(radius_px - 0.5)``.
        Point-symmetric (and symmetric under the square's eight symmetries).
    """
    r = check_number("radius_px", radius_px, 0.0, strict=True, maximum=MAX_BLUR_PX)
    h = int(np.ceil(r - 0.5))
    edges = np.arange(-h, h + 2) - 0.5
    q = _quadrant_area(edges[None, :], edges[:, None], r)  # signed areas of the disc below-left of grid nodes
    areas = q[1:, 1:] - q[1:, :-1] - q[:-1, 1:] + q[:-1, :-1]
    areas = np.clip(0.5 * (areas + areas.T), 0.0, None)  # rounding only: exact symmetry, no -1e-17
    return areas / areas.sum() if normalise else areas


def defocus(image, radius_px: float) -> np.ndarray:
    """The image seen out of focus: correlated with :func:`disc_kernel` (edges mirrored).

    Parameters
    ----------
    image : (H, W) array_like
        Grey levels.
    radius_px : float
        Radius of the blur disc, pixels (0: the image unchanged).

    Returns
    -------
    (H, W) ndarray of float64
    """
    image = np.asarray(image, dtype=float)
    if check_number("radius_px", radius_px, 0.0, maximum=MAX_BLUR_PX) == 0:
        return image.copy()
    return correlate(image, disc_kernel(radius_px), mode="mirror")


def vignette(image, corner_loss: float, *, centre=None) -> np.ndarray:
    """A lens's vignetting: the cos^4 law ``(1 + r^2 / f^2)^-2`` multiplying the image.

    Parameters
    ----------
    image : (H, W) array_like
        Grey levels.
    corner_loss : float
        Fraction of the light lost at the image corner farthest from ``centre``, in [0, 1);
        ``f`` (pixels) follows from it.
    centre : (float, float), optional
        ``(u, v)`` of the falloff's centre, pixels; default the image's centre
        ``((W - 1) / 2, (H - 1) / 2)``.

    Returns
    -------
    (H, W) ndarray of float64
    """
    image = np.asarray(image, dtype=float)
    loss = check_number("corner_loss", corner_loss, 0.0)
    if loss >= 1.0:
        raise InputError(f"corner_loss must be in [0, 1), got {corner_loss!r}")
    height, width = image.shape
    cu, cv = ((width - 1) / 2, (height - 1) / 2) if centre is None else (float(c) for c in centre)
    v, u = np.mgrid[0:height, 0:width]
    r2 = (u - cu) ** 2 + (v - cv) ** 2
    corner2 = max((x - cu) ** 2 + (y - cv) ** 2 for x in (0, width - 1) for y in (0, height - 1))
    if loss == 0 or corner2 == 0:
        return image.copy()
    inv_f2 = ((1.0 - loss) ** -0.5 - 1.0) / corner2  # (1 + corner2 / f^2)^-2 == 1 - loss
    return image / (1.0 + r2 * inv_f2) ** 2


def jpeg_roundtrip(image, quality: int) -> np.ndarray:
    """The 8-bit image after JPEG compression at ``quality`` and decompression (Pillow, in memory).

    Parameters
    ----------
    image : (H, W) array_like of uint8
        Grey levels.
    quality : int
        JPEG quality, 1..95 (Pillow's scale; 75 is its default).

    Returns
    -------
    (H, W) ndarray of uint8
    """
    from PIL import Image

    image = check_image(image, colour=False)
    if image.dtype != np.uint8:
        raise InputError(f"jpeg_roundtrip takes 8-bit grey levels (uint8), got {image.dtype}")
    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="JPEG", quality=_check_quality(quality))
    buffer.seek(0)
    with Image.open(buffer) as decoded:
        return np.asarray(decoded.convert("L"), dtype=np.uint8).copy()


def motion_blur_ideal(camera, T_WC, board: Board = Board(), size=None, *, motion_px: float,
                      angle_deg: float = 0.0, subframe_px: float = 0.5, **ideal) -> np.ndarray:
    """Noise-free image of a camera translating in its image plane during the exposure.

    Parameters
    ----------
    camera, T_WC, board, size
        As in :func:`~graphpose.synth.render.render_ideal`; ``T_WC`` is the mid-exposure pose.
    motion_px : float
        Image motion of the board's centre over the exposure, pixels, in
        [0, :data:`MAX_BLUR_PX`].
    angle_deg : float
        Direction of that motion in the image, degrees from +u towards +v.
    subframe_px : float
        Motion per sub-frame, pixels: ``ceil(motion_px / subframe_px)`` renders are averaged,
        at the midpoints of equal parts of the exposure.
    **ideal
        Settings of :func:`~graphpose.synth.render.render_ideal`.

    Returns
    -------
    (H, W) ndarray of float64
        The average of the sub-frame renders (grey levels, not clipped).
    """
    camera = as_camera(camera)
    T_WC = check_transform(T_WC)
    motion = check_number("motion_px", motion_px, 0.0, maximum=MAX_BLUR_PX)
    angle = np.deg2rad(check_number("angle_deg", angle_deg))
    step = check_number("subframe_px", subframe_px, 0.0, strict=True)
    m = max(1, int(np.ceil(motion / step - 1e-9)))
    centre = board.sheet_corners(0.0).mean(axis=1, keepdims=True)
    depth = float(to_camera(T_WC, centre)[2, 0])
    fx, fy = camera.K[0, 0], camera.K[1, 1]
    # Moving the camera by d (its frame) moves an image point at depth Z by -f d / Z.
    travel = -motion * depth * np.array([np.cos(angle) / fx, np.sin(angle) / fy, 0.0])
    total = None
    for i in range(m):
        T = T_WC.copy()
        T[:3, 3] += T_WC[:3, :3] @ (((i + 0.5) / m - 0.5) * travel)
        frame = render_ideal(camera, T, board, size, **ideal)
        total = frame if total is None else total + frame
    return total / m


def _quadrant_area(x, y, r):
    """Signed area of the disc of radius ``r`` about 0 inside ``[0, x] x [0, y]`` (negative when
    one of ``x``, ``y`` is), in closed form; arrays broadcast."""
    sx, sy = np.sign(x), np.sign(y)
    x, y = np.minimum(np.abs(x), r), np.minimum(np.abs(y), r)
    t = np.sqrt(np.maximum(r * r - y * y, 0.0))  # where the circle crosses height y

    def below_arc(a):  # integral of sqrt(r^2 - s^2) from 0 to a
        return 0.5 * (a * np.sqrt(np.maximum(r * r - a * a, 0.0)) + r * r * np.arcsin(np.minimum(a / r, 1.0)))

    inside = x * x + y * y <= r * r
    area = np.where(inside, x * y, y * t + below_arc(x) - below_arc(np.minimum(t, x)))
    return sx * sy * area


def _check_quality(quality) -> int:
    q = check_count("jpeg_quality", quality, 1)
    if q > 95:
        raise InputError(f"jpeg_quality must be an integer in 1..95, got {quality!r}")
    return q

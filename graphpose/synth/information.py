"""How much a rendered image says about its junctions: :func:`image_gradients` (the noise-free
image's derivatives with respect to a translation of the board's image) and
:func:`junction_information` (each junction's Fisher information from them, whose inverse is
the Cramer-Rao bound).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .._checks import check_count, check_number, check_transform
from ..board import Board
from ..camera_models import as_camera
from .render import image_points, image_size, render_ideal


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
        As in :func:`~graphpose.synth.render.render_ideal` (a camera with lens distortion,
        or a pinhole ``K``).
    half_width : int
        Half the window side, pixels; windows are clipped to the image.
    noise_sigma : float
        Noise standard deviation, grey levels (> 0).
    delta : float, optional
        Principal point shift for the central difference, pixels; default
        ``0.5 / supersample``.
    **ideal
        Keyword settings of :func:`~graphpose.synth.render.render_ideal`.

    Returns
    -------
    fim : (n, 2, 2) ndarray
        Information matrices in 1/px^2, row-major junction order, (u, v) order.

    Raises
    ------
    InputError
        As :func:`~graphpose.synth.render.render_ideal`, or if ``half_width`` or
        ``noise_sigma`` or ``delta`` is not positive.
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
        As in :func:`~graphpose.synth.render.render_ideal`.
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
        As :func:`~graphpose.synth.render.render_ideal`.
    """
    camera = as_camera(camera)
    size = image_size(camera, size)
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

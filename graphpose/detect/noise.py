"""The image's noise level, measured from the image itself.

The search (:mod:`.find`) and the refinement (:mod:`.refine`) set their sensitivity from
it: how far the saddle response must rise above what noise alone makes, and how much to
smooth before fitting a saddle.

The estimator is Immerkaer's (1996) mask, the difference of two discrete Laplacians,

    [[ 1, -2,  1],
     [-2,  4, -2],
     [ 1, -2,  1]],

whose response is zero on any image that is linear, and on any quadratic without a
cross term, over its 3 x 3 pixels: smooth shading, gradients and vignetting vanish, and
only edges and junctions (a small part of the image) and the noise remain. Its taps' squares
sum to 36, so white noise of ``sigma`` grey levels gives a response of standard deviation
``6 sigma``; instead of Immerkaer's mean of absolute values, the median of absolute values
(over 0.6745, the median of ``|N(0, 1)|``) is used, which the edges of a board, up to half
the pixels, do not move. Rows and columns are taken every ``stride`` pixels (the default
4 reads a sixteenth of the mask's positions, some 19,000 at 640 x 480): the noise is the same everywhere, and so is its estimate.

Quantisation to whole grey levels adds its own noise (1/12 grey level squared), which is
also noise to the search: it is part of the figure.

References
----------
J. Immerkaer, "Fast noise variance estimation", Computer Vision and Image Understanding
64(2), 1996, pp. 300-302.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from . import _search
from .search import _kernel_grey

#: Median of |N(0, 1)|: turns a median absolute value into a standard deviation.
_MAD_TO_SIGMA = 1.0 / 0.6744897501960817

#: Most pixel positions either estimate reads: the stride grows past the one asked for where
#: the image would give more, so that a 12 MP image costs what a VGA one does (a median of
#: 2^17 samples is within about 0.3 % of the whole image's, far below the estimate's own
#: 10 %). A 640 x 480 image, or a board's crop in one, stays below it at the strides used.
MAX_SAMPLES = 2**17


def _stride(shape, stride: int) -> int:
    """``stride``, or the smallest larger one that reads at most :data:`MAX_SAMPLES` positions."""
    h, w = shape
    while (-(-h // stride)) * (-(-w // stride)) > MAX_SAMPLES:
        stride += 1
    return stride


def estimate_noise(image: np.ndarray, *, stride: int = 4) -> float:
    """Standard deviation of the image's pixel noise, in the image's grey units.

    Parameters
    ----------
    image : (H, W) ndarray
        Grey image (uint8 or float), at least 3 x 3 pixels.
    stride : int
        The mask is evaluated at every ``stride``-th row and column (>= 1), or sparser where
        that would read more than :data:`MAX_SAMPLES` positions.

    Returns
    -------
    float
        Noise sigma (grey levels for an 8-bit image): the median absolute response of the
        mask over 6 and over 0.6745. White Gaussian noise of sigma 1-20 grey levels on a
        rendered board is measured within about 10 %; a clean 8-bit image reads about 0.3
        (its quantisation, and the board's edges).

    Raises
    ------
    InputError
        If the image is not 2-D, is smaller than 3 x 3, or ``stride`` is not a whole
        number >= 1.
    """
    if image.ndim != 2 or min(image.shape) < 3:
        raise InputError(f"estimate_noise takes a grey (H, W) image of at least 3 x 3 pixels, "
                         f"got shape {image.shape}")
    if int(stride) != stride or stride < 1:
        raise InputError(f"stride must be a whole number >= 1, got {stride!r}")
    h, w = image.shape
    s = _stride((h - 2, w - 2), int(stride))

    # Each row's [1, -2, 1] along the row, then [1, -2, 1] down the three rows: one compiled
    # pass over the positions read. On an 8-bit image the responses are whole numbers up to
    # 16 x 255, and their median is counted (``_search.noise_median_u8``); else they are
    # float32 (``_search.noise_response``) and partitioned. The same median either way.
    if image.dtype == np.uint8:
        median = _search.noise_median_u8(image, s, np.empty(16 * 255 + 1, dtype=np.intp))
        return 0.0 if median < 0 else median * _MAD_TO_SIGMA / 6.0
    response = np.empty((-(-(h - 2) // s)) * (-(-(w - 2) // s)), dtype=np.float32)
    _search.noise_response(_kernel_grey(image), s, response)
    if response.size == 0:
        return 0.0
    median = np.partition(response, response.size // 2)[response.size // 2]
    return float(median) * _MAD_TO_SIGMA / 6.0


def grey_range(image: np.ndarray, *, stride: int = 3, tail: float = 1.0) -> float:
    """The image's grey range: its ``100 - tail`` th percentile less its ``tail`` th (the
    nearest sample's), over every ``stride``-th row and column (sparser past
    :data:`MAX_SAMPLES` positions), in the image's grey units (the scale
    :func:`estimate_noise` is read against: a board's black and white squares, or the
    scene's darkest and brightest)."""
    stride = _stride(image.shape, int(stride))
    values = image[::stride, ::stride]  # a view: copied only where partitioned
    if values.size == 0:
        return 0.0
    k = np.rint(np.array([tail, 100.0 - tail]) / 100.0 * (values.size - 1)).astype(np.intp)
    if image.dtype == np.uint8:  # the two grey levels counted, in one compiled pass
        _search.kth_grey_u8(image, stride, k, out := np.empty(2, dtype=np.intp))
        lo, hi = out
    else:
        lo, hi = np.partition(values.ravel(), k)[k]
    return float(hi) - float(lo)


def bounding_window(image: np.ndarray, points) -> np.ndarray:
    """The part of ``image`` inside the bounding box of ``points`` (2, m) pixels (u, v),
    clipped to the image and at least one pixel: where a board's (or its bounds') grey range
    is read."""
    P = np.asarray(points, dtype=float)
    h, w = image.shape
    lo = np.clip(np.floor(np.nanmin(P, axis=1)).astype(int), 0, [w - 1, h - 1])
    hi = np.clip(np.ceil(np.nanmax(P, axis=1)).astype(int) + 1, lo + 1, [w, h])
    return image[lo[1]:hi[1], lo[0]:hi[0]]

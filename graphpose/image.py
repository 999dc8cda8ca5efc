"""Images in: reading files and converting arrays to the grey float images the detector reads.

Pixel conventions are in :mod:`graphpose.camera`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._checks import check_image
from .errors import InputError

#: ITU-R BT.601 luma weights for R, G, B.
_LUMA = np.array([0.299, 0.587, 0.114])


def as_grey(image, *, min_side: int = 1) -> np.ndarray:
    """Convert an image to a float64 grey array scaled to [0, 1].

    Parameters
    ----------
    image : (H, W), (H, W, 3) or (H, W, 4) array_like
        uint8 (scaled by 1/255), uint16 (by 1/65535), bool, or float (kept as is).
        Colour is converted with ITU-R 601 luma weights; alpha is dropped.
    min_side : int
        Smallest height and width accepted, pixels.

    Returns
    -------
    grey : (H, W) ndarray of float64
        A grey float64 image is returned itself, not copied (the tracker passes each frame
        through here several times): treat the result as read-only.

    Raises
    ------
    InputError
        As :func:`graphpose._checks.check_image`: empty, another shape or a non-numeric
        dtype, smaller than ``min_side``, or NaN or infinite values.
    """
    I = check_image(image, min_side=min_side)
    if I.ndim == 3:
        I = I[..., :3]
    if I.dtype == np.uint8:
        I = I.astype(float) / 255.0
    elif I.dtype == np.uint16:
        I = I.astype(float) / 65535.0
    else:
        I = I.astype(float, copy=False)
    return I @ _LUMA if I.ndim == 3 else I


def read_image(path) -> np.ndarray:
    """Read an image file as float64 grey in [0, 1], shape (H, W).

    Raises
    ------
    InputError
        If the file is missing, is a folder, or cannot be decoded as an image.
    """
    from skimage import io as skio

    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path} is a folder, not an image file")
    if not path.is_file():
        raise InputError(f"image file not found: {path}")
    try:
        data = skio.imread(str(path))
    except Exception as exc:  # decoders raise many types; all mean "not an image"
        raise InputError(f"cannot read image {path}: {exc}") from None
    return as_grey(data)

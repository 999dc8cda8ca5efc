"""Images in: reading files and converting arrays to the grey float images the detector reads.

Pixel conventions are in :mod:`graphpose.camera`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import InputError

#: ITU-R BT.601 luma weights for R, G, B.
_LUMA = np.array([0.299, 0.587, 0.114])


def as_grey(image) -> np.ndarray:
    """Convert an image to a float64 grey array scaled to [0, 1].

    Parameters
    ----------
    image : (H, W), (H, W, 3) or (H, W, 4) array_like
        uint8 (scaled by 1/255), uint16 (by 1/65535), bool, or float (kept as is).
        Colour is converted with ITU-R 601 luma weights; alpha is dropped.

    Returns
    -------
    grey : (H, W) ndarray of float64
        A grey float64 image is returned itself, not copied (the tracker passes each frame
        through here several times): treat the result as read-only.

    Raises
    ------
    InputError
        If the array is empty, has another shape, or holds NaN or infinite values.
    """
    I = np.asarray(image)
    if I.size == 0:
        raise InputError("image is empty")
    if I.ndim == 3 and I.shape[2] in (3, 4):
        return _finite(_scale(I[..., :3]) @ _LUMA)
    if I.ndim != 2:
        raise InputError(f"image must be 2-D grey or (H, W, 3|4) colour, got shape {I.shape}")
    return _finite(_scale(I))


def _scale(I: np.ndarray) -> np.ndarray:
    if I.dtype == np.uint8:
        return I.astype(float) / 255.0
    if I.dtype == np.uint16:
        return I.astype(float) / 65535.0
    if I.dtype.kind in "biuf":
        return I.astype(float, copy=False)
    raise InputError(f"image has unsupported dtype {I.dtype}")


def _finite(I: np.ndarray) -> np.ndarray:
    if not np.all(np.isfinite(I)):
        raise InputError("image contains NaN or infinite values")
    return I


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

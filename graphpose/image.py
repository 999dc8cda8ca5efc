"""Images in: reading files and converting arrays to the grey images the detector reads.

Pixel conventions are in :mod:`graphpose.geometry`.
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np

from ._checks import check_image
from ._pixels import grey_view
from ._png import SIGNATURE, decode_grey8
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


#: Pillow modes read straight to 8-bit grey by the decoder (``as_float=False``).
_EIGHT_BIT_MODES = {"L", "P", "RGB", "RGBA", "LA", "CMYK", "YCbCr", "1"}


def read_image(path, *, as_float: bool = False) -> np.ndarray:
    """Read an image file as grey, shape (H, W): what an 8-bit file holds, as uint8.

    The pixels are the sensor's: no EXIF rotation is applied (a calibration describes the
    sensor's own rows and columns; an image turned by its EXIF tag would not match it).

    Parameters
    ----------
    path : str or path-like
        Any format scikit-image / imageio reads (PNG, JPEG, TIFF, BMP, ...).
    as_float : bool
        False (default): an 8-bit file (grey, palette or colour) comes as uint8 grey,
        converted by the decoder itself (ITU-R 601 luma in integers; a JPEG is decoded
        straight to its luma plane), which every graphpose function reads as it is (the
        detector without converting it: 1/8 of the memory of float64 and no conversion pass
        over the image); other files (16-bit grey, float) come as float64 in [0, 1]. True:
        float64 grey in [0, 1] whatever the file, as :func:`as_grey` makes it (for arithmetic
        on the pixels). (Pillow reads 16-bit colour files as 8-bit colour, on both paths.)

    Returns
    -------
    grey : (H, W) ndarray of uint8 for an 8-bit file, else of float64 in [0, 1] (always
        float64 with ``as_float``).

    Raises
    ------
    InputError
        If the file is missing, is a folder, or cannot be decoded as an image.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path} is a folder, not an image file")
    if not path.is_file():
        raise InputError(f"image file not found: {path}")
    if path.stat().st_size == 0:  # no decoder to ask (imageio would try every plugin it has)
        raise InputError(f"cannot read image {path}: {_unreadable(path)}")
    if not as_float:
        grey = _read_eight_bit(path)
        if grey is not None:
            return check_image(grey, colour=False)
    from skimage import io as skio

    try:
        data = skio.imread(str(path))
    except Exception:  # decoders raise many types; all mean "not an image"
        raise InputError(f"cannot read image {path}: {_unreadable(path)}") from None
    return as_grey(data)


#: File name endings of the formats graphpose's readers decode (Pillow through scikit-image).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm")


def _unreadable(path: Path) -> str:
    """Why a file no decoder read is not an image, in words that say what to do.

    The decoders' own messages are no help here: for a PNG cut short, imageio's last
    fallback says that no backend was found and to install a video plugin. An empty file, or
    one of a known image ending or whose first bytes Pillow recognises, is a broken file.
    """
    if path.stat().st_size == 0:
        return "not a readable image (the file is empty: truncated or corrupt)"
    if path.suffix.lower() in IMAGE_SUFFIXES or _known_format(path):
        return "not a readable image (truncated or corrupt)"
    return ("not a readable image (truncated or corrupt, or not an image file at all: graphpose reads PNG, "
            "JPEG, TIFF, BMP, PGM, PPM and the other formats Pillow knows)")


def _known_format(path: Path) -> bool:
    """Whether Pillow recognises the file's first bytes as an image format it knows."""
    from PIL import Image

    try:
        with open(path, "rb") as f:
            head = f.read(64)
    except OSError:
        return False
    Image.init()
    return any(accept is not None and bool(accept(head)) for _, accept in Image.OPEN.values())


def _read_eight_bit(path: Path):
    """The file as uint8 grey: an 8-bit grey PNG by :func:`graphpose._png.decode_grey8`, any
    other file through Pillow's decoder; None when it is not 8-bit (or Pillow cannot open it:
    the general reader then says why)."""
    source = path
    try:
        with open(path, "rb") as f:
            data = f.read(len(SIGNATURE))
            if data == SIGNATURE:  # a PNG: read whole, decoded here if it can be
                data += f.read()
                grey = decode_grey8(data, _pillow_pixel_limit())
                if grey is not None:
                    return grey
                source = io.BytesIO(data)  # Pillow reads the rest of PNG, from the bytes read
    except OSError:
        return None  # unreadable (permissions, a read error): the general reader says why
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(source) as im:
            if im.mode not in _EIGHT_BIT_MODES:
                return None
            if im.format == "JPEG":
                im.draft("L", im.size)  # decode the luma plane only, at full size
            grey = _pixels_of(im if im.mode == "L" else im.convert("L"))
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError, Image.DecompressionBombError):
        return None  # the general reader says why
    return grey


#: Pillow's default decompression-bomb limit (``PIL.Image.MAX_IMAGE_PIXELS``, 1024^3 / 12 pixels).
_PILLOW_PIXEL_LIMIT = 1024 * 1024 * 1024 // 4 // 3


def _pillow_pixel_limit() -> int | None:
    """``PIL.Image.MAX_IMAGE_PIXELS`` as the caller left it where Pillow is imported, else its
    default: a grey PNG that graphpose decodes itself needs no Pillow import (30 ms)."""
    image = sys.modules.get("PIL.Image")
    return _PILLOW_PIXEL_LIMIT if image is None else image.MAX_IMAGE_PIXELS


def _pixels_of(im) -> np.ndarray:
    """The decoded pixels of an 8-bit grey (mode L) Pillow image as a read-only (H, W) uint8
    array (as ``np.asarray`` of an image has always been): its own memory where Pillow
    exports it (:func:`graphpose._pixels.grey_view`, through the Arrow C data interface: at
    12 MP that spares a 10-20 ms copy and its 12 MB), else a copy (``np.asarray``: a Pillow
    without the export, or an image whose rows Pillow keeps in several memory blocks, over
    its 16 MB block size)."""
    im.load()
    try:
        view = grey_view(*im.__arrow_c_array__(), im.size[1], im.size[0])
    except (AttributeError, ValueError):
        view = None
    return np.asarray(im) if view is None else np.asarray(view)

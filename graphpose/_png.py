"""The common PNG, 8-bit grey and not interlaced, decoded straight to an array.

Pillow decodes every PNG, but on an 8-bit grey 640 x 480 frame it spends about twice what
inflating its data takes (its decoder runs row by row through Python-level chunk reading): a
millisecond a frame that a tracker reading recorded frames pays every frame. This module reads
the one kind of PNG a camera or a recorder writes for a grey sensor: bit depth 8, colour type 0
(grey), no interlace. Its chunks are walked and their CRCs checked, its IDAT data inflated in one
call of :mod:`zlib` (capped at the image's size), and its row filters undone in one compiled pass
(:func:`graphpose._png_filters.png_unfilter_grey8`). Any other PNG, and any PNG that is not exactly
what its specification says (a bad CRC, a missing or short IDAT stream, trailing data in it, an
unknown filter, a chunk cut short, IDAT chunks not all in one run), is left to Pillow (:func:`decode_grey8` returns None), which
reads the rest of the format and words the errors.

Ancillary chunks do not change the pixels Pillow gives for such an image (``gAMA``, ``tRNS``,
``tEXt``, ``pHYs``, ...): they are skipped, as Pillow's grey pixels skip them.

Reference: ISO/IEC 15948 (PNG), sections 5 (datastream), 9 (filtering) and 11 (chunks).
"""

from __future__ import annotations

import struct
import zlib

import numpy as np

from ._png_filters import png_unfilter_grey8

#: The eight bytes every PNG file starts with.
SIGNATURE = b"\x89PNG\r\n\x1a\n"


def decode_grey8(data: bytes, max_pixels: int | None = None) -> np.ndarray | None:
    """The pixels of an 8-bit grey, non-interlaced PNG file's bytes, or None.

    Parameters
    ----------
    data : bytes
        The whole file.
    max_pixels : int, optional
        Larger images are left to Pillow (whose decompression-bomb check then speaks).

    Returns
    -------
    (H, W) ndarray of uint8, read-only, or None
        None for any other PNG (another bit depth, colour type or interlace), for a file that
        is not a PNG, and for one that breaks the specification: the caller hands those to
        Pillow.
    """
    if data[:8] != SIGNATURE:
        return None
    view = memoryview(data)
    header, idat, pos, size, idat_done = None, [], 8, len(data), False
    while True:
        if pos + 12 > size:
            return None  # cut short before IEND
        length, kind = struct.unpack_from(">I4s", data, pos)
        start, end = pos + 8, pos + 8 + length
        if end + 4 > size:
            return None
        if zlib.crc32(view[start:end], zlib.crc32(kind)) != struct.unpack_from(">I", data, end)[0]:
            return None
        if header is None and kind != b"IHDR":
            return None  # IHDR must come first
        if kind == b"IHDR":
            if header is not None or length != 13:
                return None
            header = struct.unpack_from(">IIBBBBB", data, start)
        elif kind == b"IDAT":
            if idat_done:
                return None  # IDAT chunks must be consecutive (section 5.6)
            idat.append(view[start:end])
        elif kind == b"IEND":
            break
        elif not kind[0] & 0x20:  # a critical chunk this reader does not know (PLTE, ...)
            return None
        idat_done = idat_done or (bool(idat) and kind != b"IDAT")
        pos = end + 4
    width, height, depth, colour, compression, method, interlace = header
    if (depth, colour, compression, method, interlace) != (8, 0, 0, 0, 0) or not idat:
        return None
    if not (0 < width < 2**31 and 0 < height < 2**31):  # the specification's range (section 11.2.2)
        return None
    if max_pixels is not None and width * height > max_pixels:
        return None
    expected = height * (width + 1)
    inflater = zlib.decompressobj()
    try:
        raw = inflater.decompress(b"".join(idat), expected)
    except zlib.error:
        return None
    if len(raw) != expected or not inflater.eof or inflater.unconsumed_tail or inflater.unused_data:
        return None  # short, or more data than the image holds
    pixels = np.empty((height, width), dtype=np.uint8)
    if png_unfilter_grey8(raw, pixels) != 0:
        return None
    pixels.flags.writeable = False  # as the decoder's other arrays (graphpose.image.read_image)
    return pixels

"""The 8-bit grey PNG reader (graphpose._png) against Pillow's decoder, on files written here.

The writer below filters each row with a chosen filter of the PNG specification (Pillow's own
encoder picks its filters itself, so it would not reach all five), so every filter, and the
first row's and first column's special cases, are decoded by both readers and compared.
"""

import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from graphpose import InputError, read_image
from graphpose._png import SIGNATURE, decode_grey8


def _paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = np.abs(p - a), np.abs(p - b), np.abs(p - c)
    return np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))


def filtered(image, kinds):
    """The PNG filter stream of an 8-bit grey image, row i filtered by kinds[i] (0-4)."""
    A = image.astype(np.int64)
    out = []
    for i, kind in enumerate(kinds):
        x = A[i]
        up = A[i - 1] if i > 0 else np.zeros_like(x)
        left = np.r_[0, x[:-1]]
        upleft = np.r_[0, up[:-1]]
        predictor = [np.zeros_like(x), left, up, (left + up) // 2, _paeth(left, up, upleft)][kind]
        out.append(bytes([kind]) + ((x - predictor) % 256).astype(np.uint8).tobytes())
    return b"".join(out)


def chunk(kind, payload):
    return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(payload, zlib.crc32(kind)))


def png(image, kinds, *, pieces=1, extra=(), depth=8, colour=0, interlace=0, corrupt=None):
    """A PNG file of ``image``: its IDAT stream in ``pieces`` chunks, ``extra`` chunks before it."""
    h, w = image.shape
    data = zlib.compress(filtered(image, kinds), 6)
    cut = np.linspace(0, len(data), pieces + 1).astype(int)
    body = [chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, colour, 0, 0, interlace)), *extra]
    body += [chunk(b"IDAT", data[a:b]) for a, b in zip(cut[:-1], cut[1:])]
    file = SIGNATURE + b"".join(body) + chunk(b"IEND", b"")
    if corrupt is not None:
        file = bytearray(file)
        file[corrupt] ^= 0xFF
        file = bytes(file)
    return file


@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (9, 1), (17, 23), (64, 5)])
def test_every_filter_decodes_as_pillow_decodes_it(shape, tmp_path):
    rng = np.random.default_rng(shape[0] * 100 + shape[1])
    image = rng.integers(0, 256, shape).astype(np.uint8)
    for trial, kinds in enumerate([[k] * shape[0] for k in range(5)] + [list(rng.integers(0, 5, shape[0]))]):
        data = png(image, kinds, pieces=1 + trial % 3,
                   extra=[chunk(b"gAMA", struct.pack(">I", 45455)), chunk(b"tEXt", b"Comment\x00graphpose")])
        path = tmp_path / f"t{trial}.png"
        path.write_bytes(data)
        with Image.open(path) as im:
            assert im.mode == "L"
            expected = np.asarray(im)
        np.testing.assert_array_equal(expected, image)  # the writer wrote what it meant to
        got = decode_grey8(data)
        assert got is not None and got.dtype == np.uint8 and not got.flags.writeable
        np.testing.assert_array_equal(got, expected)
        np.testing.assert_array_equal(read_image(path), expected)


def test_other_pngs_are_left_to_pillow_and_read_as_before(tmp_path):
    rng = np.random.default_rng(1)
    rgb = rng.integers(0, 256, (12, 10, 3)).astype(np.uint8)
    grey16 = rng.integers(0, 65536, (12, 10)).astype(np.uint16)
    for name, array in (("rgb", rgb), ("grey16", grey16)):
        Image.fromarray(array).save(tmp_path / f"{name}.png")
        assert decode_grey8((tmp_path / f"{name}.png").read_bytes()) is None
    np.testing.assert_array_equal(read_image(tmp_path / "rgb.png"), np.asarray(Image.fromarray(rgb).convert("L")))
    assert read_image(tmp_path / "grey16.png").dtype == np.float64  # 16 bits: as float, not squeezed into 8
    grey = rng.integers(0, 256, (8, 8)).astype(np.uint8)
    interlaced = png(grey, [0] * 8, interlace=1)  # not what its header says, and not ours to read
    assert decode_grey8(interlaced) is None
    palette = Image.fromarray(grey).convert("P")
    palette.save(tmp_path / "p.png")
    assert decode_grey8((tmp_path / "p.png").read_bytes()) is None


def test_a_broken_png_is_left_to_pillow_whose_error_the_reader_words(tmp_path):
    grey = np.random.default_rng(2).integers(0, 256, (20, 30)).astype(np.uint8)
    good = png(grey, [4] * 20)
    np.testing.assert_array_equal(decode_grey8(good), grey)  # the intact file, decoded to the pixel
    broken = {
        "a flipped byte in the IDAT data (its CRC fails)": png(grey, [4] * 20, corrupt=len(SIGNATURE) + 25 + 20),
        "cut short": good[:-30],
        "no IHDR first": SIGNATURE + chunk(b"IDAT", zlib.compress(filtered(grey, [0] * 20))) + chunk(b"IEND", b""),
    }
    # A filter type of 5: written by hand, the stream's last row's type byte.
    stream = bytearray(filtered(grey, [0] * 20))
    stream[19 * 31] = 5
    broken["an unknown filter type"] = (SIGNATURE + chunk(b"IHDR", struct.pack(">IIBBBBB", 30, 20, 8, 0, 0, 0, 0))
                                        + chunk(b"IDAT", zlib.compress(bytes(stream))) + chunk(b"IEND", b""))
    # The first IDAT chunk's CRC alone wrong: this reader checks it and leaves the file to
    # Pillow, which does not check an IDAT chunk's CRC and reads the pixels.
    first_idat = len(SIGNATURE) + 25  # after the signature and the IHDR chunk
    (n,) = struct.unpack_from(">I", good, first_idat)
    crc_only = bytearray(good)
    crc_only[first_idat + 8 + n] ^= 0xFF
    assert decode_grey8(bytes(crc_only)) is None
    (tmp_path / "crc.png").write_bytes(bytes(crc_only))
    np.testing.assert_array_equal(read_image(tmp_path / "crc.png"), grey)
    # IDAT chunks split by another chunk (the specification wants them consecutive; Pillow
    # stops at the first run and calls the file truncated).
    data = zlib.compress(filtered(grey, [0] * 20))
    broken["IDAT chunks not in one run"] = (
        SIGNATURE + chunk(b"IHDR", struct.pack(">IIBBBBB", 30, 20, 8, 0, 0, 0, 0)) + chunk(b"IDAT", data[:40])
        + chunk(b"tEXt", b"a\x00b") + chunk(b"IDAT", data[40:]) + chunk(b"IEND", b""))
    for why, data in broken.items():
        assert decode_grey8(data) is None, why
        path = tmp_path / "broken.png"
        path.write_bytes(data)
        with pytest.raises(InputError, match="cannot read image"):
            read_image(path)


def test_an_image_past_pillows_pixel_limit_is_left_to_its_bomb_check():
    grey = np.arange(100, dtype=np.uint8).reshape(10, 10)
    assert decode_grey8(png(grey, [0] * 10), max_pixels=99) is None
    np.testing.assert_array_equal(decode_grey8(png(grey, [0] * 10), max_pixels=100), grey)


def test_a_header_past_the_specifications_range_is_left_to_pillow():
    huge = SIGNATURE + chunk(b"IHDR", struct.pack(">IIBBBBB", 2**31, 2**31, 8, 0, 0, 0, 0)) + chunk(b"IDAT", zlib.compress(b"")) + chunk(b"IEND", b"")
    assert decode_grey8(huge, max_pixels=None) is None


def test_an_unreadable_file_is_an_input_error(tmp_path, monkeypatch):
    import builtins
    import os
    from pathlib import Path

    path = tmp_path / "locked.png"
    path.write_bytes(png(np.zeros((4, 4), np.uint8), [0] * 4))
    path.chmod(0)
    try:
        if os.access(path, os.R_OK):
            # Root reads any file: the read is refused as the system refuses it to another user
            # (PermissionError from open), so the test runs as root too.
            real_open = builtins.open

            def refuse(file, *args, **kwargs):
                if isinstance(file, (str, os.PathLike)) and Path(file) == path:
                    raise PermissionError(13, "Permission denied", str(file))
                return real_open(file, *args, **kwargs)

            monkeypatch.setattr(builtins, "open", refuse)
        with pytest.raises(InputError, match="cannot read image"):
            read_image(path)
    finally:
        path.chmod(0o600)

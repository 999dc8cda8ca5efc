"""Images in: as_grey's conversions and read_image's files."""

import numpy as np
import pytest

from graphpose import InputError, as_grey, read_image
from graphpose.io.files import encode_png


def test_as_grey_scales_dtypes():
    assert as_grey(np.full((2, 2), 255, np.uint8)).max() == 1.0
    assert as_grey(np.full((2, 2), 65535, np.uint16)).max() == 1.0
    rgb = np.zeros((2, 2, 3), np.uint8)
    rgb[..., 1] = 255
    np.testing.assert_allclose(as_grey(rgb), 0.587)
    rgba = np.concatenate([rgb, np.full((2, 2, 1), 7, np.uint8)], axis=2)
    np.testing.assert_allclose(as_grey(rgba), 0.587)


@pytest.mark.parametrize(
    "image, message",
    [(np.zeros((0, 0)), "empty"), (np.full((2, 2), np.nan), "NaN"), (np.zeros((2, 2, 2)), "shape")],
)
def test_as_grey_rejects(image, message):
    with pytest.raises(InputError, match=message):
        as_grey(image)


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
def test_read_image_errors(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_image(tmp_path / "missing.png")
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"not a png")
    with pytest.raises(InputError, match="cannot read"):
        read_image(junk)


@pytest.mark.parametrize(
    "image", [np.zeros((2, 2), complex), np.array([["a", "b"]]), np.zeros((2, 2), "datetime64[s]")])
def test_as_grey_rejects_unsupported_dtypes(image):
    with pytest.raises(InputError, match="unsupported dtype"):
        as_grey(image)


def test_as_grey_keeps_floats_and_maps_bools():
    np.testing.assert_array_equal(as_grey(np.array([[0.25, 1.5]], np.float32)), [[0.25, 1.5]])
    assert as_grey(np.array([[True, False]])).tolist() == [[1.0, 0.0]]


def test_as_grey_passes_float64_grey_through_without_a_copy():
    image = np.random.default_rng(0).random((4, 5))
    assert as_grey(image) is image
    assert as_grey(image.astype(np.float32)).dtype == np.float64


def test_as_grey_refuses_an_image_smaller_than_asked():
    with pytest.raises(InputError, match=r"image must be at least 5 x 5 pixels, got shape \(4, 9\)"):
        as_grey(np.zeros((4, 9)), min_side=5)


def test_read_image_reads_grey_in_0_1(tmp_path):
    path = tmp_path / "a.png"
    path.write_bytes(encode_png(np.array([[0, 255], [51, 102]], np.uint8)))
    np.testing.assert_allclose(read_image(path, as_float=True), [[0.0, 1.0], [0.2, 0.4]])


def test_read_image_of_a_folder_says_it_is_a_folder(tmp_path):
    # It once said "image file not found" of a folder that is there.
    with pytest.raises(InputError) as info:
        read_image(tmp_path)
    assert str(info.value) == f"{tmp_path} is a folder, not an image file"


def test_read_image_as_uint8_keeps_8_bit_grey_exactly(tmp_path):
    path = tmp_path / "a.png"
    pixels = np.random.default_rng(0).integers(0, 256, (7, 9), dtype=np.uint8)
    path.write_bytes(encode_png(pixels))
    grey = read_image(path, as_float=False)
    assert grey.dtype == np.uint8
    np.testing.assert_array_equal(grey, pixels)
    np.testing.assert_allclose(read_image(path, as_float=True), pixels / 255.0)
    # uint8 is the default.
    assert read_image(path).dtype == np.uint8 and np.array_equal(read_image(path), pixels)


@pytest.mark.parametrize("suffix, tolerance", [(".png", 1), (".jpg", 12)])
def test_read_image_as_uint8_converts_colour_to_luma(tmp_path, suffix, tolerance):
    from PIL import Image

    rgb = np.zeros((16, 16, 3), np.uint8)
    rgb[:, :8] = (200, 30, 90)
    rgb[:, 8:] = (10, 240, 60)
    path = tmp_path / f"a{suffix}"
    Image.fromarray(rgb).save(path, quality=95)
    grey = read_image(path, as_float=False)
    assert grey.dtype == np.uint8 and grey.shape == (16, 16)
    # Integer luma in the decoder against the float path's (JPEG: its own luma plane).
    assert np.abs(grey.astype(float) - 255 * read_image(path, as_float=True)).max() <= tolerance


def test_read_image_as_uint8_reads_16_bit_files_as_float(tmp_path):
    from PIL import Image

    path = tmp_path / "deep.png"
    Image.fromarray(np.array([[0, 65535], [13107, 26214]], np.uint16)).save(path)
    grey = read_image(path, as_float=False)
    assert grey.dtype == np.float64
    np.testing.assert_allclose(grey, [[0.0, 1.0], [0.2, 0.4]])


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
def test_read_image_as_uint8_errors_as_the_float_path(tmp_path):
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"not a png")
    with pytest.raises(InputError, match="cannot read"):
        read_image(junk, as_float=False)
    truncated = tmp_path / "cut.png"
    truncated.write_bytes(encode_png(np.zeros((64, 64), np.uint8))[:60])
    with pytest.raises(InputError, match="cannot read"):
        read_image(truncated, as_float=False)


def test_read_image_refuses_a_decompression_bomb_as_unreadable(tmp_path, monkeypatch):
    from PIL import Image

    path = tmp_path / "big.png"
    path.write_bytes(encode_png(np.zeros((64, 64), np.uint8)))
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 100)  # 64 x 64 is then over twice the limit
    for as_float in (False, True):
        with pytest.raises(InputError, match="cannot read image"):
            read_image(path, as_float=as_float)


@pytest.mark.slow  # reads broken files in subprocesses
def test_a_broken_file_is_named_truncated_or_corrupt_never_a_missing_plugin(tmp_path):
    cases = {"empty.png": b"", "cut.jpg": b"\xff\xd8\xff\xe0\x00\x10JFIF", "notes.dat": b"hello, not an image"}
    for name, content in cases.items():
        (tmp_path / name).write_bytes(content)
        for as_float in (True, False):
            with pytest.raises(InputError) as caught:
                read_image(tmp_path / name, as_float=as_float)
            text = str(caught.value)
            assert text.startswith(f"cannot read image {tmp_path / name}: not a readable image (")
            assert "pip" not in text and "backend" not in text
    with pytest.raises(InputError, match="the file is empty"):
        read_image(tmp_path / "empty.png")
    with pytest.raises(InputError, match="not an image file at all: graphpose reads PNG, JPEG"):
        read_image(tmp_path / "notes.dat")


def test_read_image_gives_the_decoders_pixels_without_a_copy_and_they_outlive_the_file(tmp_path):
    import gc

    from PIL import Image

    rng = np.random.default_rng(4)
    A = rng.integers(0, 256, (37, 53)).astype(np.uint8)
    Image.fromarray(A).save(tmp_path / "a.tif")  # Pillow's decoder (a grey PNG is graphpose's own)
    I = read_image(tmp_path / "a.tif")
    # Pillow's own memory, through its Arrow export, where this Pillow has one.
    exported = hasattr(Image.Image, "__arrow_c_array__")
    owner = I.base.obj if isinstance(I.base, memoryview) else I.base
    assert (type(owner).__name__ == "GreyPixels") == exported
    assert I.dtype == np.uint8 and I.flags["C_CONTIGUOUS"]
    assert not I.flags["WRITEABLE"]  # as np.asarray of a Pillow image: the decoder's pixels
    gc.collect()
    junk = [np.full(A.shape, 7, np.uint8) for _ in range(20)]  # reuse of freed memory would show
    np.testing.assert_array_equal(I, A)
    with pytest.raises(ValueError, match="read-only"):
        I[0, 0] = 0
    J = I.copy()  # what a caller who draws on it does
    J[0, 0] = 255 - A[0, 0]
    np.testing.assert_array_equal(I, A)
    del junk


def test_read_image_copies_where_pillow_will_not_export(tmp_path, monkeypatch):
    from PIL import Image

    A = np.arange(12 * 9, dtype=np.uint8).reshape(12, 9)
    Image.fromarray(A).save(tmp_path / "a.tif")

    def refuse(self, *args, **kwargs):  # as Pillow refuses an image kept in several blocks
        raise ValueError("Image rows are not contiguous in memory.")

    monkeypatch.setattr(Image.Image, "__arrow_c_array__", refuse, raising=False)
    I = read_image(tmp_path / "a.tif")
    np.testing.assert_array_equal(I, A)
    assert I.dtype == np.uint8 and not I.flags["WRITEABLE"]  # as the export's, read-only


def test_the_pixel_view_declines_an_export_that_is_not_8_bit_grey():
    from PIL import Image

    from graphpose._pixels import grey_view

    im = Image.fromarray(np.zeros((4, 6), np.uint8))
    assert grey_view(*im.__arrow_c_array__(), 5, 6) is None  # another size
    assert grey_view(*Image.new("I", (6, 4)).__arrow_c_array__(), 4, 6) is None  # 32-bit pixels
    assert np.asarray(grey_view(*im.__arrow_c_array__(), 4, 6)).shape == (4, 6)

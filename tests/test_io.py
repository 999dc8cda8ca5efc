import numpy as np
import pytest

from graphpose import InputError, as_grey, read_image


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


def test_read_image_errors(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_image(tmp_path / "missing.png")
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"not a png")
    with pytest.raises(InputError, match="cannot read"):
        read_image(junk)


def test_real_images_load(real_images):
    assert len(real_images) == 6
    for case, image in real_images:
        assert image.shape == (480, 640)
        assert case.bounds.shape == (2, 4)

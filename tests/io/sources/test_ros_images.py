"""graphpose.io.sources.ros_images: ROS image messages (raw encodings, compressed formats) as
grey pixels, and camera_info messages as cameras."""

from types import SimpleNamespace

import numpy as np
import pytest

from graphpose import PinholeCamera
from graphpose.errors import InputError
from graphpose.io.sources.ros_images import camera_info_camera, compressed_grey, image_grey
from tests.conftest import PROJECT_K as K


def _msg(encoding, pixels, big=False):
    data = np.ascontiguousarray(pixels)
    if data.dtype == np.uint16:
        data = data.astype(">u2" if big else "<u2")
    h, w = pixels.shape[:2]
    raw = data.view(np.uint8).reshape(h, -1)
    return SimpleNamespace(encoding=encoding, height=h, width=w, step=raw.shape[1], is_bigendian=int(big),
                           data=raw.reshape(-1))


def test_image_encodings():
    rng = np.random.default_rng(0)
    grey = rng.integers(0, 256, (6, 8)).astype(np.uint8)
    np.testing.assert_array_equal(image_grey(_msg("mono8", grey)), grey)
    deep = rng.integers(0, 65536, (6, 8)).astype(np.uint16)
    np.testing.assert_array_equal(image_grey(_msg("mono16", deep)), deep)
    np.testing.assert_array_equal(image_grey(_msg("16UC1", deep, big=True)), deep)
    rgb = rng.integers(0, 256, (6, 8, 3)).astype(np.uint8)
    c = rgb.astype(int)
    luma = (299 * c[..., 0] + 587 * c[..., 1] + 114 * c[..., 2] + 500) // 1000
    np.testing.assert_array_equal(image_grey(_msg("rgb8", rgb)), luma)
    np.testing.assert_array_equal(image_grey(_msg("bgr8", rgb[..., ::-1])), luma)
    # A Bayer mosaic of a grey scene whose channels are R = 40, G = 100, B = 200: every pixel
    # weighs R 1/4, G 1/2, B 1/4 whatever the pattern's phase (110), and no half-pixel shift.
    mosaic = np.empty((8, 10), np.uint8)
    mosaic[0::2, 0::2], mosaic[0::2, 1::2], mosaic[1::2, 0::2], mosaic[1::2, 1::2] = 40, 100, 100, 200
    for enc, m in (("bayer_rggb8", mosaic), ("bayer_gbrg8", mosaic[1:-1]), ("bayer_bggr8", mosaic[1:-1, 1:-1])):
        np.testing.assert_array_equal(image_grey(_msg(enc, m))[1:-1, 1:-1], 110)
    with pytest.raises(InputError, match="'32FC1' is not one graphpose reads"):
        image_grey(_msg("32FC1", grey))


def test_compressed_formats():
    from graphpose.io.files import encode_png

    grey = np.arange(48, dtype=np.uint8).reshape(6, 8)
    png = SimpleNamespace(format="png", data=np.frombuffer(encode_png(grey), np.uint8))
    np.testing.assert_array_equal(compressed_grey(png), grey)
    with pytest.raises(InputError, match="compressedDepth"):
        compressed_grey(SimpleNamespace(format="16UC1; compressedDepth", data=png.data))
    with pytest.raises(InputError, match="cannot be decoded"):
        compressed_grey(SimpleNamespace(format="jpeg", data=np.zeros(10, np.uint8)))


def test_camera_info_models():
    info = SimpleNamespace(k=K.reshape(-1), d=[-0.2, 0.05, 0.001, 0.0, 0.0], distortion_model="plumb_bob",
                           width=640, height=480)
    camera = camera_info_camera(info, "bag:/cam/camera_info")
    assert camera.model == "radtan" and np.allclose(camera.distortion[:2], [-0.2, 0.05])
    ros1 = SimpleNamespace(K=K.reshape(-1), D=[0.0] * 5, distortion_model="plumb_bob", width=640, height=480)
    assert isinstance(camera_info_camera(ros1, "bag"), PinholeCamera)  # no distortion: a pinhole camera
    with pytest.raises(InputError, match="not calibrated"):
        camera_info_camera(SimpleNamespace(k=np.zeros(9), d=[], distortion_model="", width=1, height=1), "b")

"""graphpose.io.sources.bag_writer: bags written from grey frames, checked by reading them with
``rosbags``' own reader (not graphpose's): the messages, their stamps and the camera_info."""

import io

import numpy as np
import pytest

from graphpose import PinholeCamera, RadTanCamera
from graphpose.errors import InputError
from graphpose.io.sources.bag_writer import BAG_FORMATS, write_bag
from tests.conftest import PROJECT_K as K


def _messages(path):
    """{topic: [(log time ns, message), ...]} of a bag, read by rosbags alone."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    out = {}
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        for conn, t, raw in reader.messages():
            out.setdefault(conn.topic, []).append((t, reader.deserialize(raw, conn.msgtype)))
    return out


@pytest.mark.parametrize("fmt", BAG_FORMATS)
def test_the_bag_holds_mono8_images_at_their_stamps_and_the_camera(tmp_path, frames, fmt):
    stamps = np.array([1700000000.25, 1700000000.5, 1700000001.000001])
    camera = RadTanCamera(K, [-0.2, 0.05, 0.001, -0.002, 0.01], (64, 48))
    path = write_bag(tmp_path / ("b.bag" if fmt == "ros1" else "b"), frames[:3], stamps, fmt=fmt,
                     topic="/cam0/image_raw", camera=camera, frame_id="cam0")
    got = _messages(path)
    assert set(got) == {"/cam0/image_raw", "/cam0/camera_info"}
    images = got["/cam0/image_raw"]
    assert len(images) == 3
    for k, (t, msg) in enumerate(images):
        ns = round(stamps[k] * 1e9)
        assert t == ns and (msg.header.stamp.sec, msg.header.stamp.nanosec) == divmod(ns, 10**9)
        assert msg.header.frame_id == "cam0" and msg.encoding == "mono8" and (msg.height, msg.width) == (48, 64)
        np.testing.assert_array_equal(np.asarray(msg.data).reshape(48, 64), frames[k])
    [(t, info)] = got["/cam0/camera_info"]
    k_, d_, p_ = ((info.K, info.D, info.P) if fmt == "ros1" else (info.k, info.d, info.p))
    assert t == round(stamps[0] * 1e9) and info.distortion_model == "plumb_bob"
    assert (info.width, info.height) == (64, 48)
    np.testing.assert_array_equal(np.reshape(k_, (3, 3)), K)
    np.testing.assert_array_equal(d_, camera.distortion)
    np.testing.assert_array_equal(np.reshape(p_, (3, 4)), np.hstack([K, np.zeros((3, 1))]))


def test_compressed_frames_are_png_on_the_compressed_topic(tmp_path, frames):
    from PIL import Image

    path = write_bag(tmp_path / "c", frames[:2], [1.0, 2.0], compressed=True, camera=PinholeCamera(K, (64, 48)))
    got = _messages(path)
    assert set(got) == {"/camera/image_raw/compressed", "/camera/camera_info"}
    for k, (t, msg) in enumerate(got["/camera/image_raw/compressed"]):
        assert "png" in msg.format and t == (k + 1) * 10**9
        np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(bytes(msg.data)))), frames[k])
    # A pinhole camera is written as plumb_bob with five zero coefficients.
    np.testing.assert_array_equal(got["/camera/camera_info"][0][1].d, np.zeros(5))


def test_no_camera_no_camera_info_and_an_unknown_format_refused(tmp_path, frames):
    assert set(_messages(write_bag(tmp_path / "n", frames[:1], [0.0]))) == {"/camera/image_raw"}
    with pytest.raises(InputError, match="fmt must be one of ros1, ros2-sqlite3, ros2-mcap, got 'ros3'"):
        write_bag(tmp_path / "x", frames[:1], [0.0], fmt="ros3")
    assert not (tmp_path / "x").exists()

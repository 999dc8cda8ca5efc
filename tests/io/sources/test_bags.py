"""graphpose.io.sources.bags: ROS 1 and ROS 2 bags read as the frames their image topic holds,
each at its header stamp, with the camera_info beside it; missing and wrong topics named."""

import numpy as np
import pytest

from graphpose import PinholeCamera
from graphpose.errors import InputError
from graphpose.io.sources import open_frames
from graphpose.io.sources.bag_writer import BAG_FORMATS, write_bag
from tests.conftest import PROJECT_K as K


def _bag_path(tmp_path, fmt, compressed):
    return tmp_path / (f"{fmt}-{compressed}" + (".bag" if fmt == "ros1" else ""))


@pytest.mark.slow  # 0.6 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("fmt", BAG_FORMATS)
@pytest.mark.parametrize("compressed", [False, True])
def test_bags_hold_the_frames_their_stamps_and_camera(tmp_path, frames, fmt, compressed):
    stamps = 1700000000.0 + np.arange(len(frames)) / 30.0
    path = write_bag(_bag_path(tmp_path, fmt, compressed), frames, stamps, fmt=fmt, compressed=compressed,
                     camera=PinholeCamera(K, size=(64, 48)))
    bag = open_frames(path)
    assert len(bag) == len(frames) and bag.topic.endswith("/compressed") == compressed
    np.testing.assert_allclose(bag.timestamps, stamps, rtol=0, atol=1e-6)  # the header stamps
    for f, im in zip(bag.frames(), frames):
        np.testing.assert_array_equal(f.image, im)
    np.testing.assert_array_equal(bag.read(7).image, frames[7])  # reopened at a frame
    assert isinstance(bag.camera, PinholeCamera) and np.allclose(bag.camera.K, K)
    assert bag.camera_source.endswith("/camera/camera_info")


def test_bag_topics_named_when_missing_or_wrong(tmp_path, frames):
    path = write_bag(tmp_path / "b.bag", frames[:3], np.arange(3.0), fmt="ros1")
    with pytest.raises(InputError, match=r"has no topic /left.*image topics: /camera/image_raw \(sensor_msgs/msg/Image, 3"):
        open_frames(path, topic="/left")
    bag = open_frames(path)  # one image topic: no --topic needed
    assert bag.topic == "/camera/image_raw" and bag.camera is None
    with pytest.raises(InputError, match="--topic /x chooses a ROS bag's image topic"):
        open_frames(tmp_path, topic="/x")


def test_bag_with_two_image_topics_needs_one(tmp_path, frames):
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    Image, Header, Time = (store.types[n] for n in ("sensor_msgs/msg/Image", "std_msgs/msg/Header",
                                                    "builtin_interfaces/msg/Time"))
    with Writer(tmp_path / "two", version=9) as writer:
        for topic, encoding in (("/left/image", "mono8"), ("/right/image", "yuv422")):
            conn = writer.add_connection(topic, "sensor_msgs/msg/Image", typestore=store)
            msg = Image(header=Header(stamp=Time(sec=1, nanosec=0), frame_id="c"), height=48, width=64,
                        encoding=encoding, is_bigendian=0, step=64 * (2 if encoding == "yuv422" else 1),
                        data=np.zeros(48 * 64 * (2 if encoding == "yuv422" else 1), np.uint8))
            writer.write(conn, 1_000_000_000, store.serialize_cdr(msg, "sensor_msgs/msg/Image"))
    with pytest.raises(InputError, match="several image topics; give one with --topic: image topics: /left/image"):
        open_frames(tmp_path / "two")
    with pytest.raises(InputError, match="encoding 'yuv422' is not one graphpose reads"):
        open_frames(tmp_path / "two", topic="/right/image")
    assert len(open_frames(tmp_path / "two" / "two.db3" if (tmp_path / "two" / "two.db3").exists()
                           else tmp_path / "two", topic="/left/image")) == 1

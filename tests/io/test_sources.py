"""Frame sources (graphpose.io.sources): videos, ROS bags, globs and list files, read as the
frames they hold, each with its own time; damage and wrong topics named."""

import os
import shutil
from types import SimpleNamespace

import numpy as np
import pytest

from graphpose import PinholeCamera
from graphpose.errors import InputError
from graphpose.io.files import write_png
from graphpose.io.sources import BrokenRecordingError, ImageFiles, expand_paths, open_frames
from graphpose.io.sources.bag_writer import BAG_FORMATS, write_bag
from graphpose.io.sources.ros_images import camera_info_camera, compressed_grey, image_grey
from graphpose.io.sources.video_out import VideoWriter
from tests.conftest import PROJECT_K as K


@pytest.fixture(scope="module")
def frames():
    """Twelve 8-bit frames of a moving pattern (distinct, so a wrong frame is seen), 64 x 48."""
    rng = np.random.default_rng(3)
    base = rng.integers(0, 256, (48, 64)).astype(np.uint8)
    return np.stack([np.roll(base, 3 * k, axis=1) for k in range(12)])


def _video(path, frames, fps=25.0, **kw):
    with VideoWriter(path, fps, **kw) as w:
        for im in frames:
            w.add(im)
    return path


@pytest.mark.parametrize("suffix", [".mp4", ".mkv", ".avi"])
def test_video_frames_times_and_seeking(tmp_path, frames, suffix):
    # A key frame every 4 frames with B-frames between: a seek lands on a key frame and decodes on.
    video = open_frames(_video(tmp_path / f"v{suffix}", frames, options={"g": "4", "bf": "2"}))
    assert len(video.key_pts) == 3
    assert video.kind == "video" and len(video) == len(frames)
    steps = np.diff(video.timestamps)
    np.testing.assert_allclose(steps, 1 / 25.0, atol=1e-3)  # presentation times, frame by frame
    in_order = [f.image for f in video.frames()]
    assert all(im.shape == (48, 64) and im.dtype == np.uint8 for im in in_order)
    # Each decoded frame is nearest to its own source frame (the codec's loss is small beside a shift).
    for k, im in enumerate(in_order):
        errors = [np.mean(np.abs(im.astype(float) - 16 - f * 219 / 255)) for f in frames.astype(float)]
        assert int(np.argmin(errors)) == k
    for k in (9, 2, 10, 0, 11):  # backwards and forwards: a seek or a decode on
        frame = video.read(k)
        assert frame.index == k and frame.timestamp == video.timestamps[k]
        np.testing.assert_array_equal(frame.image, in_order[k])
    with pytest.raises(InputError, match="frame 12 is not in"):
        video.read(12)


def test_video_cut_short_gives_the_frames_before_then_says_where(tmp_path, frames):
    big = np.repeat(np.repeat(np.concatenate([frames] * 3), 4, axis=1), 4, axis=2)  # 36 frames, 256 x 192
    data = _video(tmp_path / "v.mkv", big).read_bytes()
    (tmp_path / "cut.mkv").write_bytes(data[: len(data) // 2])
    video = open_frames(tmp_path / "cut.mkv")
    assert 0 < len(video) < 36
    got = []
    with pytest.raises(BrokenRecordingError, match=r"cut\.mkv broke after frame \d+ \(t = [\d.]+ s\)") as caught:
        for f in video.frames():
            got.append(f.index)
    assert got == list(range(len(video))) and caught.value.index == len(video)


def test_mp4_without_its_index_is_named(tmp_path, frames):
    data = _video(tmp_path / "v.mp4", frames).read_bytes()
    (tmp_path / "cut.mp4").write_bytes(data[: len(data) // 2])  # the moov atom is written last
    with pytest.raises(InputError, match="'moov' atom\\) is missing"):
        open_frames(tmp_path / "cut.mp4")


def test_not_a_video(tmp_path):
    (tmp_path / "x.mp4").write_bytes(b"no video here" * 10)
    with pytest.raises(InputError, match="not a video FFmpeg can read"):
        open_frames(tmp_path / "x.mp4")
    with pytest.raises(InputError, match="video file not found"):
        open_frames(tmp_path / "none.mp4")


def _bag_path(tmp_path, fmt, compressed):
    return tmp_path / (f"{fmt}-{compressed}" + (".bag" if fmt == "ros1" else ""))


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


def test_globs_list_files_and_folders(tmp_path, frames):
    for k in range(4):
        write_png(tmp_path / f"f{k}.png", frames[k])
    (tmp_path / "notes.md").write_text("not an image")
    (tmp_path / "list.txt").write_text("# two frames\nf2.png\n\nf0.png\n")
    assert [p.name for p in expand_paths(str(tmp_path / "f*.png"))] == ["f0.png", "f1.png", "f2.png", "f3.png"]
    assert [p.name for p in expand_paths(tmp_path / "list.txt")] == ["f2.png", "f0.png"]
    assert [p.name for p in expand_paths(tmp_path)] == ["f0.png", "f1.png", "f2.png", "f3.png"]
    files = open_frames([str(tmp_path / "f[13].png")])
    assert isinstance(files, ImageFiles) and len(files) == 2 and files.timestamps is None
    np.testing.assert_array_equal(files.read(1).image, frames[3])
    with pytest.raises(InputError, match="matches no file"):
        expand_paths(str(tmp_path / "g*.png"))
    (tmp_path / "empty.txt").write_text("# nothing\n")
    with pytest.raises(InputError, match="names no images"):
        expand_paths(tmp_path / "empty.txt")
    with pytest.raises(InputError, match="is read on its own"):
        open_frames([tmp_path / "a.mp4", tmp_path / "f0.png"])


def test_list_images_is_every_command_s_rule_for_a_folder(tmp_path):
    from graphpose.calibrate.frames import source_files
    from graphpose.io.sources.paths import list_images
    from graphpose.track.frames import list_frames

    for name in ("b.PNG", "a.jpg", "c.tiff", "notes.txt", "d.png.bak"):
        (tmp_path / name).write_bytes(b"x")
    (tmp_path / "e.png").mkdir()  # a folder named like an image is no image
    want = [tmp_path / "a.jpg", tmp_path / "b.PNG", tmp_path / "c.tiff"]
    assert list_images(tmp_path) == want
    assert expand_paths(tmp_path) == want == list_frames(tmp_path) == source_files(tmp_path)
    empty = tmp_path / "empty"
    empty.mkdir()
    assert list_images(empty) == []
    with pytest.raises(InputError, match=r"no image files \(\.png, .*\) in .*empty$"):
        expand_paths(str(empty) + os.sep)
    with pytest.raises(InputError, match="holds no image file"):
        source_files(empty, "camera 0")

"""The commands on recordings as people make them: a video, a ROS bag, a quoted glob, a list file;
and each bad input's one line, with what came before the damage written."""

import json

import numpy as np
import pytest

from graphpose import PinholeCamera, read_tum
from graphpose.cli import main
from graphpose.io.files import write_png
from graphpose.io.sources import open_frames
from graphpose.io.sources.bag_writer import write_bag
from graphpose.io.sources.video_out import VideoWriter
from tests.conftest import PROJECT_K
from tests.helpers import PROJECT_K_OPTION as K_OPTION



@pytest.fixture(scope="module")
def clip(track_clip, tmp_path_factory):
    """The first 24 frames of the rendered clip (no pan yet): as a video (H.264, a key frame every
    8), as PNG files of the same decoded frames, and as a ROS 2 bag with its camera_info."""
    folder = tmp_path_factory.mktemp("clip")
    images = track_clip.images[:24]
    with VideoWriter(folder / "clip.mkv", 30, options={"g": "8"}) as w:
        for im in images:
            w.add(im)
    decoded = folder / "decoded"
    decoded.mkdir()
    for f in open_frames(folder / "clip.mkv").frames():
        write_png(decoded / f"frame_{f.index:03d}.png", f.image)
    bag = write_bag(folder / "bag", images, 50.0 + np.arange(24) / 30.0, fmt="ros2-mcap",
                    camera=PinholeCamera(PROJECT_K, size=(640, 480)))
    return folder, decoded, bag


@pytest.mark.slow  # encodes, decodes and tracks a video twice
def test_track_video_as_its_decoded_frames(clip, tmp_path, capsys):
    folder, decoded, _ = clip
    assert main(["track", str(folder / "clip.mkv"), "--K", K_OPTION, "--tum", str(tmp_path / "v.tum"),
                 "--json", str(tmp_path / "v.json"), "-q"]) == 0
    pts = open_frames(folder / "clip.mkv").timestamps  # milliseconds in Matroska: not index / 30
    (tmp_path / "times.txt").write_text("".join(f"{float(t)!r}\n" for t in pts))
    assert main(["track", str(decoded), "--K", K_OPTION, "--tum", str(tmp_path / "f.tum"), "-q",
                 "--timestamps", str(tmp_path / "times.txt")]) == 0
    video, files = read_tum(tmp_path / "v.tum"), read_tum(tmp_path / "f.tum")
    assert len(video) == len(files) == 24
    np.testing.assert_allclose(video.poses, files.poses, atol=1e-9)  # same pixels and times, same poses
    np.testing.assert_allclose(video.timestamps, pts, atol=1e-6)  # the container's times
    doc = json.loads((tmp_path / "v.json").read_text())
    assert doc["frames"][5]["file"].endswith("clip.mkv#5") and doc["frames"][5]["index"] == 5


@pytest.mark.slow  # 5.7 s or so on two idle cores: a render, a calibration or a subprocess
def test_track_bag_takes_its_camera_info(clip, tmp_path, capsys):
    folder, _, bag = clip
    assert main(["track", str(bag), "--tum", str(tmp_path / "b.tum")]) == 0
    out = capsys.readouterr().out
    assert "camera: from the bag's camera_info" in out and "/camera/camera_info" in out
    tum = read_tum(tmp_path / "b.tum")
    assert len(tum) == 24 and tum.timestamps[0] == pytest.approx(50.0)


@pytest.mark.slow  # 5.2 s or so on two idle cores: a render, a calibration or a subprocess
def test_track_bag_without_the_topic(clip, capsys):
    _, _, bag = clip
    assert main(["track", str(bag), "--topic", "/left/image_raw"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "has no topic /left/image_raw; its image topics: /camera/image_raw (sensor_msgs/msg/Image, 24" in err


@pytest.mark.slow  # encodes and tracks a cut video
def test_track_truncated_video_writes_what_came_before(clip, tmp_path, capsys):
    folder, _, _ = clip
    data = (folder / "clip.mkv").read_bytes()
    cut = tmp_path / "cut.mkv"
    cut.write_bytes(data[: len(data) * 2 // 3])
    code = main(["track", str(cut), "--K", K_OPTION, "--tum", str(tmp_path / "cut.tum"),
                 "--json", str(tmp_path / "cut.json"), "--overlay-video", str(tmp_path / "cut.mp4")])
    captured = capsys.readouterr()
    n = len(open_frames(cut))
    assert code == 2 and 0 < n < 24
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"graphpose track: error: {cut} broke after frame {n - 1} (t = ")
    assert len(read_tum(tmp_path / "cut.tum")) == n  # every frame before the damage, tracked and written
    assert len(json.loads((tmp_path / "cut.json").read_text())["frames"]) == n
    assert len(open_frames(tmp_path / "cut.mp4")) == n
    assert f"{n} frames:" in captured.out


@pytest.mark.slow  # encodes a video overlay frame by frame
def test_overlay_video_has_every_frame(clip, tmp_path, capsys):
    folder, _, _ = clip
    out = tmp_path / "overlay.mp4"
    assert main(["track", str(folder / "clip.mkv"), "--K", K_OPTION, "--overlay-video", str(out), "-q"]) == 0
    video = open_frames(out)
    assert len(video) == 24 and video.read(3).image.shape == (480, 640)
    np.testing.assert_allclose(video.timestamps, open_frames(folder / "clip.mkv").timestamps, atol=1e-3)


def test_track_no_frame_shows_a_board(tmp_path, capsys):
    with VideoWriter(tmp_path / "blank.mp4", 30) as w:
        for k in range(3):
            w.add(np.full((96, 128), 60 + 40 * k, np.uint8))
    assert main(["track", str(tmp_path / "blank.mp4"), "--K", "100,100,64,48", "-q"]) == 1
    err = capsys.readouterr().err
    assert "no frame of the 3 in" in err and "blank.mp4 shows the board 8x6" in err


def test_track_unreadable_encoding(tmp_path, capsys):
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    Image, Header, Time = (store.types[n] for n in ("sensor_msgs/msg/Image", "std_msgs/msg/Header",
                                                    "builtin_interfaces/msg/Time"))
    with Writer(tmp_path / "yuv.bag") as writer:
        conn = writer.add_connection("/cam/image", "sensor_msgs/msg/Image", typestore=store)
        msg = Image(header=Header(seq=0, stamp=Time(sec=1, nanosec=0), frame_id="c"), height=4, width=4,
                    encoding="yuv422", is_bigendian=0, step=8, data=np.zeros(32, np.uint8))
        writer.write(conn, 10**9, store.serialize_ros1(msg, "sensor_msgs/msg/Image"))
    assert main(["track", str(tmp_path / "yuv.bag"), "--K", K_OPTION]) == 2
    assert "topic /cam/image: image encoding 'yuv422' is not one graphpose reads (mono8" in capsys.readouterr().err


@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
def test_globs_and_list_files(clip, tmp_path, capsys):
    _, decoded, _ = clip
    pattern = str(decoded / "frame_00[0-5].png")
    listing = tmp_path / "frames.txt"
    listing.write_text("".join(f"{decoded / f'frame_{k:03d}.png'}\n" for k in range(6)))
    for source in (pattern, str(listing)):
        assert main(["track", source, "--K", K_OPTION, "--tum", str(tmp_path / "g.tum"), "-q"]) == 0
        assert len(read_tum(tmp_path / "g.tum")) == 6
        assert main(["estimate", source, "--K", K_OPTION, "-q", "--json", str(tmp_path / "e.json")]) == 0
        assert len(json.loads((tmp_path / "e.json").read_text())) == 6


def test_estimate_every_nth_frame_names_index_and_time(clip, tmp_path, capsys):
    folder, _, bag = clip
    assert main(["estimate", str(folder / "clip.mkv"), "--K", K_OPTION, "--every", "10", "-q",
                 "--json", str(tmp_path / "e.json")]) == 0
    rows = json.loads((tmp_path / "e.json").read_text())
    pts = open_frames(folder / "clip.mkv").timestamps
    assert [r["frame"] for r in rows] == [0, 10, 20]
    assert [r["timestamp"] for r in rows] == pytest.approx(pts[[0, 10, 20]])
    assert all(r["status"] == "ok" for r in rows)
    assert main(["estimate", str(bag), "--every", "12", "--json", str(tmp_path / "b.json")]) == 0
    assert "camera: from the bag's camera_info" in capsys.readouterr().out
    assert main(["estimate", str(folder / "decoded"), "--K", K_OPTION, "--every", "2"]) == 2
    assert "--every and --topic go with one video or ROS bag" in capsys.readouterr().err


@pytest.mark.slow  # a video through graphpose batch on a Dask cluster
def test_batch_rows_name_frame_and_time(clip, tmp_path, capsys):
    """One task a chunk of frames, each worker opening the video and seeking to its chunk; and a
    list file of the decoded frames gives the same poses."""
    pytest.importorskip("distributed")
    folder, decoded, _ = clip
    out = tmp_path / "rows.jsonl"
    assert main(["batch", str(folder / "clip.mkv"), "--K", K_OPTION, "--out", str(out), "--workers", "2",
                 "--images-per-task", "5", "-q"]) == 0
    rows = sorted((json.loads(line) for line in out.read_text().splitlines()), key=lambda r: r["frame"])
    pts = open_frames(folder / "clip.mkv").timestamps
    assert [r["frame"] for r in rows] == list(range(24))
    assert [r["timestamp"] for r in rows] == pytest.approx(pts)
    assert rows[7]["image"].endswith("clip.mkv#7") and all(r["status"] == "ok" for r in rows)
    listing = tmp_path / "decoded.txt"
    listing.write_text("".join(f"decoded/frame_{k:03d}.png\n" for k in (7, 19)))
    listing = listing.rename(folder / "decoded.txt")  # paths relative to the list's folder
    out2 = tmp_path / "files.jsonl"
    assert main(["batch", str(listing), "--K", K_OPTION, "--out", str(out2), "--workers", "1", "-q"]) == 0
    files = {json.loads(line)["image"]: json.loads(line) for line in out2.read_text().splitlines()}
    for k in (7, 19):  # a frame read from the video is the frame read from its PNG
        np.testing.assert_allclose(files[str(decoded / f"frame_{k:03d}.png")]["T_WC"], rows[k]["T_WC"], atol=1e-9)


@pytest.mark.slow  # whole calibrations through the CLI
def test_calibrate_takes_globs_and_list_files(tmp_path, capsys):
    from graphpose.synth.calibration import calibration_set, radtan_camera

    views = calibration_set(radtan_camera(), 6, rng=5)
    for k, image in enumerate(views.images):
        write_png(tmp_path / f"view_{k}.png", image)
    (tmp_path / "views.lst").write_text("".join(f"view_{k}.png\n" for k in range(6)))
    for source in (str(tmp_path / "view_*.png"), str(tmp_path / "views.lst")):
        assert main(["calibrate", source, "--board", "8x6x0.0635", "--out", str(tmp_path / "cam.json"), "-q",
                     "--json", str(tmp_path / "report.json")]) == 0
        assert len(json.loads((tmp_path / "report.json").read_text())["images"]) == 6


@pytest.fixture(scope="module")
def waved(tmp_path_factory):
    """A rendered clip of the board waved before a small radtan camera (8 s at 10 frames a
    second, fast moves between key poses, some boards partly out of view), as H.264."""
    from graphpose import RadTanCamera
    from graphpose.synth.clip import calibration_clip

    camera = RadTanCamera([[265.0, 0, 161.0], [0, 264.0, 120.5], [0, 0, 1]], [-0.3, 0.11, 0.0008, -0.0005, -0.02],
                          size=(320, 240))
    clip = calibration_clip(camera, 8.0, 10.0, rng=2, key_every_s=1.0, partial_share=0.3, max_subframes=4)
    path = tmp_path_factory.mktemp("waved") / "waved.mp4"
    with VideoWriter(path, 10) as w:
        for image in clip.frames():
            w.add(image)
    return path, clip


@pytest.mark.slow  # a whole calibration from a video
def test_calibrate_chooses_views_from_a_video(waved, tmp_path, capsys):
    path, clip = waved
    report = tmp_path / "report.json"
    assert main(["calibrate", str(path), "--board", "8x6x0.0635", "--out", str(tmp_path / "cam.json"),
                 "--json", str(report), "--max-views", "6"]) == 0
    out = capsys.readouterr().out
    doc = json.loads(report.read_text())
    frames = doc["views"]["frames"]
    assert len(frames) == len(clip) == 80
    used = [f["frame"] for f in frames if f["status"] == "used"]
    assert len(used) == 6 and [Path_name(i["image"]) for i in doc["images"]] == [f"waved.mp4#{k}" for k in used]
    assert all(clip.subframes[k] == 1 for k in used)  # no motion-blurred frame among them
    reasons = {f["status"] for f in frames} - {"used"}
    assert reasons <= {"no board", "too few junctions", "moving fast", "blurred", "near-duplicate",
                       "beyond max_views"} and "beyond max_views" in reasons
    assert all(f["detail"] for f in frames if f["status"] != "used")  # each reason in words
    assert f"views: 6 of 80 frames chosen" in out and ", ".join(f"#{k}" for k in used) in out


def Path_name(text):
    from pathlib import Path

    return Path(text).name

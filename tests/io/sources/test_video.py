"""graphpose.io.sources.video: videos read as the frames they hold, each at its presentation
time, in order or by seeking; a video cut short read up to where it broke, damage named."""

import numpy as np
import pytest

from graphpose.errors import InputError
from graphpose.io.sources import BrokenRecordingError, open_frames
from graphpose.io.sources.video_out import VideoWriter


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



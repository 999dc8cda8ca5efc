"""graphpose.io.sources.video_out: videos written frame by frame, checked by decoding them with
PyAV directly (not graphpose's own reader); a file appears whole or not at all."""

import numpy as np
import pytest

from graphpose.errors import InputError
from graphpose.io.sources.video_out import VideoWriter


def _decoded(path):
    """Every frame of ``path`` as grey uint8 and its time in seconds, by PyAV alone."""
    import av

    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        out = [(f.to_ndarray(format="gray"), float(f.pts * f.time_base)) for f in container.decode(stream)]
    return np.stack([im for im, _ in out]), np.array([t for _, t in out])


def test_frames_are_written_in_order_at_the_rate_asked(tmp_path):
    # Flat grey frames of distinct levels: through yuv420p, lossless H.264 (crf 0) and PyAV's
    # conversion back to full-range grey, each comes back within a level or so.
    levels = np.arange(20, 240, 20, dtype=np.uint8)
    path = tmp_path / "flat.mp4"
    with VideoWriter(path, 12.5, crf=0) as w:
        for g in levels:
            w.add(np.full((32, 48), g, np.uint8))
    assert w.count == len(levels)
    images, times = _decoded(path)
    assert images.shape == (len(levels), 32, 48)
    np.testing.assert_allclose(images.reshape(len(levels), -1).mean(axis=1), levels, atol=1.5)
    np.testing.assert_allclose(times - times[0], np.arange(len(levels)) / 12.5, atol=1e-3)


def test_rgb_frames_and_chosen_times(tmp_path):
    rgb = np.zeros((16, 16, 3), np.uint8)
    rgb[..., 1] = 200  # green: luma well above black
    path = tmp_path / "rgb.mkv"
    with VideoWriter(path, 10.0) as w:
        for t in (0.0, 0.25, 1.0):
            w.add(rgb, pts_s=t)
    images, times = _decoded(path)
    np.testing.assert_allclose(times - times[0], [0.0, 0.25, 1.0], atol=1e-3)
    assert images.mean() > 100


def test_a_failed_video_leaves_no_file(tmp_path):
    path = tmp_path / "v.mp4"
    with pytest.raises(RuntimeError, match="stopped"):
        with VideoWriter(path, 10.0) as w:
            w.add(np.zeros((16, 16), np.uint8))
            raise RuntimeError("stopped")
    assert list(tmp_path.iterdir()) == []  # neither the video nor the file written beside it


def test_bad_frames_are_refused_and_an_aborted_video_leaves_no_file(tmp_path):
    w = VideoWriter(tmp_path / "a.mp4", 10.0)
    for bad in (np.zeros((16, 16), np.float32), np.zeros((16, 16, 4), np.uint8)):
        with pytest.raises(InputError, match="a video frame must be uint8"):
            w.add(bad)
    with pytest.raises(InputError, match="yuv420p needs an even width and height, got 15 x 16"):
        w.add(np.zeros((16, 15), np.uint8))
    w.abort()
    assert list(tmp_path.iterdir()) == []

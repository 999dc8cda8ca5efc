"""Frames and their times: graphpose.track.frames."""

import numpy as np
import pytest

from graphpose import InputError
from graphpose.io.files import write_png
from graphpose.track.frames import (
    FrameSource,
    frame_timestamps,
    list_frames,
    read_timestamps,
)


def _grey(k):
    return np.full((24, 32), 40 * k, np.uint8)


def test_list_frames_reads_images_in_name_order_and_ignores_other_files(tmp_path):
    for name in ("f02.png", "f00.png", "f01.PNG"):
        write_png(tmp_path / name, _grey(1))
    (tmp_path / "notes.txt").write_text("not a frame")
    (tmp_path / "sub.png").mkdir()
    assert [p.name for p in list_frames(tmp_path)] == ["f00.png", "f01.PNG", "f02.png"]
    with pytest.raises(InputError, match="not found"):
        list_frames(tmp_path / "nowhere")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="no image files"):
        list_frames(tmp_path / "empty")


def test_read_timestamps(tmp_path):
    path = tmp_path / "t.txt"
    path.write_text("# seconds\n10.0\n\n10.1 1 2 3 0 0 0 1\n10.2,extra\n")
    np.testing.assert_array_equal(read_timestamps(path, 3), [10.0, 10.1, 10.2])


def test_read_timestamps_errors(tmp_path):
    path = tmp_path / "t.txt"
    path.write_text("0.0\nabc\n")
    with pytest.raises(InputError, match="t.txt:2"):
        read_timestamps(path)
    path.write_text("0.0\n0.1\n")
    with pytest.raises(InputError, match="2 timestamps for 3 frames"):
        read_timestamps(path, 3)
    path.write_text("0.0\n0.0\n")
    with pytest.raises(InputError, match="increasing"):
        read_timestamps(path)
    with pytest.raises(InputError, match="not found"):
        read_timestamps(tmp_path / "missing.txt")
    with pytest.raises(InputError, match="cannot read timestamps file"):
        read_timestamps(tmp_path)  # a folder
    path.write_bytes(b"\xff\xfe\x00\x81")
    with pytest.raises(InputError, match="cannot read timestamps file"):
        read_timestamps(path)  # not text


def test_frame_timestamps():
    np.testing.assert_allclose(frame_timestamps(None, 25.0, 3), [0.0, 0.04, 0.08])
    np.testing.assert_array_equal(frame_timestamps([[1.0], [2.0]], 25.0, 2), [1.0, 2.0])
    with pytest.raises(InputError, match="timestamps has 1 entries for 2 frames"):
        frame_timestamps([0.0], 30.0, 2)
    with pytest.raises(InputError, match="increasing"):
        frame_timestamps([1.0, 1.0], 30.0, 2)
    with pytest.raises(InputError, match="fps"):
        frame_timestamps(None, 0.0, 2)


def test_frame_sources(tmp_path):
    for k in range(2):
        write_png(tmp_path / f"f{k}.png", _grey(k + 1))
    folder = FrameSource(tmp_path)
    assert len(folder) == 2 and folder.path(1) == tmp_path / "f1.png"
    frame = folder.load(1)  # an 8-bit file is read as estimate reads it: uint8, as it is
    assert frame.dtype == np.uint8 and np.all(frame == 80)
    files = FrameSource([str(tmp_path / "f1.png"), tmp_path / "f0.png"])
    assert files.path(0) == tmp_path / "f1.png"
    stack = FrameSource(np.stack([_grey(1), _grey(2)]))
    assert len(stack) == 2 and stack.path(0) is None
    assert stack.load(1).dtype == np.uint8  # 8-bit grey is used as it is
    mixed = FrameSource([_grey(1), tmp_path / "f0.png"])
    assert mixed.path(0) is None and mixed.path(1) == tmp_path / "f0.png"


def test_frames_are_converted_to_grey_once():
    grey = _grey(3)
    source = FrameSource([grey / 255.0, np.dstack([grey] * 3), grey.astype(np.uint16) * 257])
    for k in range(3):
        np.testing.assert_allclose(source.load(k), 120 / 255.0, atol=1e-12)


def test_frame_sources_that_are_not_sequences():
    with pytest.raises(InputError, match=r"one array of shape \(24, 32\)"):
        FrameSource(_grey(1))
    with pytest.raises(InputError, match="got int"):
        FrameSource(5)


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_bad_frames_are_errors_naming_the_frame(tmp_path):
    nan_frame = _grey(1) / 255.0
    nan_frame[3, 3] = np.nan
    source = FrameSource([_grey(1), nan_frame, [[0.0, 1.0], [2.0]], np.zeros((2, 2, 2))])
    with pytest.raises(InputError, match="frame 1 .*NaN"):
        source.load(1)
    with pytest.raises(InputError, match="frame 2 must be"):
        source.load(2)
    with pytest.raises(InputError, match="frame 3 must be"):
        source.load(3)
    (tmp_path / "broken.png").write_bytes(b"\x89PNG not really")
    with pytest.raises(InputError, match="cannot read image .*broken.png"):
        FrameSource([tmp_path / "broken.png"]).load(0)

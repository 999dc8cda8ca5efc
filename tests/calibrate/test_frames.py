"""graphpose.calibrate.frames: one camera's image files (folder, glob, file, list), the number in
a file's name, and the cameras' frames grouped into views by number or timestamp."""

import pytest

from graphpose import InputError
from graphpose.calibrate.frames import file_number, match_frames, source_files


def test_frames_match_by_number_or_timestamp():
    assert file_number("left07.jpg") == 7 and file_number("cam2/img_0012.png") == 12
    with pytest.raises(InputError, match="no frame number"):
        file_number("left.jpg")
    assert match_frames([[1, 2, 4], [2, 3, 4]]) == [(0, None), (1, 0), (None, 1), (2, 2)]
    # Timestamps in seconds within a tolerance; each camera gives at most one frame a view.
    views = match_frames([[0.0, 0.1, 0.2], [0.004, 0.103, 0.35]], tolerance=0.01)
    assert views == [(0, 0), (1, 1), (2, None), (None, 2)]
    with pytest.raises(InputError, match="repeat"):
        match_frames([[1, 1], [1, 2]])


def test_match_frames_groups_within_the_tolerance_from_a_view_s_first_stamp():
    # The spread is measured from a view's first stamp: 0.0, 0.008 join; 0.016 is 0.016 from
    # the first, so it starts the next view even though it is 0.008 from the second.
    assert match_frames([[0.0], [0.008], [0.016]], tolerance=0.01) == [(0, 0, None), (None, None, 0)]
    # Three cameras, a camera missing from the middle view; stamps given out of order.
    assert match_frames([[5, 1], [1, 5], [1, 3, 5]]) == [(1, 0, 0), (None, None, 1), (0, 1, 2)]
    assert match_frames([[], []]) == []


def _touch(folder, *names):
    for name in names:
        (folder / name).write_bytes(b"")
    return [folder / n for n in names]


def test_source_files_from_a_folder_a_glob_a_file_or_a_list(tmp_path):
    left = _touch(tmp_path, "left02.jpg", "left01.jpg", "left10.png")
    right = _touch(tmp_path, "right01.jpg")
    _touch(tmp_path, "notes.txt")
    assert source_files(tmp_path) == sorted(left + right)  # images only, in name order
    assert source_files(str(tmp_path / "left*.jpg")) == sorted(left[:2])
    assert source_files(right[0]) == right
    assert source_files([str(left[2]), left[0]]) == [left[2], left[0]]  # a list as given


def test_source_files_names_the_source_in_its_errors(tmp_path):
    with pytest.raises(InputError, match=r"^camera 1: .*nothing_here is no file, folder or glob pattern"):
        source_files(tmp_path / "nothing_here", "camera 1")
    with pytest.raises(InputError, match=r"^right: .*\*\.png holds no image file"):
        source_files(str(tmp_path / "*.png"), "right")
    with pytest.raises(InputError, match="^source: image not found: .*gone.jpg"):
        source_files([tmp_path / "gone.jpg"])
    with pytest.raises(InputError, match="^left: no image given"):
        source_files([], "left")

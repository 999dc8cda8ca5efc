"""graphpose.io.sources.paths: globs, list files and folders expanded to image files, and the
one rule for a folder's images."""

import os

import numpy as np
import pytest

from graphpose.errors import InputError
from graphpose.io.files import write_png
from graphpose.io.sources import ImageFiles, expand_paths, open_frames


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

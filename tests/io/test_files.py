"""Files out and in (graphpose.io.files): JSON read and written whole, PNG bytes."""

import json
import struct

import numpy as np
import pytest

from graphpose import InputError
from graphpose.io.files import (
    atomic_write,
    dumps_json,
    encode_png,
    read_json,
    write_json,
    write_png,
)


def png_size(path):
    """(width, height) from a PNG file's header; fails unless the file is a PNG."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def test_read_json_names_what_it_reads(tmp_path):
    path = tmp_path / "a.json"
    path.write_text('{"a": [1, 2.5]}')
    assert read_json(path) == {"a": [1, 2.5]}
    with pytest.raises(InputError, match=f"pose file not found: {tmp_path / 'b.json'}"):
        read_json(tmp_path / "b.json", "pose file")
    path.write_text("{oops")
    with pytest.raises(InputError, match=f"cannot read case file {path}: "):
        read_json(path, "case file")


def test_atomic_write_leaves_old_file_or_nothing(tmp_path):
    target = tmp_path / "out.json"
    write_json(target, {"a": np.array([1.0, np.nan]), "b": np.bool_(True)})
    assert json.loads(target.read_text()) == {"a": [1.0, None], "b": True}
    (tmp_path / "dir").mkdir()
    with pytest.raises(InputError, match="cannot write"):
        atomic_write(tmp_path / "dir", b"x")  # replacing a folder fails
    with pytest.raises(InputError, match="cannot write"):
        atomic_write(tmp_path / "nowhere" / "out.json", b"x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir", "out.json"]


def test_json_text_round_trip_with_one_matrix_row_per_line():
    value = [{"name": "a b", "T": np.eye(4), "empty": {}, "none": [], "nested": [{"x": [1, 2]}, "s"],
              "ok": np.bool_(False), "nan": float("nan")}]
    text = dumps_json(value)
    assert json.loads(text) == [{"name": "a b", "T": np.eye(4).tolist(), "empty": {}, "none": [],
                                 "nested": [{"x": [1, 2]}, "s"], "ok": False, "nan": None}]
    assert '"T": [[1.0, 0.0, 0.0, 0.0],\n' in text and text.count("[0.0, 0.0, 0.0, 1.0]") == 1


def test_png_round_trip(tmp_path):
    from skimage.io import imread

    rgb = np.random.default_rng(3).integers(0, 256, (5, 7, 3), dtype=np.uint8)
    path = tmp_path / "x.png"
    path.write_bytes(encode_png(rgb))
    np.testing.assert_array_equal(imread(path), rgb)
    assert png_size(path) == (7, 5)
    grey = tmp_path / "grey.png"
    write_png(grey, rgb[..., 0])
    np.testing.assert_array_equal(imread(grey), rgb[..., 0])
    with pytest.raises(InputError, match="uint8"):
        encode_png(rgb.astype(float))


def test_atomic_file_appears_only_at_commit_and_abort_leaves_the_old_file(tmp_path):
    from graphpose.io.files import AtomicFile

    path = tmp_path / "out.txt"
    path.write_text("old")
    f = AtomicFile(path)
    f.file.write("new\r\nline")  # text, newlines as given
    assert path.read_text() == "old" and f.tmp.parent == tmp_path and f.tmp.name.startswith(".out.txt.")
    f.commit()
    assert path.read_bytes() == b"new\r\nline"
    g = AtomicFile(path, binary=True, suffix="body")
    g.file.write(b"half")
    assert g.tmp.name.endswith(".body")
    g.abort()
    assert path.read_bytes() == b"new\r\nline" and sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]
    with pytest.raises(InputError, match="cannot write .*nowhere"):
        AtomicFile(tmp_path / "nowhere" / "x.txt")

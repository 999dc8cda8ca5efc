"""Image paths from folders, patterns and list files; per-image polygons from a bounds file."""

import json
import os

import numpy as np
import pytest

from graphpose import InputError
from graphpose.batch.inputs import check_polygon, collect_images, read_bounds_file


@pytest.fixture
def tree(tmp_path):
    """a/1.png a/2.JPG a/notes.md a/sub/3.png b/4.png, and a link to a/1.png."""
    for name in ("a/1.png", "a/2.JPG", "a/notes.md", "a/sub/3.png", "b/4.png"):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(b"")
    os.symlink("a/1.png", tmp_path / "link.png")
    return tmp_path


def test_a_folder_gives_its_image_files_by_name(tree):
    assert collect_images([tree / "a"]) == [str(tree / "a/1.png"), str(tree / "a/2.JPG")]


def test_patterns_match_files_and_double_star_crosses_folders(tree):
    assert collect_images([str(tree / "*/*.png")]) == [str(tree / "a/1.png"), str(tree / "b/4.png")]
    assert collect_images([str(tree / "**/*.png")]) == [
        str(tree / p) for p in ("a/1.png", "a/sub/3.png", "b/4.png", "link.png")]
    with pytest.raises(InputError, match="matches no file"):
        collect_images([str(tree / "*.tif")])


def test_a_list_file_is_relative_to_its_folder_and_keeps_missing_images(tree, monkeypatch):
    (tree / "b/list.txt").write_text("# images\n\n4.png\n../a/1.png\n  missing.png  \n" + str(tree / "a/2.JPG") + "\n")
    monkeypatch.chdir(tree / "a")
    assert collect_images(["../b/list.txt"]) == [
        str(tree / "b/4.png"), str(tree / "a/1.png"), str(tree / "b/missing.png"), str(tree / "a/2.JPG")]


def test_each_path_once_in_order_links_kept_apart_and_absolute(tree, monkeypatch):
    monkeypatch.chdir(tree)
    got = collect_images(["a/1.png", "a", "link.png", "./a/1.png", "gone.png"])
    assert got == [str(tree / "a/1.png"), str(tree / "a/2.JPG"), str(tree / "link.png"), str(tree / "gone.png")]


def test_nothing_to_do_is_an_error(tree):
    (tree / "empty").mkdir()
    with pytest.raises(InputError, match="no image files"):
        collect_images([tree / "empty"])
    with pytest.raises(InputError, match="no images"):
        collect_images([])
    (tree / "empty.txt").write_text("# nothing\n")
    with pytest.raises(InputError, match="no images"):
        collect_images([tree / "empty.txt"])


def test_bounds_file_as_a_mapping_or_a_case_file(tmp_path):
    poly = [[10, 300, 310, 5], [20, 15, 200, 210]]
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub/map.json").write_text(json.dumps({"x.png": poly, "/abs/y.png": None}))
    got = read_bounds_file(tmp_path / "sub/map.json")
    assert set(got) == {str(tmp_path / "sub/x.png"), "/abs/y.png"}
    assert np.array_equal(got[str(tmp_path / "sub/x.png")], poly) and got["/abs/y.png"] is None
    (tmp_path / "cases.json").write_text(json.dumps({"K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
                                                     "cases": [{"image": "sub/x.png", "bounds": poly}]}))
    got = read_bounds_file(tmp_path / "cases.json")
    assert list(got) == [str(tmp_path / "sub/x.png")]
    # A case file's case without bounds is searched whole, as 'graphpose estimate --cases' does.
    (tmp_path / "cases.json").write_text(json.dumps({"cases": [{"image": "sub/x.png"}, {"image": "z.png",
                                                                                      "bounds": poly}]}))
    got = read_bounds_file(tmp_path / "cases.json")
    assert got[str(tmp_path / "sub/x.png")] is None and np.array_equal(got[str(tmp_path / "z.png")], poly)


@pytest.mark.parametrize("doc, fragment", [
    ([1, 2], "JSON object"),
    ({"x.png": [[1, 2, 3], [4, 5, 6]]}, r"bounds of x.png .* shape \(2, 4\)"),
    ({"x.png": [["a"] * 4, ["b"] * 4]}, "real numbers"),
    ({"cases": [{"bounds": None}]}, r"cases\[0\] must be an object with 'image'"),
])
def test_bad_bounds_files(tmp_path, doc, fragment):
    (tmp_path / "b.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=fragment):
        read_bounds_file(tmp_path / "b.json")
    with pytest.raises(InputError, match="not found"):
        read_bounds_file(tmp_path / "absent.json")


def test_a_polygon_must_be_finite():
    with pytest.raises(InputError, match="NaN or infinite"):
        check_polygon([[0, 1, 2, np.nan], [0, 1, 2, 3]], "bounds")

"""estimate_images, the worker's function, run in this process: each outcome's row and status."""

import imageio.v3 as iio
import numpy as np
import pytest

import graphpose.estimate
from graphpose.batch.work import (
    BOARD_NOT_FOUND,
    CRASHED,
    ERROR,
    EXTRA_KEYS,
    FAILED,
    MISSING,
    OK,
    UNREADABLE,
    estimate_images,
    failed_record,
    warm_up,
)
from graphpose.io.records import result_record
from graphpose.image import read_image
from graphpose.estimate import estimate_pose
from tests.batch.helpers import make_image_set


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    return make_image_set(tmp_path_factory.mktemp("work-images"), n_files=2, n_paths=2)


def test_a_good_image_gives_the_estimate_json_record_of_estimate_pose(images):
    path = images.paths[0]
    [row] = estimate_images([(path, images.bounds[path])], images.K, images.board)
    expected = result_record(path, images.expected[path], None)
    assert row["status"] == OK and row["time_s"] > 0 and row["worker"] is None
    assert list(row) == [*expected, "camera", "board", *EXTRA_KEYS]
    assert {k: row[k] for k in expected} == expected
    assert row["camera"]["model"] == "pinhole" and row["camera"]["K"] == images.K.tolist()
    assert row["board"] == {"cols": 8, "rows": 6, "square_m": 0.0635}
    assert row["bounds"] == images.bounds[path].tolist() and row["robust"] is False


def test_each_failure_is_its_own_row_and_the_rest_go_on(images, tmp_path):
    blank = tmp_path / "blank.png"
    iio.imwrite(blank, np.full((240, 320), 128, np.uint8))
    good = images.paths[0]
    off = np.array([[1000.0, 2000.0, 2000.0, 1000.0], [0.0, 0.0, 100.0, 100.0]])
    items = [(images.missing, None), (images.corrupt, None), (str(blank), None), (good, off),
             (good, images.bounds[good])]
    rows = estimate_images(items, images.K, images.board)
    assert [r["image"] for r in rows] == [p for p, _ in items]
    assert [r["status"] for r in rows] == [MISSING, UNREADABLE, BOARD_NOT_FOUND, FAILED, OK]
    assert rows[0]["message"] == f"image file not found: {images.missing}"
    assert "cannot read image" in rows[1]["message"]
    assert "bounds" in rows[3]["message"]
    for row in rows[:4]:
        assert row["T_WC"] is None and row["message"] and "\n" not in row["message"]


def test_an_unexpected_exception_is_an_error_row_with_its_type(images, monkeypatch):
    def broken(*args, **kwargs):
        raise ZeroDivisionError("a bug\nover two lines")

    monkeypatch.setattr(graphpose.estimate, "estimate_pose", broken)
    [row] = estimate_images([(images.paths[0], images.bounds[images.paths[0]])], images.K, images.board)
    assert row["status"] == ERROR and row["message"] == "ZeroDivisionError: a bug over two lines"


def test_no_polygon_is_estimate_pose_without_bounds(images):
    # graphpose estimate IMAGE without --bounds: the library searches the whole image.
    path = images.paths[1]
    [row] = estimate_images([(path, None)], images.K, images.board)
    expected = result_record(path, estimate_pose(read_image(path, as_float=False), images.K, bounds=None,
                                                 board=images.board), None)
    assert {k: row[k] for k in expected} == expected


def test_failed_record_has_every_key(images):
    row = failed_record("x.png", CRASHED, "the worker died")
    good = estimate_images([(images.paths[0], images.bounds[images.paths[0]])], images.K, images.board)[0]
    assert list(row) == list(good)
    assert (row["status"], row["message"], row["T_WC"]) == (CRASHED, "the worker died", None)
    warm_up()  # imports only; must not fail

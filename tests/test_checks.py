"""graphpose._checks: every checker's error paths, once each, and what the checkers return.

The modules that call them test only that they do (one bad value each); the messages are
pinned here.
"""

import numpy as np
import pytest

from graphpose import Board, InputError
from graphpose._checks import (
    as_float_array,
    as_points,
    as_polygon,
    check_bounds,
    check_correspondences,
    check_count,
    check_image,
    check_in_front,
    check_K,
    check_number,
    check_range,
    check_size,
    check_timestamps,
    check_transform,
)
from graphpose.board import check_board
from graphpose.geometry import T_from_params, project
from tests.conftest import BOARD_WPTS, PROJECT_K


@pytest.mark.parametrize(
    "K, message",
    [
        (np.eye(2), "shape"),
        ([[500, 0, 320], [0, 500, np.nan], [0, 0, 1]], "NaN"),
        ([[0, 0, 320], [0, 500, 240], [0, 0, 1]], "focal"),
        ([[500, 0, 320], [0, 500, 240], [0, 1, 1]], "last row"),
    ],
)
def test_check_K_rejects(K, message):
    with pytest.raises(InputError, match=message):
        check_K(K)


def test_check_transform_rejects():
    with pytest.raises(InputError, match="shape"):
        check_transform(np.eye(3))
    with pytest.raises(InputError, match="NaN"):
        check_transform(np.full((4, 4), np.nan))
    bad = np.eye(4)
    bad[0, 0] = -1.0  # a reflection, det -1
    with pytest.raises(InputError, match="rotation"):
        check_transform(bad)
    bad = np.eye(4)
    bad[3, 0] = 1.0
    with pytest.raises(InputError, match="last row"):
        check_transform(bad)


def test_as_points_rejects():
    with pytest.raises(InputError, match=r"shape \(2, N\)"):
        as_points(np.zeros((3, 4)), 2)
    with pytest.raises(InputError, match="NaN"):
        as_points([[np.nan], [0.0]], 2)
    with pytest.raises(InputError, match="at least 4"):
        as_points(np.zeros((2, 3)), 2, min_count=4)


def test_as_float_array_converts_numbers_and_checks_shape():
    a = np.eye(3)
    assert as_float_array(a, "a") is a
    out = as_float_array([[1, 2], [True, 4]], "a", shape=(2, 2))
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, [[1.0, 2.0], [1.0, 4.0]])
    with pytest.raises(InputError, match=r"a must have shape \(3,\), got \(2, 2\)"):
        as_float_array(out, "a", shape=(3,))


@pytest.mark.parametrize("bad", [[[1, 2], [3]], "abc", "1.5", ["1", "2"], [1j, 2], [1, None], {"a": 1}])
def test_as_float_array_refuses_non_numbers(bad):
    with pytest.raises(InputError, match="thing must be a rectangular array of real numbers"):
        as_float_array(bad, "thing")


def test_public_validators_name_the_parameter_on_non_numbers():
    with pytest.raises(InputError, match="K must be"):
        check_K("abc")
    with pytest.raises(InputError, match="T_guess must be"):
        check_transform([[1, 0], [0]], "T_guess")
    with pytest.raises(InputError, match="Ipts must be"):
        as_points([[1, 2], [3]], 2, "Ipts")



def test_as_polygon_takes_any_polygon_or_a_given_vertex_count():
    triangle = as_polygon([[0, 10, 5], [0, 0, 8]], "p")
    assert triangle.dtype == np.float64 and triangle.shape == (2, 3)
    assert as_polygon(np.zeros((2, 4)), "p", 4).shape == (2, 4)
    with pytest.raises(InputError, match=r"p must have shape \(2, m\) with m >= 3 vertices .*got \(2, 2\)"):
        as_polygon(np.zeros((2, 2)), "p")
    with pytest.raises(InputError, match=r"p must have shape \(2, m\) with m >= 3 vertices .*got \(4, 2\)"):
        as_polygon(np.zeros((4, 2)), "p")
    with pytest.raises(InputError, match=r"p must have shape \(2, 4\) \(u and v of 4 vertices\), got \(2, 5\)"):
        as_polygon(np.zeros((2, 5)), "p", 4)
    with pytest.raises(InputError, match="p contains NaN"):
        as_polygon([[0, 1, np.inf], [0, 1, 2]], "p")
    with pytest.raises(InputError, match="p must be a rectangular array of real numbers"):
        as_polygon([[0, 1, 2], [0, 1]], "p")


@pytest.mark.parametrize("image, message", [
    (np.zeros((0, 3)), r"img is empty, shape \(0, 3\)"),
    (np.zeros((4, 4, 2)), r"img must be 2-D grey or \(H, W, 3\|4\) colour, got shape \(4, 4, 2\)"),
    (np.zeros(5), "img must be 2-D grey"),
    (np.zeros((2, 9)), r"img must be at least 3 x 3 pixels, got shape \(2, 9\)"),
    (np.full((4, 4), np.nan), "img contains NaN or infinite values"),
    (np.zeros((4, 4), complex), "img has unsupported dtype complex128"),
    (np.array([["a", "b"]]), "img has unsupported dtype"),
    ([[1, 2, 3], [4, 5]], "img must be a rectangular array of real numbers"),
])
def test_check_image_rejects(image, message):
    with pytest.raises(InputError, match=message):
        check_image(image, "img", min_side=3)


def test_check_image_returns_the_array_itself_and_takes_colour_only_when_asked():
    image = np.zeros((5, 6, 4), np.uint8)
    assert check_image(image) is image
    assert check_image([[1, 2], [3, 4]]).dtype.kind == "i"
    with pytest.raises(InputError, match=r"patch must be 2-D, got shape \(5, 6, 4\)"):
        check_image(image, "patch", colour=False)


def test_check_bounds_rejects_each_fault_and_names_the_parameter():
    shape = (480, 640)
    good = np.array([[100.0, 500, 500, 100], [100, 100, 400, 400]])
    np.testing.assert_array_equal(check_bounds(good.tolist(), shape), good)
    for poly, message in [
        (good[:, :3], r"--bounds must have shape \(2, 4\)"),
        (np.where(good == 500, np.nan, good), "--bounds contains NaN"),
        (good + [[700], [0]], r"--bounds vertices \[0, 1, 2, 3\] lie off the 640 x 480 image"),
        (good[:, ::-1], "--bounds must run clockwise"),
        (np.array([[100.0, 500, 200, 100], [100, 100, 200, 400]]), "--bounds must be a convex quadrilateral"),
        (np.array([[100.0, 105, 105, 100], [100, 100, 105, 105]]), r"--bounds is degenerate \(area 25.0 px\^2\)"),
    ]:
        with pytest.raises(InputError, match=message):
            check_bounds(poly, shape, "--bounds")
    # Without an image shape, the polygon alone is checked.
    np.testing.assert_array_equal(check_bounds(good + [[700], [0]], None), good + [[700], [0]])


def test_check_correspondences_rejects_and_fills_in_the_mask():
    T = T_from_params([0.2, 0.15, -1.0, 0.0, 0.0, 0.0])
    I = project(PROJECT_K, T, BOARD_WPTS)
    K, Ipts, Wpts, mask = check_correspondences(PROJECT_K.tolist(), I, BOARD_WPTS)
    assert mask.shape == (48,) and mask.all() and Ipts.shape == (2, 48) and K.shape == (3, 3)
    for args, message in [
        ((PROJECT_K, I[:, :40], BOARD_WPTS), "Ipts and Wpts must hold the same number of points, got 40 and 48"),
        ((PROJECT_K, I, BOARD_WPTS, np.ones(47, bool)), r"mask must be a boolean array of shape \(48,\)"),
        ((PROJECT_K, I, BOARD_WPTS, np.ones(48)), r"mask must be a boolean array of shape \(48,\), got float64"),
        ((PROJECT_K, I, BOARD_WPTS, np.arange(48) < 3), "pose needs at least 4 trusted points, got 3"),
        ((PROJECT_K, I[:1], BOARD_WPTS), r"Ipts must have shape \(2, N\)"),
    ]:
        with pytest.raises(InputError, match=message):
            check_correspondences(*args)


def test_check_in_front_names_the_callers_index():
    check_in_front(np.array([1.0, 2.0]), "the guess")
    with pytest.raises(InputError, match=r"2 target point\(s\) lie at or behind the camera at the guess "
                       r"\(first index 7, depth -1 m\)"):
        check_in_front(np.array([1.0, -1.0, 0.0]), "the guess", index=[3, 7, 9])


@pytest.mark.parametrize("value, kwargs, message", [
    ("1", {}, "x must be a finite number, got '1'"),
    (True, {}, "x must be a finite number, got True"),
    (np.nan, {}, "x must be a finite number, got nan"),
    (-1.0, {"minimum": 0.0}, "x must be a finite number >= 0, got -1.0"),
    (0.0, {"minimum": 0.0, "strict": True}, "x must be a finite number > 0, got 0.0"),
    (0.8, {"minimum": 0.0, "maximum": 0.7}, "x must be a finite number >= 0 and <= 0.7, got 0.8"),
])
def test_check_number_rejects(value, kwargs, message):
    with pytest.raises(InputError) as info:
        check_number("x", value, **kwargs)
    assert str(info.value) == message


def test_check_number_returns_a_float():
    assert check_number("x", np.int64(3), 0.0) == 3.0 and isinstance(check_number("x", 3), float)


@pytest.mark.parametrize("value, message", [
    (1.0, r"r must be a pair \(low, high\) metres, got 1.0"),
    ("ab", r"r must be a pair \(low, high\) metres, got 'ab'"),
    ((2.0, 1.0), r"r must be a pair \(low, high\) metres with low <= high, low > 0, got \(2.0, 1.0\)"),
    ((0.0, 1.0), r"with low <= high, low > 0, got \(0.0, 1.0\)"),
    ((0.5, np.inf), "with low <= high, low > 0"),
])
def test_check_range_rejects(value, message):
    with pytest.raises(InputError, match=message):
        check_range("r", value, "(low, high) metres", 0.0, strict=True)
    assert check_range("r", [0.5, 2], "(low, high)") == (0.5, 2.0)


@pytest.mark.parametrize("value", [1, 2.0, 8.9, "3", True, None])
def test_check_count_rejects(value):
    with pytest.raises(InputError, match=f"n must be an integer >= 2, got {value!r}"):
        check_count("n", value, 2)
    assert check_count("n", np.int32(5), 2) == 5


def test_check_size_rejects():
    assert check_size((640, 480)) == (640, 480)
    with pytest.raises(InputError, match="size must be"):
        check_size(640)
    with pytest.raises(InputError, match="size height must be a positive integer, got 0"):
        check_size((640, 0))


def test_check_board_rejects_what_is_not_a_board():
    board = Board(5, 4)
    assert check_board(board) is board
    with pytest.raises(InputError, match="board must be a graphpose.Board, got tuple"):
        check_board((8, 6))


def test_check_timestamps_rejects():
    np.testing.assert_array_equal(check_timestamps([0, 1, 2.5]), [0.0, 1.0, 2.5])
    with pytest.raises(InputError, match=r"t must be 1-D \(one time per frame\), got shape \(1, 2\)"):
        check_timestamps([[0, 1]], "t")
    with pytest.raises(InputError, match="strictly increasing"):
        check_timestamps([0, 1, 1], "t")


def test_min_pose_points_is_the_one_minimum_of_the_pose_checks_and_the_tracker_setting():
    from graphpose._checks import MIN_POSE_POINTS, check_correspondences
    from graphpose.track.config import TrackerConfig

    K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    rng = np.random.default_rng(1)
    W = np.vstack([rng.uniform(0, 0.2, (2, MIN_POSE_POINTS)), np.zeros((1, MIN_POSE_POINTS))])
    I = rng.uniform(0, 400, (2, MIN_POSE_POINTS))
    assert check_correspondences(K, I, W)[3].sum() == MIN_POSE_POINTS
    with pytest.raises(InputError, match=f"at least {MIN_POSE_POINTS} trusted points, got {MIN_POSE_POINTS - 1}"):
        check_correspondences(K, I[:, 1:], W[:, 1:])
    assert TrackerConfig(min_junctions=MIN_POSE_POINTS).min_junctions == MIN_POSE_POINTS
    with pytest.raises(InputError, match=f"integer >= {MIN_POSE_POINTS}"):
        TrackerConfig(min_junctions=MIN_POSE_POINTS - 1)

import numpy as np
import pytest

from graphpose import Board, InputError
from graphpose._checks import as_float_array, as_points, check_K, check_transform
from graphpose.camera import (
    C_from_rpy,
    T_from_params,
    params_from_T,
    project,
    rpy_from_C,
    to_camera,
)


def test_euler_round_trip_random():
    rng = np.random.default_rng(0)
    for _ in range(500):
        rpy = rng.uniform([-np.pi, -np.pi / 2, -np.pi], [np.pi, np.pi / 2, np.pi])
        C = C_from_rpy(*rpy)
        np.testing.assert_allclose(C.T @ C, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(rpy_from_C(C), rpy, atol=1e-9)


@pytest.mark.parametrize("pitch", [np.pi / 2, -np.pi / 2])
def test_euler_gimbal_lock_reproduces_rotation(pitch):
    C = C_from_rpy(0.3, pitch, -1.1)
    rpy = rpy_from_C(C)
    assert rpy[0] == 0.0
    np.testing.assert_allclose(C_from_rpy(*rpy), C, atol=1e-9)


def test_euler_order_is_zyx():
    # A pure yaw turns x into y; roll then pitch then yaw are applied in that order.
    np.testing.assert_allclose(C_from_rpy(0, 0, np.pi / 2) @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    C = C_from_rpy(0.1, 0.2, 0.3)
    Cx = C_from_rpy(0.1, 0, 0)
    Cy = C_from_rpy(0, 0.2, 0)
    Cz = C_from_rpy(0, 0, 0.3)
    np.testing.assert_allclose(C, Cz @ Cy @ Cx, atol=1e-12)


def test_params_round_trip():
    p = np.array([0.2, -0.1, -1.2, 3.0, 0.4, -2.0])
    np.testing.assert_allclose(params_from_T(T_from_params(p)), p, atol=1e-12)


def test_project_centre_of_fronto_parallel_camera():
    K = check_K([[500, 0, 320], [0, 500, 240], [0, 0, 1]])
    T = T_from_params([0.1, 0.2, -1.0, 0, 0, 0])
    uv = project(K, T, [[0.1, 0.2], [0.2, 0.2], [0.0, 0.0]])
    np.testing.assert_allclose(uv, [[320, 370], [240, 240]])
    assert to_camera(T, [[0.1], [0.2], [0.0]])[2, 0] == pytest.approx(1.0)


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


def test_board_world_points_and_parse():
    b = Board()
    W = b.world_points()
    assert W.shape == (3, 48)
    np.testing.assert_allclose(W[:, 9], [0.0635, 0.0635, 0.0])
    assert Board.parse("9x7x0.03") == Board(9, 7, 0.03)
    assert Board.from_world_points(W) == b
    with pytest.raises(InputError, match="COLSxROWS"):
        Board.parse("8x6")
    with pytest.raises(InputError, match="grid"):
        Board.from_world_points(W[:, ::-1])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"cols": 1}, "cols must be an integer >= 2"),
        ({"rows": 2.0}, "rows must be an integer >= 2"),
        ({"square_m": 0.0}, "square_m must be a positive number"),
        ({"square_m": -0.1}, "square_m must be a positive number"),
        ({"square_m": np.inf}, "square_m must be a positive number"),
        ({"square_m": "0.1"}, "square_m must be a rectangular array of real numbers"),
        ({"square_m": [0.1, 0.2]}, r"square_m must have shape \(\)"),
    ],
)
def test_board_rejects(kwargs, message):
    with pytest.raises(InputError, match=message):
        Board(**kwargs)


def test_board_from_world_points_rejects_a_partial_grid():
    W = Board().world_points()
    with pytest.raises(InputError, match="47 points is not a full row-major grid"):
        Board.from_world_points(W[:, :47])  # last row one junction short
    with pytest.raises(InputError, match="starting at the upper-left junction"):
        Board.from_world_points(W + [[0.01], [0.0], [0.0]])
    with pytest.raises(InputError, match=r"shape \(3, n\)"):
        Board.from_world_points(W[:2])
    with pytest.raises(InputError, match="NaN"):
        Board.from_world_points(np.where(W == W[0, 5], np.nan, W))
    with pytest.raises(InputError, match="Wpts must be a rectangular array"):
        Board.from_world_points([[0.0, 1.0], [0.0]])


def test_sheet_corners_border_the_squares_clockwise():
    b = Board(4, 3, 0.5)
    np.testing.assert_array_equal(b.sheet_corners(0.0), [[-0.5, 2.0, 2.0, -0.5], [-0.5, -0.5, 1.5, 1.5], [0, 0, 0, 0]])
    np.testing.assert_array_equal(
        b.sheet_corners(), [[-0.75, 2.25, 2.25, -0.75], [-0.75, -0.75, 1.75, 1.75], [0, 0, 0, 0]])
    per_corner = b.sheet_corners([0.0, 1.0, 2.0, 3.0])
    np.testing.assert_array_equal(per_corner[:2], [[-0.5, 2.5, 3.0, -2.0], [-0.5, -1.0, 2.5, 3.0]])


@pytest.mark.parametrize("margin", [-0.1, np.nan, [0.5, 0.5], "wide"])
def test_sheet_corners_rejects_bad_margin(margin):
    with pytest.raises(InputError, match="margin must be"):
        Board().sheet_corners(margin)


def test_real_world_points_match_board(real_cases):
    import json

    from tests.conftest import REAL_DIR

    W = np.asarray(json.loads((REAL_DIR / "cases.json").read_text())["world_points"])
    assert real_cases.board == Board()
    np.testing.assert_allclose(Board.from_world_points(W).world_points(), W, atol=1e-12)

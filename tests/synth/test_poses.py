"""graphpose.synth.poses: random poses with the sheet in view, pose guesses, loose polygons.

Each property is the docstring's promise, checked over a few seeds with exact geometry
(the sheet's corners projected through the same camera).
"""

import numpy as np
import pytest

from graphpose import Board, FisheyeCamera, InputError, PinholeCamera
from graphpose.geometry import project, to_camera
from graphpose.synth.poses import _turn_towards, loose_polygon, perturb_pose, random_pose
from graphpose.synth.render import render
from tests.conftest import PROJECT_K as K

SIZE = (640, 480)


def _rotation_angle_deg(R):
    return np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)))


@pytest.mark.parametrize("seed", range(5))
def test_a_random_pose_keeps_the_whole_sheet_border_px_inside_the_image(seed):
    board = Board()
    T = random_pose(K, board=board, size=SIZE, rng=seed, border_px=8.0)
    np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)
    corners = project(K, T, board.sheet_corners(0.5))
    # 8 px: border_px as given; the image's pixel centres run from 0 to size - 1.
    assert corners.min() >= 8.0 - 1e-9
    assert np.all(corners[0] <= SIZE[0] - 1 - 8.0 + 1e-9) and np.all(corners[1] <= SIZE[1] - 1 - 8.0 + 1e-9)
    assert np.all(to_camera(T, board.sheet_corners(0.5))[2] > 0)


@pytest.mark.parametrize("seed", range(5))
def test_a_random_pose_puts_the_board_centre_at_a_depth_in_distance(seed):
    board = Board()
    T = random_pose(K, board=board, size=SIZE, rng=seed, distance=(0.9, 1.1))
    centre = board.world_points().mean(axis=1)  # the junctions' centre: the board's
    # (0.9, 1.1) m as given: a pinhole camera's depth (z in the camera frame).
    assert 0.9 - 1e-9 <= to_camera(T, centre[:, None])[2, 0] <= 1.1 + 1e-9


def test_a_random_pose_is_the_seeds_own():
    np.testing.assert_array_equal(random_pose(K, size=SIZE, rng=3), random_pose(K, size=SIZE, rng=3))
    assert not np.array_equal(random_pose(K, size=SIZE, rng=3), random_pose(K, size=SIZE, rng=4))


def test_a_random_pose_through_a_fisheye_keeps_the_curved_sheet_in_the_image():
    camera = FisheyeCamera(K, [0.03, -0.01, 0.002, -0.0005], SIZE)
    board = Board()
    T = random_pose(camera, board=board, rng=2, border_px=8.0, distance=(0.9, 1.1))
    # The sheet's outline at the 32 points per edge the docstring names, through the lens.
    c = board.sheet_corners(0.5)
    step = np.roll(c, -1, axis=1) - c
    outline = (c[:, :, None] + step[:, :, None] * (np.arange(32) / 32)).reshape(3, -1)
    uv = camera.project(to_camera(T, outline))
    assert np.all(np.isfinite(uv))
    assert uv.min() >= 8.0 - 1e-9 and np.all(uv[0] <= SIZE[0] - 1 - 8.0 + 1e-9)
    assert np.all(uv[1] <= SIZE[1] - 1 - 8.0 + 1e-9)
    # Through a lens, distance is measured along the ray: the centre's range from the camera.
    centre = board.world_points().mean(axis=1)
    assert 0.9 - 1e-9 <= np.linalg.norm(to_camera(T, centre[:, None])) <= 1.1 + 1e-9


def test_a_pose_guess_is_turned_and_moved_by_amounts_in_the_ranges_given():
    T = random_pose(K, size=SIZE, rng=0)
    for seed in range(20):
        guess = perturb_pose(T, rng=seed, angle_deg=(8.0, 12.0), offset_m=(0.15, 0.25))
        np.testing.assert_allclose(guess[:3, :3] @ guess[:3, :3].T, np.eye(3), atol=1e-12)
        np.testing.assert_array_equal(guess[3], [0, 0, 0, 1])
        # The ranges are the call's; 1e-9: the rotation angle read back through arccos.
        assert 8.0 - 1e-9 <= _rotation_angle_deg(T[:3, :3].T @ guess[:3, :3]) <= 12.0 + 1e-9
        assert 0.15 - 1e-12 <= np.linalg.norm(guess[:3, 3] - T[:3, 3]) <= 0.25 + 1e-12


def test_a_zero_perturbation_gives_the_pose_back():
    T = random_pose(K, size=SIZE, rng=1)
    np.testing.assert_allclose(perturb_pose(T, rng=0, angle_deg=(0.0, 0.0), offset_m=(0.0, 0.0)), T, atol=1e-15)


@pytest.mark.parametrize("kwargs, name", [
    ({"angle_deg": (12.0, 8.0)}, "angle_deg"),
    ({"angle_deg": (-1.0, 2.0)}, "angle_deg"),
    ({"offset_m": (0.1, np.nan)}, "offset_m"),
])
def test_a_bad_perturbation_range_is_refused_by_name(kwargs, name):
    with pytest.raises(InputError, match=name):
        perturb_pose(np.eye(4), rng=0, **kwargs)


def test_a_perturbed_pose_must_be_rigid():
    with pytest.raises(InputError):
        perturb_pose(np.diag([2.0, 1.0, 1.0, 1.0]), rng=0)


def test_a_loose_polygon_is_the_outline_moved_by_at_most_the_offset():
    board = Board()
    R = render(PinholeCamera(K, SIZE), random_pose(K, board=board, size=SIZE, rng=5), board=board, size=SIZE,
               noise_sigma=0.0, rng=0)
    polygon = loose_polygon(R, rng=1, offset_px=(-4.0, 4.0))
    assert polygon.shape == (2, 4)
    assert np.abs(polygon - R.outline).max() <= 4.0  # offset_px as given
    assert not np.array_equal(polygon, R.outline)
    np.testing.assert_array_equal(loose_polygon(R, rng=1, offset_px=(0.0, 0.0)), R.outline)


def test_an_inset_polygon_lies_inside_the_sheets_outline():
    board = Board()
    R = render(PinholeCamera(K, SIZE), random_pose(K, board=board, size=SIZE, rng=6), board=board, size=SIZE,
               noise_sigma=0.0, rng=0)
    inset = loose_polygon(R, rng=2, offset_px=(0.0, 0.0), inset=True)
    # The inset vertices are sheet corners at 25-75 % of the margin: between the squares'
    # corners (margin 0) and the sheet's (the outline).
    squares = project(K, R.T_WC, board.sheet_corners(0.0))
    for v, outer, inner in zip(inset.T, R.outline.T, squares.T):
        assert np.linalg.norm(v - inner) < np.linalg.norm(outer - inner)
        assert np.linalg.norm(v - outer) < np.linalg.norm(outer - inner)


def test_a_bad_offset_range_is_refused_by_name():
    board = Board()
    R = render(PinholeCamera(K, SIZE), random_pose(K, board=board, size=SIZE, rng=5), board=board, size=SIZE,
               noise_sigma=0.0, rng=0)
    with pytest.raises(InputError, match="offset_px"):
        loose_polygon(R, rng=0, offset_px=(4.0, -4.0))


@pytest.mark.parametrize("ray", [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.3, -0.2, 0.9], [1.0, 0.0, 0.0],
                                 [0.1, 0.2, -0.97]])
def test_turning_the_optical_axis_onto_a_ray(ray):
    ray = np.asarray(ray) / np.linalg.norm(ray)
    R = _turn_towards(ray)
    np.testing.assert_allclose(R @ [0.0, 0.0, 1.0], ray, atol=1e-12)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)

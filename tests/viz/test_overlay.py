"""The overlay picture: each mark where the pose and the junctions put it, in its colour."""

from types import SimpleNamespace

import numpy as np
import pytest

from graphpose import (
    Board,
    InputError,
    RadTanCamera,
    T_from_params,
    params_from_T,
    project,
)
from graphpose.geometry import to_camera
from graphpose.viz.overlay import COLOURS, draw_overlay

K = np.array([[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]])
BOARD = Board(4, 3, 0.05)
# Camera 0.8 m in front of the board, looking straight at it, the board's centre near the middle.
T_WC = T_from_params([0.075, 0.05, -0.8, 0.0, 0.0, 0.0])


def _estimate(trusted):
    points = project(K, T_WC, BOARD.world_points())
    junctions = SimpleNamespace(points=points, trusted=np.asarray(trusted, bool))
    return SimpleNamespace(T_WC=T_WC, params=params_from_T(T_WC), junctions=junctions, mask=junctions.trusted,
                           rms_px=0.25, converged=True, cross_check=SimpleNamespace(agree=True))


def _close(pixel, colour, tol=40):
    return np.all(np.abs(pixel.astype(int) - colour) <= tol)


@pytest.fixture
def picture():
    image = np.full((480, 640), 0.5)
    trusted = np.ones(BOARD.n, bool)
    trusted[5] = False
    estimate = _estimate(trusted)
    before = image.copy()
    out = draw_overlay(image, estimate, K, BOARD, label="synthetic.png")
    np.testing.assert_array_equal(image, before)  # pure: the input is untouched
    return out, estimate.junctions.points


def test_shape_and_type(picture):
    out, _ = picture
    assert out.shape == (480, 640, 3) and out.dtype == np.uint8


def test_trusted_ring_untrusted_cross_and_reprojection(picture):
    out, points = picture
    u, v = np.round(points[:, 6]).astype(int)  # trusted: ring of radius 6, plus at the centre
    assert _close(out[v, u + 6], COLOURS["trusted"])
    assert _close(out[v, u], COLOURS["reprojected"])
    u, v = np.round(points[:, 5]).astype(int)  # untrusted: a red cross over the plus
    assert _close(out[v + 3, u + 3], COLOURS["untrusted"])


def test_axes_from_the_origin(picture):
    out, _ = picture
    o, x, y = project(K, T_WC, np.array([[0, 0.1, 0], [0, 0, 0.1], [0, 0, 0]])).T
    mid_x = np.round((o + x) / 2).astype(int)
    mid_y = np.round((o + y) / 2).astype(int)
    assert _close(out[mid_x[1], mid_x[0]], COLOURS["x"])
    assert _close(out[mid_y[1], mid_y[0]], COLOURS["y"])
    # z points into the board, straight away from this camera: its arrow is a dot on the origin.
    ou, ov = np.round(o).astype(int)
    assert _close(out[ov, ou], COLOURS["z"], tol=60)


def test_text_box_in_a_free_corner(picture):
    out, _ = picture
    grey = int(round(40 + 170 * 0.5))
    corner = out[:8, :8].astype(int)
    assert np.all(corner < grey - 30)  # darkened box
    box = out[:150, :400]
    white = np.all(box > 240, axis=2)
    assert white.sum() > 500  # the text is there
    assert np.all(np.abs(out[-1, -1].astype(int) - grey) <= 1)  # the opposite corner is untouched


def test_text_box_moves_away_from_the_board():
    # The board in the upper-left corner pushes the text to another corner.
    T = T_from_params([0.5, 0.36, -0.8, 0.0, 0.0, 0.0])
    estimate = _estimate(np.ones(BOARD.n, bool))
    estimate.T_WC = T
    estimate.junctions.points = project(K, T, BOARD.world_points())
    assert np.all(estimate.junctions.points < 200)
    out = draw_overlay(np.full((480, 640), 0.5), estimate, K, BOARD)
    grey = int(round(40 + 170 * 0.5))
    assert np.all(np.abs(out[2, 2].astype(int) - grey) <= 1)
    assert np.all(out[2, -3] < grey - 30)


def test_not_converged_and_bounds_and_missing_points():
    estimate = _estimate(np.zeros(BOARD.n, bool))
    estimate.converged = False
    estimate.junctions.points = estimate.junctions.points.copy()
    estimate.junctions.points[:, 0] = np.nan  # a junction never measured is skipped, not drawn
    bounds = np.array([[100.0, 540.0, 540.0, 100.0], [100.0, 100.0, 380.0, 380.0]])
    out = draw_overlay(np.zeros((480, 640, 3), np.uint8), estimate, K, BOARD, bounds=bounds)
    assert _close(out[240, 540], COLOURS["bounds"], tol=60)
    red = np.all(np.abs(out[:150, :400].astype(int) - COLOURS["bad"]) <= 40, axis=2)
    assert red.sum() > 50  # "NOT converged" in red


def test_cross_check_failure_is_written_in_red():
    estimate = _estimate(np.ones(BOARD.n, bool))
    estimate.cross_check.agree = False
    out = draw_overlay(np.full((480, 640), 0.5), estimate, K, BOARD)
    red = np.all(np.abs(out[:150, :400].astype(int) - COLOURS["bad"]) <= 40, axis=2)
    good = np.all(np.abs(out[:150, :400].astype(int) - COLOURS["good"]) <= 40, axis=2)
    assert red.sum() > 50 and good.sum() == 0


def test_camera_behind_the_board_draws_no_projection():
    estimate = _estimate(np.ones(BOARD.n, bool))
    estimate.T_WC = T_from_params([0.075, 0.05, 0.8, 0.0, 0.0, 0.0])  # behind: nothing projects
    estimate.params = params_from_T(estimate.T_WC)
    estimate.junctions.points = np.full((2, BOARD.n), np.nan)
    out = draw_overlay(np.full((480, 640), 0.5), estimate, K, BOARD)
    centre = out[200:280, 280:360]
    assert np.all(centre == centre[0, 0])


def test_estimate_without_junctions_marks_only_the_reprojection(picture):
    # estimate_pose_from_points gives no junctions: the pose and its reprojection are drawn.
    estimate = _estimate(np.ones(BOARD.n, bool))
    estimate.junctions = None
    out = draw_overlay(np.full((480, 640), 0.5), estimate, K, BOARD)
    with_rings, points = picture
    u, v = np.round(points[:, 6]).astype(int)
    assert _close(out[v, u], COLOURS["reprojected"])
    assert not _close(out[v, u + 6], COLOURS["trusted"]) and _close(with_rings[v, u + 6], COLOURS["trusted"])


def test_bad_inputs():
    estimate = _estimate(np.ones(BOARD.n, bool))
    with pytest.raises(InputError, match="K"):
        draw_overlay(np.zeros((10, 10)), estimate, np.eye(2), BOARD)
    with pytest.raises(InputError, match="shape"):
        draw_overlay(np.zeros((10, 10, 2)), estimate, K, BOARD)
    with pytest.raises(InputError, match=r"bounds must have shape \(2, m\) with m >= 3 vertices"):
        draw_overlay(np.zeros((10, 10)), estimate, K, BOARD, bounds=np.zeros((4, 2)))
    with pytest.raises(InputError, match=r"bounds must have shape \(2, m\) with m >= 3 vertices .* got \(2, 2\)"):
        draw_overlay(np.zeros((10, 10)), estimate, K, BOARD, bounds=np.zeros((2, 2)))


def test_the_grid_is_drawn_through_the_lens():
    # A strong barrel lens bends the board's rows: the drawn line follows the camera's curve,
    # not the straight chord between the junctions.
    camera = RadTanCamera(K, [-0.5, 0.3, 0.0, 0.0], size=(640, 480))
    board = Board(3, 3, 0.15)  # large squares, close: the top row runs through strong distortion
    T = T_from_params([0.15, 0.15, -0.4, 0.0, 0.0, 0.0])
    estimate = _estimate(np.ones(BOARD.n, bool))
    estimate.T_WC, estimate.params, estimate.mask = T, params_from_T(T), np.ones(board.n, bool)
    estimate.junctions = None
    out = draw_overlay(np.full((480, 640), 0.5), estimate, camera, board)
    mid = np.array([[0.075], [0.0], [0.0]])  # halfway between junctions 0 and 1, on the top row
    on_curve = camera.project(to_camera(T, mid))[:, 0]
    ends = camera.project(to_camera(T, board.world_points()[:, :2]))
    chord = ends.mean(axis=1)
    assert np.hypot(*(on_curve - chord)) > 4.0  # the curve and the chord are apart
    magenta = np.abs(out.astype(int) - COLOURS["reprojected"]).sum(axis=2) < np.abs(
        out.astype(int) - round(40 + 170 * 0.5)).sum(axis=2)
    u, v = np.round(on_curve).astype(int)
    assert magenta[v - 1:v + 2, u - 1:u + 2].any()
    u, v = np.round(chord).astype(int)
    assert not magenta[v - 1:v + 2, u - 1:u + 2].any()


def test_image_of_another_size_than_the_calibration_is_refused():
    camera = RadTanCamera(K, [-0.2, 0.1, 0.0, 0.0], size=(640, 480))
    with pytest.raises(InputError, match="calibrated for 640 x 480"):
        draw_overlay(np.zeros((240, 320)), _estimate(np.ones(BOARD.n, bool)), camera, BOARD)


def test_orientation_ambiguity_is_written():
    estimate = _estimate(np.ones(BOARD.n, bool))
    plain = draw_overlay(np.full((480, 640), 0.5), estimate, K, BOARD)
    estimate.orientation_ambiguous = True
    flagged = draw_overlay(np.full((480, 640), 0.5), estimate, K, BOARD)
    yellow = np.all(np.abs(flagged[:200, :400].astype(int) - COLOURS["bounds"]) <= 40, axis=2)
    assert yellow.sum() > 50 and not np.all(np.abs(plain[:200, :400].astype(int) - COLOURS["bounds"]) <= 40,
                                            axis=2).any()

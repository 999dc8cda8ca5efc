"""Tests of graphpose.detect.junctions: real images, synthetic truth, trust, refinement, errors."""

import numpy as np
import pytest

from graphpose import (
    Board,
    BoardNotFoundError,
    InputError,
    Junctions,
    cross_junctions,
    extract_junctions,
    refine_junctions,
)
from graphpose.geometry import project
from graphpose.course import pose_estimate_nls
from graphpose.synth.poses import loose_polygon, random_pose
from graphpose.synth.render import render
from tests.conftest import PROJECT_K as K

#: OpenCV findChessboardCornersSB (CALIB_CB_ACCURACY) reprojection RMS on targets 01-06, px.
#: Copied from issue 2, which set them as the goal (our junctions must fit a pinhole pose at
#: least as well); not measured by this test. benchmarks/junctions.py measures OpenCV
#: itself, side by side, in each run.
OPENCV_SB_RMS = [0.072, 0.128, 0.103, 0.191, 0.156, 0.063]


def pose_rms(K, guess, points, board=Board()):
    """RMS distance, px, between the junctions and the reprojection of the fitted pose."""
    W = board.world_points()
    T = pose_estimate_nls(K, guess, points, W)
    return np.sqrt(np.mean(np.sum((project(K, T, W) - points) ** 2, axis=0)))


@pytest.fixture(scope="module")
def real_junctions(real_images):
    return [(case, image, extract_junctions(image, bounds=case.bounds)) for case, image in real_images]


def synthetic(seed, noise=2.0, blur=1.0, inset=False, **kw):
    rng = np.random.default_rng(seed)
    R = render(K, random_pose(K, rng=rng), noise_sigma=noise, blur_sigma=blur, rng=rng, **kw)
    return R, loose_polygon(R, inset=inset, rng=rng)


# ----------------------------------------------------------------------------- real images


def test_real_images_give_48_trusted_junctions_in_row_major_order(real_junctions):
    board = Board()
    for case, _, J in real_junctions:
        assert isinstance(J, Junctions)
        assert J.points.shape == (2, 48) and J.trusted.shape == (48,) and J.residual.shape == (48,)
        assert J.trusted.all(), case.image.name
        grid = J.points.reshape(2, board.rows, board.cols)
        # Row-major: the first junction is the one nearest the polygon's first vertex, rows
        # run from it towards the second vertex and columns towards the fourth.
        assert np.argmin(np.hypot(*(J.points - case.bounds[:, :1]))) == 0
        along_row = np.diff(grid, axis=2).reshape(2, -1)
        along_col = np.diff(grid, axis=1).reshape(2, -1)
        first_edge = case.bounds[:, 1] - case.bounds[:, 0]
        last_edge = case.bounds[:, 3] - case.bounds[:, 0]
        assert np.all(first_edge @ along_row > 0) and np.all(last_edge @ along_col > 0)
        # Neighbours are about one square apart, never two.
        steps = np.hypot(*along_row)
        assert steps.max() < 1.5 * np.median(steps)


def test_real_images_match_reference_junctions_within_1_px(real_junctions):
    checked = 0
    for case, _, J in real_junctions:
        if case.ref_junctions is not None:
            mean_px = np.mean(np.hypot(*(J.points - case.ref_junctions)))
            assert mean_px < 1.0  # the goal from the issue
            assert mean_px < 0.5  # regression guard (an earlier run): 0.22 and 0.30 px
            checked += 1
    assert checked == 2


def test_real_images_fit_a_pose_at_least_as_well_as_opencv(real_cases, real_junctions):
    for (case, _, J), limit in zip(real_junctions, OPENCV_SB_RMS):
        assert pose_rms(real_cases.K, case.guess_T_WC, J.points) <= limit, case.image.name


def test_colour_16_bit_and_8_bit_images_agree(real_images):
    case, image = real_images[0]
    grey8 = np.rint(image * 255).astype(np.uint8)
    reference = extract_junctions(grey8, bounds=case.bounds).points
    colour = np.repeat(grey8[:, :, None], 3, axis=2)
    deep = grey8.astype(np.uint16) * 257
    for variant in (colour, deep, grey8.astype(float) / 255.0):
        np.testing.assert_allclose(extract_junctions(variant, bounds=case.bounds).points, reference, atol=1e-6)


# ------------------------------------------------------------------------------ synthetic


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("noise, blur, limit", [(2.0, 1.0, 0.03), (6.0, 2.0, 0.07)])
def test_synthetic_rms_error_against_truth(noise, blur, limit):
    errors = []
    for seed in range(6):
        R, poly = synthetic(100 + seed, noise, blur, inset=bool(seed % 2))
        J = extract_junctions(R.image, bounds=poly)
        assert J.trusted.all()
        errors.append(np.sum((J.points - R.junctions) ** 2, axis=0))
    assert np.sqrt(np.mean(np.concatenate(errors))) < limit


def test_noise_free_synthetic_image_is_exact():
    R, poly = synthetic(7, noise=0.0, blur=1.0, quantize=False)
    J = extract_junctions(R.image, bounds=poly)
    assert np.max(np.hypot(*(J.points - R.junctions))) < 0.01


def test_polygon_inside_the_margin_or_outside_the_sheet_gives_the_same_junctions():
    rng = np.random.default_rng(11)
    R = render(K, random_pose(K, rng=rng), rng=rng)
    inset = extract_junctions(R.image, bounds=loose_polygon(R, inset=True, rng=rng)).points
    outside = extract_junctions(R.image, bounds=loose_polygon(R, offset_px=(2.0, 5.0), rng=rng) + [[-3.0], [0.0]]).points
    np.testing.assert_allclose(inset, outside, atol=0.01)  # the re-centring stops within 0.02 px steps


def test_larger_board_and_other_grid():
    board = Board(5, 4, 0.08)
    rng = np.random.default_rng(12)
    R = render(K, random_pose(K, board, rng=rng), board, rng=rng)
    J = extract_junctions(R.image, bounds=loose_polygon(R, rng=rng), board=board)
    assert J.points.shape == (2, 20) and J.trusted.all()
    assert np.sqrt(np.mean(np.sum((J.points - R.junctions) ** 2, axis=0))) < 0.03
    np.testing.assert_allclose(cross_junctions(R.image, loose_polygon(R, rng=rng), board.world_points()),
                               R.junctions, atol=0.1)


@pytest.mark.parametrize("half", [6, 10])
def test_occluded_junction_is_not_trusted(half):
    # A grey sticker over the inner part of junction 20 (squares ~39 px): the smaller one
    # leaves the fit a worse residual, the larger one leaves no saddle at all.
    R, poly = synthetic(13)
    image = R.image.copy()
    u, v = np.rint(R.junctions[:, 20]).astype(int)
    image[v - half:v + half + 1, u - half:u + half + 1] = 128
    J = extract_junctions(image, bounds=poly)
    assert not J.trusted[20]
    assert J.trusted.sum() == 47
    # Either seen and refined as well as the sticker allows, or not seen at all (NaN).
    assert np.isnan(J.points[:, 20]).all() or np.hypot(*(J.points[:, 20] - R.junctions[:, 20])) < 0.5
    assert np.isnan(J.points[:, 20]).all() == (not J.seen[20])


# ---------------------------------------------------------------------------- refinement


def test_refine_junctions_recovers_perturbed_positions():
    R, _ = synthetic(21)
    rng = np.random.default_rng(22)
    start = R.junctions + rng.uniform(-1.5, 1.5, R.junctions.shape)
    points, trusted, residual = refine_junctions(R.image, start, 10.0)
    assert points.shape == (2, 48) and trusted.shape == (48,) and residual.shape == (48,)
    assert trusted.all() and np.all(np.isfinite(residual))
    assert np.sqrt(np.mean(np.sum((points - R.junctions) ** 2, axis=0))) < 0.03


def test_refine_junctions_away_from_any_junction_is_not_trusted():
    R, _ = synthetic(23)
    flat = np.array([[5.0, 630.0], [5.0, 470.0]])  # image corners: background, no junction
    _, trusted, _ = refine_junctions(R.image, flat, np.array([6.0, 6.0]))
    assert not trusted.any()


# --------------------------------------------------------------------------------- errors


@pytest.fixture(scope="module")
def small_case():
    return synthetic(31)


@pytest.mark.parametrize(
    "poly, message",
    [
        (np.zeros((4, 2)), r"shape \(2, 4\)"),
        (np.zeros((2, 3)), r"shape \(2, 4\)"),
        (np.array([[np.nan, 1, 2, 3], [0, 1, 2, 3]]), "NaN"),
        (np.array([[900.0, 1200, 1200, 900], [100, 100, 300, 300]]), "off the"),
        (np.array([[100.0, 100, 300, 300], [100, 300, 300, 100]]), "clockwise"),
        (np.array([[100.0, 300, 100, 300], [100, 100, 300, 300]]), "convex|clockwise|degenerate"),
        (np.array([[100.0, 101, 101, 100], [100, 100, 101, 101]]), "degenerate"),
        ([[100, 300, 300], [100, 100, 300, 300]], "bounds must be a rectangular array of real numbers"),
    ],
)
def test_bad_polygon_raises_input_error(small_case, poly, message):
    R, _ = small_case
    with pytest.raises(InputError, match=message):
        extract_junctions(R.image, bounds=poly)


@pytest.mark.parametrize(
    "image, message",
    [(np.zeros((0, 0)), "empty"), (np.zeros((4, 4, 4, 4)), "2-D"), (np.full((480, 640), np.nan), "NaN"),
     (np.zeros((1, 4000)), r"at least 5 x 5 pixels, got shape \(1, 4000\)"),
     (np.zeros((4000, 4), np.uint8), r"at least 5 x 5 pixels")],
)
def test_bad_image_raises_input_error(small_case, image, message):
    _, poly = small_case
    with pytest.raises(InputError, match=message):
        extract_junctions(image, bounds=poly)


@pytest.mark.parametrize("kind", ["blank", "noise"])
def test_image_without_a_board_raises_board_not_found(small_case, kind):
    R, poly = small_case
    rng = np.random.default_rng(5)
    image = np.full(R.image.shape, 0.5) if kind == "blank" else rng.uniform(0, 1, R.image.shape)
    with pytest.raises(BoardNotFoundError):
        extract_junctions(image, bounds=poly)


def test_polygon_starting_on_a_column_is_refused_not_turned(small_case):
    # Starting at the second vertex would name another corner junction 0 (and put the
    # board's 6-junction columns along the first edge): refused, never a turned pose.
    R, poly = small_case
    with pytest.raises(BoardNotFoundError, match="the bounds do not outline the board found"):
        extract_junctions(R.image, bounds=np.roll(poly, -1, axis=1))


def test_polygon_around_part_of_the_board_still_labels_the_board_from_its_edges(small_case):
    # The bounds only narrow the search and name junction 0's corner: the labels come from
    # the board's own edges, so bounds round its left half find the whole board.
    R, _ = small_case
    J = R.junctions.reshape(2, 6, 8)
    corners = np.stack([J[:, 0, 0], J[:, 0, 4], J[:, 5, 4], J[:, 5, 0]], axis=1)
    part = corners + [[-5, 5, 5, -5], [-5, -5, 5, 5]]
    found = extract_junctions(R.image, bounds=part)
    assert found.trusted.all() and not found.orientation_ambiguous
    np.testing.assert_allclose(found.points, R.junctions, atol=0.1)


def test_polygon_over_a_corner_of_the_board_says_it_holds_no_board():
    # The README's example: a 100 px square over the lower corner of the bundled
    # synthetic_03.png. It once said "found a 5 x 4 grid of junctions", of a polygon that
    # holds one junction (a corner one, which has too few neighbours to start a grid).
    from graphpose import bundled_cases, read_image

    case = bundled_cases().cases[2]
    bounds = np.array([[300.0, 400, 400, 300], [300, 300, 400, 400]])
    # Nothing inside them at the fast path's levels; a coarser level (searched where nothing is
    # found) sees the board, which the bounds do not outline: still a refusal, now saying so.
    with pytest.raises(BoardNotFoundError, match="the bounds do not outline the board found"):
        extract_junctions(read_image(case.image), bounds=bounds)


def test_bounds_round_one_corner_of_the_board_do_not_outline_it(small_case):
    # Bounds drawn round the board's first square-and-a-half: the board grows from seeds
    # inside them, but their vertices do not run round its corners: refused.
    R, _ = small_case
    J = R.junctions.reshape(2, 6, 8)
    corners = np.stack([J[:, 0, 0], J[:, 0, 2], J[:, 2, 2], J[:, 2, 0]], axis=1)
    with pytest.raises(BoardNotFoundError, match="the bounds do not outline the board found"):
        extract_junctions(R.image, bounds=corners + [[-5, 5, 5, -5], [-5, -5, 5, 5]])


def test_bounds_away_from_the_board_hold_no_board(small_case):
    R, _ = small_case
    empty = np.array([[5.0, 60, 60, 5], [5, 5, 60, 60]])
    with pytest.raises(BoardNotFoundError, match="no checkerboard inside the bounds"):
        extract_junctions(R.image, bounds=empty)


@pytest.mark.parametrize("true, spec", [((7, 5), (8, 6)), ((8, 6), (8, 8)), ((8, 6), (7, 5)), ((8, 6), (9, 6))])
def test_board_spec_that_does_not_match_the_board_says_what_was_found(true, spec):
    # With or without bounds: once "only 48 of 48 grid junctions found", or a sub-window of
    # the board fitted to a smaller spec.
    rng = np.random.default_rng(1)
    board = Board(*true, 0.0635)
    R = render(K, random_pose(K, board, rng=rng), board, rng=rng)
    message = r"found a \d x \d board of junctions; the board spec says " + f"{spec[0]} x {spec[1]}"
    for bounds in (loose_polygon(R, rng=rng), None):
        with pytest.raises(BoardNotFoundError, match=message):
            extract_junctions(R.image, bounds=bounds, board=Board(*spec, 0.0635))


def test_bad_options_raise_input_error(small_case):
    R, poly = small_case
    with pytest.raises(InputError, match="window"):
        extract_junctions(R.image, bounds=poly, window=0.9)
    with pytest.raises(InputError, match="smooth_sigma"):
        extract_junctions(R.image, bounds=poly, smooth_sigma=-1.0)
    with pytest.raises(InputError, match="half_width"):
        refine_junctions(R.image, R.junctions, 1.0)
    with pytest.raises(InputError, match="half_width"):
        refine_junctions(R.image, R.junctions, np.ones(3) * 5)
    with pytest.raises(InputError, match="points"):
        refine_junctions(R.image, R.junctions.T, 5.0)
    with pytest.raises(InputError, match="NaN"):
        refine_junctions(R.image, np.full((2, 3), np.nan), 5.0)
    with pytest.raises(InputError, match="half_width must be a rectangular array of real numbers"):
        refine_junctions(R.image, R.junctions, "wide")


def test_a_partly_covered_raw_image_keeps_its_labels_through_the_lens():
    # OpenCV's raw sample with its distortion, a round grey patch (a hand, say) over its
    # right-hand columns. The rest keep their labels and positions; the covered junctions
    # are NaN (they once made the lens's undistortion raise on NaN). A straight-edged
    # cover along a column would look like the board's edge and be refused instead.
    from skimage.draw import disk

    from graphpose.image import read_image
    from graphpose.io.cameras import read_camera
    from tests.conftest import OPENCV_DIR as folder
    from tests.conftest import opencv_file

    opencv_file("left01.jpg")  # skips (or, with GRAPHPOSE_REQUIRE_REAL=1, fails) when absent
    camera = read_camera(folder / "left.opencv.yml")
    board = Board(9, 6, 0.03)
    image = read_image(folder / "left01.jpg", as_float=True)  # float: the cover below is a grey level in [0, 1]
    whole = extract_junctions(image, bounds=None, board=board, camera=camera)
    assert whole.trusted.all() and not whole.orientation_ambiguous
    grid = whole.points.reshape(2, 6, 9)
    step = np.hypot(*(grid[:, 2, 8] - grid[:, 2, 7]))
    centre = grid[:, 2:4, 8].mean(axis=1)
    covered = image.copy()
    covered[disk((centre[1], centre[0]), 2.2 * step, shape=image.shape)] = 0.45
    part = extract_junctions(covered, bounds=None, board=board, camera=camera)
    distance = np.hypot(*(whole.points - centre[:, None])) / step
    hidden, touched = distance < 1.8, distance < 3.0  # under the patch; near its rim
    assert 0 < hidden.sum() < touched.sum() < board.n // 2
    assert not part.seen[hidden].any() and np.isnan(part.points[:, hidden]).all()
    assert part.trusted[~touched].all()
    np.testing.assert_allclose(part.points[:, ~touched], whole.points[:, ~touched], atol=0.05)


@pytest.mark.parametrize("kind, limit", [("radtan", 0.0055), ("fisheye", 0.007)])
def test_junctions_through_a_strong_lens_are_fitted_where_the_lens_straightens_the_edges(kind, limit):
    # Noise-free raw renders: the saddle fitted in each patch's own frame, where the lens
    # straightens the edges, gives 0.0045 px RMS (radial-tangential; 0.004 on a pinhole
    # image) and 0.0046 px (fisheye, 190 degrees; 0.0073 in the camera's distortion-free
    # image, which stretches the rim); fitted on the raw pixel grid, the curved edges biased
    # it to 0.0071 and 0.021 px, the same way at neighbouring junctions, and so the pose's
    # NEES to 35-134.
    from graphpose import K_from_params
    from graphpose.camera_models import FisheyeCamera, RadTanCamera
    from graphpose.synth.poses import random_pose

    if kind == "radtan":
        camera = RadTanCamera(K_from_params(400.0, 400.0, 322.5, 238.3), [-0.3, 0.1, 0.001, -0.0005, 0.0],
                              size=(640, 480))
        distance = (0.75, 1.1)
    else:
        camera = FisheyeCamera(K_from_params(203.0, 203.0, 321.0, 241.0), [-0.013, -0.004, 0.0035, -0.001],
                               size=(640, 480))
        distance = (0.45, 0.7)
    board = Board()
    rng = np.random.default_rng(5)
    errors = []
    for _ in range(3):
        R = render(camera, random_pose(camera, board, distance=distance, rng=rng), board, noise_sigma=0.0, rng=rng)
        J = extract_junctions(R.image, bounds=R.outline, board=board, camera=camera)
        assert J.trusted.sum() >= 44
        errors.append(np.hypot(*(J.points - R.junctions))[J.trusted])
    errors = np.concatenate(errors)
    assert np.sqrt(np.mean(errors ** 2)) < limit and errors.max() < 0.05


def test_refine_junctions_takes_the_camera_as_extract_junctions_does():
    # The tracker refines predicted positions with refine_junctions: through a fisheye its
    # camera makes the fit as exact as extract_junctions' (noise-free render).
    from graphpose import K_from_params
    from graphpose.camera_models import FisheyeCamera
    from graphpose.synth.poses import random_pose

    camera = FisheyeCamera(K_from_params(203.0, 203.0, 321.0, 241.0), [-0.013, -0.004, 0.0035, -0.001],
                           size=(640, 480))
    rng = np.random.default_rng(6)
    board = Board()
    R = render(camera, random_pose(camera, board, distance=(0.45, 0.7), rng=rng), board, noise_sigma=0.0, rng=rng)
    start = R.junctions + rng.uniform(-1.0, 1.0, R.junctions.shape)
    half = 0.5 * extract_junctions(R.image, bounds=R.outline, board=board, camera=camera).square_px
    errors = {}
    for name, cam in (("lens", camera), ("raw grid", None)):
        points, trusted, _ = refine_junctions(R.image, start, np.clip(half, 2, 12), camera=cam)
        errors[name] = np.sqrt(np.mean(np.hypot(*(points - R.junctions))[trusted] ** 2))
    assert errors["lens"] < 0.011 < errors["raw grid"], errors


# ------------------------------------------------- the two stages: find_board, then refine


def assert_same_junctions(A, B):
    """Two Junctions equal to the bit (NaN where NaN), every field."""
    for name in ("points", "trusted", "residual", "square_px", "homography", "seen"):
        np.testing.assert_array_equal(getattr(A, name), getattr(B, name), err_msg=name)
    assert (A.orientation_ambiguous, A.junction0_square) == (B.orientation_ambiguous, B.junction0_square)


def fisheye_render(seed):
    """(camera, board, rendering): a raw render through a strong fisheye (190 degrees), noise 1."""
    from graphpose import K_from_params
    from graphpose.camera_models import FisheyeCamera

    camera = FisheyeCamera(K_from_params(203.0, 203.0, 321.0, 241.0), [-0.013, -0.004, 0.0035, -0.001],
                           size=(640, 480))
    board = Board()
    rng = np.random.default_rng(seed)
    R = render(camera, random_pose(camera, board, distance=(0.45, 0.7), rng=rng), board, noise_sigma=1.0, rng=rng)
    return camera, board, R


def test_find_board_then_refine_is_extract_junctions_on_real_images(real_images):
    from graphpose.detect import find_board, refine
    from graphpose.image import read_image

    for case, image in real_images[:3]:
        for bounds in (case.bounds, None):
            found = find_board(image, Board(), bounds=bounds)
            assert_same_junctions(refine(image, found), extract_junctions(image, bounds=bounds))
    # 8-bit, as the command line reads it (its residuals in [0, 1] grey units too).
    case = real_images[0][0]
    image = read_image(case.image, as_float=False)
    assert_same_junctions(refine(image, find_board(image, Board(), bounds=case.bounds)),
                          extract_junctions(image, bounds=case.bounds))


def test_find_board_then_refine_is_extract_junctions_on_rendered_images():
    from graphpose.detect import find_board, refine

    for seed, noise in ((41, 2.0), (42, 12.0)):  # clean, and noisy (the smoothing from the noise)
        R, poly = synthetic(seed, noise=noise)
        for bounds in (poly, None):
            assert_same_junctions(refine(R.image, find_board(R.image, Board(), bounds=bounds)),
                                  extract_junctions(R.image, bounds=bounds))
    R, poly = synthetic(43)
    found = find_board(R.image, Board(), bounds=poly)
    assert_same_junctions(refine(R.image, found, window=0.4, smooth_sigma=1.0),
                          extract_junctions(R.image, bounds=poly, window=0.4, smooth_sigma=1.0))


def test_refine_with_a_camera_is_the_lens_path():
    # A raw render through a strong fisheye: the board found once, with no camera, and refined
    # through the camera equals extract_junctions through it; without the lens it is no grid.
    from graphpose.detect import find_board, refine

    camera, board, R = fisheye_render(7)
    found = find_board(R.image, board, bounds=R.outline)
    lens = refine(R.image, found, camera=camera)
    assert_same_junctions(lens, extract_junctions(R.image, bounds=R.outline, board=board, camera=camera))
    assert lens.trusted.sum() >= 44
    # Without the lens (no camera, or only its K) the rim's curved grid is no planar grid.
    for no_lens in (None, np.asarray(camera.K)):
        with pytest.raises(BoardNotFoundError, match="a lens with distortion"):
            refine(R.image, found, camera=no_lens)
    error = np.hypot(*(lens.points - R.junctions))[lens.trusted]
    assert np.sqrt(np.mean(error ** 2)) < 0.05


def test_found_board_labels_need_no_camera():
    # The same raw fisheye render: find_board takes no camera, and its labels are the truth's
    # (each coarse junction within a pixel and a half of the junction of its board index).
    import inspect

    from graphpose.detect import FoundBoard, find_board

    assert "camera" not in inspect.signature(find_board).parameters
    _, board, R = fisheye_render(8)
    found = find_board(R.image, board, bounds=R.outline)
    assert isinstance(found, FoundBoard) and found.board == board and found.noise > 0
    assert found.points.shape == (2, board.n) and found.seen.all()
    np.testing.assert_array_equal(found.labels, np.arange(board.n))
    assert np.hypot(*(found.points - R.junctions)).max() < 1.5


def test_find_board_and_refine_refuse_bad_input(small_case):
    from graphpose.detect import FoundBoard, find_board, refine

    R, poly = small_case
    found = find_board(R.image, Board(), bounds=poly)
    with pytest.raises(InputError, match="board must be a graphpose.Board"):
        find_board(R.image, (8, 6))
    with pytest.raises(InputError, match="clockwise"):
        find_board(R.image, Board(), bounds=poly[:, ::-1])
    with pytest.raises(InputError, match="found must be a FoundBoard"):
        refine(R.image, found.points)
    with pytest.raises(InputError, match="found must name its board"):
        refine(R.image, FoundBoard(found.points, found.seen, found.step_px, False))
    from dataclasses import replace

    with pytest.raises(InputError, match=r"the 63 junctions of its 9 x 7 board"):
        refine(R.image, replace(found, board=Board(9, 7)))
    with pytest.raises(InputError, match="window"):
        refine(R.image, found, window=0.9)
    with pytest.raises(InputError, match="calibrated for 320 x 240"):
        from graphpose.camera_models import RadTanCamera

        refine(R.image, found, camera=RadTanCamera(K, [0.1, 0, 0, 0, 0], size=(320, 240)))


def test_refine_junctions_unchecked_is_the_checked_refinement():
    # The tracker's call (check=False, on frames it checked once) refines as the checked call.
    R, _ = synthetic(44)
    rng = np.random.default_rng(45)
    start = R.junctions + rng.uniform(-1.0, 1.0, R.junctions.shape)
    half = rng.uniform(6.0, 10.0, start.shape[1])
    for image in (R.image, np.round(R.image * 255).astype(np.uint8)):
        checked = refine_junctions(image, start, half, smooth_sigma=0.8)
        unchecked = refine_junctions(image, start, half, smooth_sigma=0.8, check=False)
        for a, b in zip(checked, unchecked):
            np.testing.assert_array_equal(a, b)


def _part_of_a_grid(rng, cols=4, rows=3, noise=0.05):
    """A small part of a board seen through a random homography: grid (2, n), points (2, n)."""
    grid = np.stack(np.meshgrid(np.arange(cols, dtype=float), np.arange(rows, dtype=float))).reshape(2, -1)
    H = np.array([[22.0, 3.0, 300.0], [-4.0, 21.0, 200.0], [1e-3, -2e-3, 1.0]]) + rng.normal(0, [[1, 1, 5], [1, 1, 5], [1e-4, 1e-4, 0]])
    from graphpose.geometry import apply_homography
    return grid, apply_homography(H, grid) + rng.normal(0, noise, (2, grid.shape[1]))


def test_deleted_offsets_are_the_distances_from_the_grid_fitted_without_each_point():
    from graphpose.detect.grid import fit_homography
    from graphpose.detect.junctions import _deleted_offsets
    from graphpose.geometry import apply_homography
    rng = np.random.default_rng(4)
    grid, points = _part_of_a_grid(rng)
    fitted = np.ones(grid.shape[1], dtype=bool)
    fitted[5] = False  # one point outside the fit is judged by its plain residual
    H = fit_homography(grid[:, fitted], points[:, fitted])
    off = _deleted_offsets(H, grid, points, fitted)
    assert off[5] == pytest.approx(np.hypot(*(apply_homography(H, grid[:, 5:6])[:, 0] - points[:, 5])))
    for i in np.flatnonzero(fitted):
        others = fitted.copy()
        others[i] = False
        Hi = fit_homography(grid[:, others], points[:, others])
        loo = np.hypot(*(apply_homography(Hi, grid[:, i:i + 1])[:, 0] - points[:, i]))
        assert off[i] == pytest.approx(loo, rel=0.05, abs=2e-3)  # first order in the noise
    plain = np.hypot(*(apply_homography(H, grid) - points))
    assert np.all(off[fitted] > plain[fitted])  # a point in the fit pulls it towards itself


def test_a_junction_pulled_a_pixel_on_a_small_part_of_a_board_is_not_trusted():
    # On a 4 x 3 part a corner junction pulls the homography towards itself, and its plain
    # residual shows about half its error (under the gate); judged against the grid the others
    # draw, it is caught.
    from graphpose.detect.junctions import _judge
    rng = np.random.default_rng(2)
    grid, points = _part_of_a_grid(rng, noise=0.15)
    points[:, 0] += [0.85, -0.75]  # 1.1 px off
    n = grid.shape[1]
    ok, seen = np.ones(n, dtype=bool), np.ones(n, dtype=bool)
    J = _judge(points, ok, np.full(n, 0.01), np.full(n, 20.0), grid, seen, False)
    assert not J.trusted[0] and J.trusted.sum() == n - 1

"""Tests of the synthetic renderer: exact areas, exact truth, statistics, poses, data files."""

import importlib.util
import json

import numpy as np
import pytest
from scipy.ndimage import correlate1d, maximum_filter, minimum_filter
from skimage.io import imread

from graphpose.board import Board
from graphpose.geometry import K_from_params, T_from_params, project, to_camera
from graphpose.camera_models import FisheyeCamera, PinholeCamera, RadTanCamera
from graphpose.course import saddle_point
from graphpose.errors import InputError
from graphpose.estimate import pose_difference
from graphpose.synth.information import image_gradients, junction_information
from graphpose.synth.lens import in_view, view_limit
from graphpose.synth.poses import loose_polygon, perturb_pose, random_pose
from graphpose.synth.raster import coverage, pixel_kernel, polygon_coverage
from graphpose.synth.render import Rendering, _black_squares_world, _Light, image_points, render, render_ideal
from tests.conftest import PROJECT_K as K_REAL
from tests.conftest import REPO


def shoelace(P):
    x, y = P
    return 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def fronto(u0, v0, f=500.0, square_px=40.0, board=Board()):
    """K and T_WC of a fronto-parallel view putting junction 0 at (u0, v0), squares square_px wide."""
    Z = f * board.square_m / square_px
    return K_from_params(f, f, u0, v0), T_from_params([0.0, 0.0, -Z, 0.0, 0.0, 0.0])


# ------------------------------------------------------------------ exact area


def test_dark_area_equals_projected_black_squares():
    board = Board()
    T = random_pose(K_REAL, board, rng=np.random.default_rng(1))
    levels = dict(background=200.0, white=200.0, black=50.0, gradient=0.0)
    for blur in (0.0, 1.0):  # blur moves grey around but keeps its total
        I = render_ideal(K_REAL, T, board, blur_sigma=blur, supersample=2, **levels)
        dark = np.sum(200.0 - I) / 150.0
        exact = sum(abs(shoelace(project(K_REAL, T, Q))) for Q in _black_squares_world(board))
        assert dark == pytest.approx(exact, rel=1e-6)


def test_blur_free_fronto_parallel_edge_values():
    K, T = fronto(100.3, 80.0)
    I = render_ideal(K, T, blur_sigma=0.0, gradient=0.0, white=200.0, black=40.0, background=60.0)
    # Row 100 runs between junction rows 0 and 1: the square left of u = 100.3 is white
    # (square (0, 1)), the one right of it black; pixel 100 spans [99.5, 100.5].
    assert I[100, 99] == pytest.approx(200.0, abs=1e-9)
    assert I[100, 100] == pytest.approx(0.8 * 200.0 + 0.2 * 40.0, abs=1e-9)
    assert I[100, 101] == pytest.approx(40.0, abs=1e-9)
    # The upper-left square is black, as on the real target.
    assert I[60, 80] == pytest.approx(40.0, abs=1e-9)
    # Sheet edge: the left margin ends at u = 100.3 - 1.5 * 40 = 40.3.
    assert I[100, 40] == pytest.approx(0.8 * 60.0 + 0.2 * 200.0, abs=1e-9)


def _blur_integrate(fine, sigma, S, reach):
    """Blur a dense fine image (h*S, w*S) and integrate it over pixels, giving (h, w): the
    dense twin of the renderer's sparse path."""
    k = pixel_kernel(sigma, S, reach)
    rows = sum(correlate1d(fine[:, b::S], k[:, b], axis=1, mode="constant") for b in range(S))
    return sum(correlate1d(rows[b::S, :], k[:, b], axis=0, mode="constant") for b in range(S))


def test_sparse_blur_equals_dense_fine_grid_reference():
    # The renderer blurs sparse coverage entries and moves the light's v-part past a column
    # sum; here the same image is made the plain way: dense fine grid over the whole image
    # (plus the kernel's reach), times the light, blurred and integrated per pixel.
    board, size, S, sigma = Board(3, 3), (200, 160), 3, 0.8
    K = K_from_params(564.9, 564.3, 100.0, 80.0)
    T = random_pose(K, board, size, distance=(1.3, 1.6), rng=np.random.default_rng(8))
    levels = dict(background=50.0, white=210.0, black=30.0)
    light = _Light(*size, 0.3, np.deg2rad(60.0))
    reach = int(np.ceil(5.0 * sigma)) + 1
    origin = np.array([[-reach - 0.5], [-reach - 0.5]])
    corners = [board.sheet_corners(0.5), *_black_squares_world(board)]
    polys = [(project(K, T, Q) - origin) * S for Q in corners]
    gains = [160.0] + [-180.0] * (len(polys) - 1)
    h, w = (size[1] + 2 * reach) * S, (size[0] + 2 * reach) * S
    u = (np.arange(w) + 0.5) / S - reach - 0.5
    v = (np.arange(h) + 0.5) / S - reach - 0.5
    fine = coverage(polys, h, w, gains) * light(u[None, :], v[:, None])
    blurred = _blur_integrate(fine, sigma, S, reach)[reach:-reach, reach:-reach]
    U, V = np.meshgrid(np.arange(size[0]), np.arange(size[1]))
    expected = 50.0 * light(U, V) + blurred
    settings = dict(blur_sigma=sigma, supersample=S, gradient=0.3, light_angle_deg=60.0)
    I = render_ideal(K, T, board, size, **settings, **levels)
    assert np.abs(I - expected).max() < 1e-9


# ------------------------------------------------------------------ exact truth


@pytest.mark.parametrize("u0, v0", [(120.5, 90.0), (121.0, 90.5)])
def test_noise_free_render_is_point_symmetric_about_each_junction(u0, v0):
    board = Board()
    K, T = fronto(u0, v0, square_px=30.0)
    I = render_ideal(K, T, board, (480, 320), gradient=0.0, blur_sigma=1.0, supersample=3)
    hw = 8
    for u, v in project(K, T, board.world_points()).T:
        a, b = int(round(2 * u)), int(round(2 * v))  # pixel p maps to 2j - p
        rows, cols = np.arange(int(v) - hw, int(v) + hw + 1), np.arange(int(u) - hw, int(u) + hw + 1)
        patch = I[np.ix_(rows, cols)]
        mirror = I[np.ix_(b - rows, a - cols)]
        assert np.abs(patch - mirror).max() < 1e-9
        assert np.ptp(patch) > 100  # the window does see the junction


def test_whole_pixel_shift_of_principal_point_shifts_image():
    K, T = fronto(150.2, 100.7)
    I = render_ideal(K, T, gradient=0.0, blur_sigma=1.3)
    K2 = K.copy()
    K2[0, 2] += 1.0
    K2[1, 2] -= 2.0
    J = render_ideal(K2, T, gradient=0.0, blur_sigma=1.3)
    assert np.allclose(J[:-2, 1:], I[2:, :-1], atol=1e-9)


def test_supersampling_2_4_and_8_agree_on_junction_positions():
    # The junction displacement between two renders is the least-squares translation of the
    # window's pattern: (I_S - I_8) projected on the gradient dI/d(u, v).
    board, size = Board(3, 3), (240, 200)
    K = K_from_params(564.9, 564.3, 120.0, 100.0)
    rng = np.random.default_rng(3)
    hw = 6
    for _ in range(2):
        T = random_pose(K, board, size, distance=(1.1, 1.4), rng=rng)
        ref = render_ideal(K, T, board, size, supersample=8)
        gu, gv = image_gradients(K, T, board, size, supersample=8)
        for S, tol in ((2, 0.002), (4, 0.0005)):
            coarse = render_ideal(K, T, board, size, supersample=S)
            for u, v in np.rint(project(K, T, board.world_points())).astype(int).T:
                window = slice(v - hw, v + hw + 1), slice(u - hw, u + hw + 1)
                G = np.stack([gu[window].ravel(), gv[window].ravel()], axis=1)
                shift = np.linalg.lstsq(G, (coarse - ref)[window].ravel(), rcond=None)[0]
                assert np.hypot(*shift) < tol


# ------------------------------------------------------------------ render, noise


def test_render_fields_and_noise_statistics():
    T = T_from_params([0.2, 0.1, -1.0, 0.1, 0.2, 0.3])
    ideal = render_ideal(K_REAL, T)
    r = render(K_REAL, T, noise_sigma=2.0, rng=np.random.default_rng(7), quantize=False)
    assert isinstance(r, Rendering) and r.image.dtype == np.float64
    residual = r.image - ideal
    assert residual.mean() == pytest.approx(0.0, abs=0.02)
    assert residual.std() == pytest.approx(2.0, rel=0.01)
    q = render(K_REAL, T, noise_sigma=2.0, rng=7)
    assert q.image.dtype == np.uint8 and q.image.shape == (480, 640)
    assert np.array_equal(q.image, np.clip(np.rint(r.image), 0, 255).astype(np.uint8))
    assert np.allclose(q.junctions, project(K_REAL, T, Board().world_points()))
    assert (q.blur_sigma, q.noise_sigma, q.size) == (1.0, 2.0, (640, 480))
    # Outline: clockwise on screen, first vertex nearest junction 0.
    assert shoelace(q.outline) > 0
    assert np.argmin(np.hypot(*(q.outline - q.junctions[:, :1]))) == 0


def test_render_is_deterministic():
    T = T_from_params([0.2, 0.1, -1.0, 0.1, 0.2, 0.3])
    assert np.array_equal(render_ideal(K_REAL, T), render_ideal(K_REAL, T))
    assert np.array_equal(render(K_REAL, T, rng=3).image, render(K_REAL, T, rng=3).image)


def test_board_partly_outside_the_image_renders_the_visible_part():
    K, T = fronto(-100.0, 50.0)  # the left two-thirds of the board is off the image
    I = render_ideal(K, T, gradient=0.0, blur_sigma=0.0, background=60.0, white=200.0, black=40.0)
    full = render_ideal(K_from_params(500.0, 500.0, 300.0, 50.0), T, size=(1040, 480), gradient=0.0,
                        blur_sigma=0.0, background=60.0, white=200.0, black=40.0)
    assert np.allclose(I, full[:, 400:], atol=1e-9)


# ------------------------------------------------------------------ poses and polygons


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_random_pose_keeps_the_sheet_in_view():
    rng = np.random.default_rng(11)
    board = Board()
    for _ in range(30):
        T = random_pose(K_REAL, board, (640, 480), rng=rng)
        r = render(K_REAL, T, board, noise_sigma=0.0, blur_sigma=0.0, gradient=0.0)
        uv = r.outline
        assert np.all((uv >= 8) & (uv <= np.array([[631], [471]])))
        width = np.hypot(*(uv[:, 1] - uv[:, 0]))
        assert 200 < width < 520
        assert T[2, 3] < 0 and shoelace(uv) > 0
        assert np.argmin(np.hypot(*(uv - r.junctions[:, :1]))) == 0


def test_loose_polygon_and_inset():
    T = random_pose(K_REAL, rng=np.random.default_rng(2))
    r = render(K_REAL, T, rng=2)
    loose = loose_polygon(r, rng=np.random.default_rng(5))
    assert loose.shape == (2, 4)
    assert np.all(np.abs(loose - r.outline) <= 4.0) and np.any(np.abs(loose - r.outline) > 0.5)
    inner = loose_polygon(r, offset_px=(0.0, 0.0), inset=True, rng=np.random.default_rng(5))
    squares = project(K_REAL, T, np.array([[-1, 8, 8, -1], [-1, -1, 6, 6], [0, 0, 0, 0]]) * 0.0635)
    for P in (inner,):
        for k in range(4):  # each vertex lies between the squares' corner and the sheet's
            a, b = np.linalg.norm(P[:, k] - squares[:, k]), np.linalg.norm(P[:, k] - r.outline[:, k])
            total = np.linalg.norm(r.outline[:, k] - squares[:, k])
            assert a + b == pytest.approx(total, rel=1e-9) and min(a, b) > 0.2 * total


def test_perturb_pose_moves_by_the_requested_amounts():
    T = random_pose(K_REAL, rng=np.random.default_rng(4))
    G = perturb_pose(T, rng=np.random.default_rng(4))
    metres, angle = pose_difference(G, T)
    assert 8.0 <= angle <= 12.0
    assert 0.15 <= metres <= 0.25


# ------------------------------------------------------------------ errors


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda T: render_ideal(np.eye(2), T), "K must have shape"),
        (lambda T: render_ideal(K_REAL, np.eye(3)), "T_WC must have shape"),
        (lambda T: render_ideal(K_REAL, T, size=(640,)), "size must be"),
        (lambda T: render_ideal(K_REAL, T, size=(640, 0)), "height must be a positive integer"),
        (lambda T: render_ideal(K_REAL, T, board="8x6"), "board must be"),
        (lambda T: render_ideal(K_REAL, T, gradient=1.0), "gradient must be in"),
        (lambda T: render_ideal(K_REAL, T, blur_sigma=-1.0), "blur_sigma must be"),
        (lambda T: render_ideal(K_REAL, T, margin=float("nan")), "margin must be"),
        (lambda T: render_ideal(K_REAL, T, white="bright"), "white must be a finite number"),
        (lambda T: render_ideal(K_REAL, T, supersample=0), "supersample must be"),
        (lambda T: render(K_REAL, T, noise_sigma=-2.0), "noise_sigma must be"),
        (lambda T: render_ideal(K_REAL, T_from_params([0, 0, 1.0, 0, 0, 0])), "in front of the camera"),
        (lambda T: random_pose(K_REAL, distance=(0.1, 0.1), rng=0), "no pose in"),
        (lambda T: random_pose(K_REAL, distance=(1.0, 0.5), rng=0), "distance must be"),
        (lambda T: random_pose(K_REAL, max_tilt_deg=90, rng=0), "max_tilt_deg must be below"),
        (lambda T: random_pose(K_REAL, max_tries=0, rng=0), "max_tries must be"),
        (lambda T: loose_polygon(render(K_REAL, T, rng=0), offset_px=(3, -3), rng=0), "offset_px must be"),
        (lambda T: junction_information(K_REAL, T, half_width=0), "half_width must be"),
        (lambda T: junction_information(K_REAL, T, noise_sigma=0.0), "noise_sigma must be a finite number > 0"),
        (lambda T: junction_information(K_REAL, T, delta=0.0), "delta must be a finite number > 0"),
        (lambda T: polygon_coverage(np.zeros((2, 2)), (4, 4)), "m >= 3 vertices"),
        (lambda T: perturb_pose(np.eye(3), rng=0), "T_WC must have shape"),
        (lambda T: random_pose(K_REAL, distance=1.0, rng=0), r"distance must be a pair \(near, far\) metres, got 1.0"),
        (lambda T: random_pose(K_REAL, distance=(0.0, 1.0), rng=0), "distance must be .* low > 0"),
        (lambda T: random_pose(K_REAL, distance=(1.0, 2.0, 3.0), rng=0), "distance must be a pair"),
        (lambda T: loose_polygon(render(K_REAL, T, rng=0), offset_px=4.0, rng=0), "offset_px must be a pair"),
        (lambda T: loose_polygon(render(K_REAL, T, rng=0), offset_px="34", rng=0), "offset_px must be a pair"),
        (lambda T: perturb_pose(T, angle_deg=(12.0, 8.0), rng=0), "angle_deg must be .* low <= high"),
        (lambda T: perturb_pose(T, angle_deg=10.0, rng=0), "angle_deg must be a pair"),
        (lambda T: perturb_pose(T, offset_m=(-0.1, 0.2), rng=0), "offset_m must be .* low >= 0"),
        (lambda T: perturb_pose(T, offset_m=(0.1, np.inf), rng=0), "offset_m must be"),
    ],
)
@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
def test_input_errors(call, match):
    T = T_from_params([0.2, 0.1, -1.0, 0.0, 0.0, 0.0])
    with pytest.raises(InputError, match=match):
        call(T)


# ------------------------------------------------------------------ bundled data


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_bundled_data_regenerates_identically(tmp_path):
    spec = importlib.util.spec_from_file_location("make_data", REPO / "scripts" / "make_data.py")
    make_data = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_data)
    fresh = make_data.make(tmp_path)
    stored = json.loads((REPO / "graphpose" / "data" / "cases.json").read_text())
    assert [c["image"] for c in fresh["cases"]] == [c["image"] for c in stored["cases"]]
    for key in ("K", "image_size", "square_m", "world_points"):
        assert np.array_equal(fresh[key], stored[key])
    assert fresh["grid"] == stored["grid"]
    for new, old in zip(fresh["cases"], stored["cases"]):
        for key in ("true_T_WC", "true_junctions", "guess_T_WC", "bounds"):
            np.testing.assert_allclose(new[key], old[key], rtol=0, atol=1e-10)
        assert np.array_equal(imread(tmp_path / new["image"]), imread(REPO / "graphpose" / "data" / old["image"]))


def test_bundled_truth_is_consistent():
    from graphpose.io.cases import load_cases

    cases = load_cases(REPO / "graphpose" / "data" / "cases.json")
    for case in cases.cases:
        assert np.allclose(case.true_junctions, project(cases.K, case.true_T_WC, cases.board.world_points()))
        assert imread(case.image).shape == (480, 640)


def test_sheet_just_outside_the_image_renders_background():
    # Sheets beyond the right edge: a few pixels off (inside the blur kernel's reach, where no
    # fine cell of the window is fully covered, which once broke the sparse path) and far off.
    K = K_REAL
    for x in (-0.75, -2.0):
        T = T_from_params([x, 0.0, -1.2, 0.0, 0.0, 0.0])
        assert project(K, T, Board().sheet_corners(0.5))[0].min() > 640
        ideal = render_ideal(K, T, blur_sigma=1.0, gradient=0.0)
        assert ideal.dtype == np.float64 and ideal.shape == (480, 640)
        np.testing.assert_allclose(ideal, 60.0, atol=1e-6)


# ------------------------------------------------------------------ lens distortion

#: A 640 x 480 wide-angle lens with strong barrel distortion, and a fisheye seeing 112 degrees
#: off its axis.
WIDE = RadTanCamera([[400.0, 0.0, 322.5], [0.0, 400.0, 238.3], [0.0, 0.0, 1.0]], [-0.3, 0.1, 0.001, -0.0005, 0.0],
                    size=(640, 480))
FISHEYE = FisheyeCamera([[165.0, 0.0, 321.0], [0.0, 165.0, 241.0], [0.0, 0.0, 1.0]],
                        [-0.013, -0.004, 0.0035, -0.001], size=(640, 480))
LENSES = [(WIDE, (0.5, 0.8)), (FISHEYE, (0.25, 0.4))]


def test_pinhole_camera_renders_exactly_as_K():
    T = random_pose(K_REAL, rng=np.random.default_rng(6))
    assert np.array_equal(T, random_pose(PinholeCamera(K_REAL), rng=np.random.default_rng(6)))
    a, b = render(K_REAL, T, rng=1), render(PinholeCamera(K_REAL, (640, 480)), T, rng=1)
    assert np.array_equal(a.image, b.image) and np.array_equal(a.junctions, b.junctions)
    assert a.camera == PinholeCamera(K_REAL) and b.camera == PinholeCamera(K_REAL, (640, 480))


def test_distortion_free_lens_path_equals_the_pinhole_path():
    # A radial-tangential camera with zero coefficients takes the lens path (clipping to the
    # cone, polylines, segments) and must give the pinhole path's image.
    rng = np.random.default_rng(12)
    for _ in range(2):
        T = random_pose(K_REAL, rng=rng)
        for settings in ({}, {"blur_sigma": 0.0}, {"blur_sigma": 0.6, "supersample": 3}):
            I = render_ideal(K_REAL, T, **settings)
            J = render_ideal(RadTanCamera(K_REAL, [0.0] * 4), T, **settings)
            assert np.abs(I - J).max() < 1e-9


@pytest.mark.parametrize("camera, distance", LENSES)
def test_distorted_render_truth_is_the_camera_projection(camera, distance):
    board = Board()
    T = random_pose(camera, board, distance=distance, rng=np.random.default_rng(3))
    r = render(camera, T, board, rng=3)
    assert r.camera == camera and r.size == (640, 480) and r.image.shape == (480, 640)
    assert np.array_equal(r.K, camera.K)
    assert np.array_equal(r.junctions, camera.project(to_camera(T, board.world_points())))
    assert np.array_equal(r.outline, camera.project(to_camera(T, board.sheet_corners(0.5))))
    # The lens matters: the pinhole camera with the same K puts the junctions elsewhere.
    assert np.hypot(*(r.junctions - project(camera.K, T, board.world_points()))).max() > 5


@pytest.mark.parametrize("camera", [
    RadTanCamera([[400.0, 0.0, 320.0], [0.0, 410.0, 240.5], [0.0, 0.0, 1.0]], [-0.3, 0.1, 0.0, 0.0, 0.01]),
    FisheyeCamera([[165.0, 0.0, 320.0], [0.0, 166.0, 240.5], [0.0, 0.0, 1.0]], [-0.013, -0.004, 0.0035, -0.001]),
])
def test_distorted_render_is_point_symmetric_about_a_centred_junction(camera):
    # Radial distortion is odd about the principal point: a fronto-parallel board whose
    # centre junction lies on it images point-symmetrically about it, curved edges and all,
    # and the noise-free saddle point of that junction is the truth.
    board = Board(7, 5)
    T = np.eye(4)
    T[:3, 3] = [3 * board.square_m, 2 * board.square_m, -0.6]
    I = render_ideal(camera, T, board, (640, 480), gradient=0.0)
    truth = image_points(camera, T, board.world_points())[:, 17]  # row 2, column 3: the centre
    assert np.allclose(truth, [320.0, 240.5], atol=1e-12)
    u, v = 640 - np.arange(640), 481 - np.arange(480)  # pixel p maps to 2 * truth - p
    cols, rows = np.flatnonzero(u < 640), np.flatnonzero(v < 480)
    assert np.abs(I[np.ix_(rows, cols)] - I[np.ix_(v[rows], u[cols])]).max() < 1e-9
    assert np.abs(I - render_ideal(camera.pinhole(), T, board, (640, 480), gradient=0.0)).max() > 50
    patch = I[234:248, 314:327]  # centred on (320, 240.5)
    assert np.abs(saddle_point(patch).ravel() + [314, 234] - truth).max() < 1e-6


@pytest.mark.slow  # renders at several supersamplings
@pytest.mark.parametrize("camera, distance", LENSES)
def test_finer_polylines_and_supersampling_barely_change_distorted_junctions(camera, distance):
    # Halving the chords (a quarter of the sagitta) and doubling the fine grid move the
    # junctions by far less than any detector's error (~0.01 px); the displacement is the
    # least-squares translation of each 13 x 13 window, as in the supersampling test above.
    board = Board()
    T = random_pose(camera, board, distance=distance, rng=np.random.default_rng(5))
    base = render_ideal(camera, T, board)
    finer = render_ideal(camera, T, board, edge_tol_px=2.5e-5)
    both = render_ideal(camera, T, board, edge_tol_px=2.5e-5, supersample=8)
    coarse = render_ideal(camera, T, board, edge_tol_px=0.05)
    gu, gv = image_gradients(camera, T, board, edge_tol_px=2.5e-5, supersample=8)
    hw, coarse_shift = 6, 0.0
    for u, v in np.rint(image_points(camera, T, board.world_points())).astype(int).T:
        window = slice(v - hw, v + hw + 1), slice(u - hw, u + hw + 1)
        assert np.abs(finer - base)[window].max() < 0.02  # grey levels
        G = np.stack([gu[window].ravel(), gv[window].ravel()], axis=1)
        finer_shift, both_shift, shift = (
            np.hypot(*np.linalg.lstsq(G, (base - other)[window].ravel(), rcond=None)[0])
            for other in (finer, both, coarse))
        assert finer_shift < 2e-4 and both_shift < 5e-4
        coarse_shift = max(coarse_shift, shift)
    assert coarse_shift > 5e-4  # the measure does see a coarse polyline


def _dense_grey(camera, T, board, uv, n, size=(640, 480), margin=0.5):
    """Mean of (sheet 100, squares and background 0) over n x n points spread over each pixel
    of uv (2, m), each point classified through camera.unproject and the board's plane:
    independent of the renderer's polylines, clipping and rasteriser."""
    g = (np.arange(n) + 0.5) / n - 0.5
    du, dv = (a.ravel() for a in np.meshgrid(g, g))
    pts = (uv[:, :, None] + np.stack([du, dv])[:, None, :]).reshape(2, -1)
    rays = camera.unproject(pts)
    ok = np.all(np.isfinite(rays), axis=0)
    rays = np.where(ok, rays, 0.0)
    ok &= in_view(rays, view_limit(camera, size))
    dW = T[:3, :3] @ rays
    with np.errstate(divide="ignore", invalid="ignore"):
        s = -T[2, 3] / dW[2]
        x, y = T[:2, 3:4] + s * dW[:2]
    q, m = board.square_m, margin * board.square_m
    sheet = ok & (s > 0) & (x > -q - m) & (x < board.cols * q + m) & (y > -q - m) & (y < board.rows * q + m)
    i, j = np.floor(x / q) + 1, np.floor(y / q) + 1
    black = sheet & (i >= 0) & (i <= board.cols) & (j >= 0) & (j <= board.rows) & ((i + j) % 2 == 0)
    return (100.0 * (sheet & ~black)).reshape(uv.shape[1], -1).mean(axis=1)


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("camera, distance", LENSES)
def test_distorted_junctions_match_a_brute_force_reference(camera, distance):
    # Independent of the polylines, the clipping and the rasteriser: each pixel of a 9 x 9
    # window around a junction as the mean of 40 x 40 point samples, each classified through
    # camera.unproject (blur-free, so a pixel is the limit of that mean). The least-squares
    # translation between the two windows, how far the renderer's junction lies from the
    # reference's, is far below the detector's error (~0.01 px).
    board = Board()
    T = random_pose(camera, board, distance=distance, rng=np.random.default_rng(5))
    levels = {"background": 0.0, "white": 100.0, "black": 0.0, "gradient": 0.0, "blur_sigma": 0.0}
    I = render_ideal(camera, T, board, **levels)
    gu, gv = image_gradients(camera, T, board, delta=0.05, **levels)
    uv = image_points(camera, T, board.world_points())
    hw = 4
    for k, (u, v) in enumerate(np.rint(uv[:, [0, 20, 27, 47]]).astype(int).T):
        U, V = np.meshgrid(np.arange(u - hw, u + hw + 1), np.arange(v - hw, v + hw + 1))
        reference = _dense_grey(camera, T, board, np.vstack([U.ravel(), V.ravel()]).astype(float), 40)
        window = slice(v - hw, v + hw + 1), slice(u - hw, u + hw + 1)
        G = np.stack([gu[window].ravel(), gv[window].ravel()], axis=1)
        shift = np.linalg.lstsq(G, I[window].ravel() - reference, rcond=None)[0]
        assert np.hypot(*shift) < 1e-3
        if k == 0:  # the same measure sees a junction moved by 0.01 px
            moved = _dense_grey(camera, T, board, np.vstack([U.ravel() + 0.01, V.ravel()]).astype(float), 40)
            assert np.hypot(*np.linalg.lstsq(G, I[window].ravel() - moved, rcond=None)[0]) > 5e-3


@pytest.mark.slow  # renders through a wide fisheye at full size
@pytest.mark.parametrize("camera, params", [
    (FISHEYE, [0.4, 0.3, -0.15, 0.3, 1.9, 0.2]),  # along a large board: beyond theta_max, and behind
    (WIDE, [0.5, 0.35, -0.2, 0.0, 1.3, 0.0]),  # a board half behind the camera
])
def test_board_beyond_the_lens_range_renders_what_the_model_images(camera, params):
    # Blur-free pixels are exact areas: they must match the mean of dense point samples, each
    # classified on its own through unproject (so only rays within the model's cone, in front
    # of the board), at edges, at the fisheye's rim and in flat areas.
    board = Board(20, 14, 0.05)
    T = T_from_params(params)
    corners_C = to_camera(T, board.sheet_corners(0.5))
    assert np.any(corners_C[2] < 0) and not np.all(in_view(corners_C, view_limit(camera, (640, 480))))
    levels = {"background": 0.0, "white": 100.0, "black": 0.0, "gradient": 0.0, "blur_sigma": 0.0}
    I = render_ideal(camera, T, board, **levels)
    assert 0.02 < np.mean(I > 50) < 0.5  # a good part of the image shows the board
    # Junctions outside the cone have no image (NaN), the others are camera.project.
    r = render(camera, T, board, noise_sigma=0.0, **levels)
    P_C = to_camera(T, board.world_points())
    seen = in_view(P_C, view_limit(camera, (640, 480)))
    assert 0 < seen.sum() < board.n and np.all(np.isnan(r.junctions[:, ~seen]))
    assert np.array_equal(r.junctions[:, seen], camera.project(P_C[:, seen]))
    # Edge pixels (partly covered), some at the rim, against 100 x 100 samples per pixel.
    rng = np.random.default_rng(0)
    V, U = np.nonzero((I > 1.0) & (I < 99.0))
    rim = np.hypot(U - camera.cx, V - camera.cy)
    if camera.model == "fisheye":
        limit = view_limit(camera, (640, 480))
        k1, k2, k3, k4 = camera.distortion
        t = limit**2
        edge = camera.fx * limit * (1 + t * (k1 + t * (k2 + t * (k3 + t * k4))))
        near = np.flatnonzero(np.abs(rim - edge) < 1.5)
        assert near.size > 20
        pick = np.concatenate([rng.choice(near, 8, replace=False), rng.choice(U.size, 16, replace=False)])
    else:
        pick = rng.choice(U.size, 24, replace=False)
    uv = np.vstack([U[pick], V[pick]]).astype(float)
    assert np.abs(_dense_grey(camera, T, board, uv, 100) - I[V[pick], U[pick]]).max() < 0.3
    # Flat areas, judged from one sample per pixel away from edges (and from the rim, where
    # the lens squeezes whole squares into a pixel): exactly 0 or 100.
    U, V = np.meshgrid(np.arange(640), np.arange(480))
    centre = _dense_grey(camera, T, board, np.vstack([U.ravel(), V.ravel()]).astype(float), 1).reshape(480, 640)
    flat = maximum_filter(centre, 5) == minimum_filter(centre, 5)
    if camera.model == "fisheye":
        flat &= np.abs(np.hypot(U - camera.cx, V - camera.cy) - edge) > 4
    assert flat.mean() > 0.8 and np.abs(I - centre)[flat].max() < 1e-9


@pytest.mark.slow  # many poses through strong lenses
@pytest.mark.parametrize("camera, distance", LENSES)
def test_random_pose_keeps_the_distorted_sheet_in_view(camera, distance):
    rng = np.random.default_rng(21)
    board = Board()
    sheet = board.sheet_corners(0.5)
    n = 400
    outline = (sheet[:, :, None] + (np.roll(sheet, -1, axis=1) - sheet)[:, :, None] * (np.arange(n) / n))
    for _ in range(10):
        T = random_pose(camera, board, distance=distance, rng=rng)
        P_C = to_camera(T, outline.reshape(3, -1))
        assert np.all(in_view(P_C, view_limit(camera, (640, 480))))
        uv = camera.project(P_C)
        assert np.all((uv >= 7.9) & (uv <= np.array([[632.1], [472.1]])))
        r = render(camera, T, board, noise_sigma=0.0)
        assert np.all(np.isfinite(r.junctions)) and shoelace(r.outline) > 0
        assert np.argmin(np.hypot(*(r.outline - r.junctions[:, :1]))) == 0
        # The board faces the camera: its normal within the tilt of the line of sight.
        centre_C = to_camera(T, board.world_points().mean(axis=1, keepdims=True))[:, 0]
        normal_C = T[:3, :3].T[:, 2]
        assert np.degrees(np.arccos(normal_C @ centre_C / np.linalg.norm(centre_C))) < 35.0 + 1e-9
        assert np.linalg.norm(centre_C) == pytest.approx(np.clip(np.linalg.norm(centre_C), *distance))
    inner = loose_polygon(r, offset_px=(0.0, 0.0), inset=True, rng=rng)
    assert np.all(np.hypot(*(inner - r.outline)) > 1.0)


@pytest.mark.slow  # 0.2 s or so on two idle cores: a render, a calibration or a subprocess
def test_principal_point_shift_translates_the_distorted_image():
    # The premise of image_gradients and junction_information with a lens: moving cx, cy by
    # whole pixels moves the raw image by as many pixels.
    from dataclasses import replace

    T = random_pose(WIDE, distance=(0.5, 0.8), rng=np.random.default_rng(9))
    I = render_ideal(WIDE, T, gradient=0.0, blur_sigma=1.3)
    K2 = WIDE.K.copy()
    K2[0, 2] += 1.0
    K2[1, 2] -= 2.0
    J = render_ideal(replace(WIDE, K=K2), T, gradient=0.0, blur_sigma=1.3)
    assert np.allclose(J[:-2, 1:], I[2:, :-1], atol=1e-9)
    fim = junction_information(WIDE, T, noise_sigma=2.0, edge_tol_px=1e-3)
    assert fim.shape == (48, 2, 2) and np.all(np.linalg.eigvalsh(fim) > 0)


@pytest.mark.parametrize("call, match", [
    (lambda: render_ideal(WIDE, np.eye(4), size=(800, 600)), "calibrated for 640 x 480"),
    (lambda: random_pose(FISHEYE, size=(320, 240), rng=0), "calibrated for 640 x 480"),
    (lambda: render_ideal(WIDE, np.eye(4), edge_tol_px=0.0), "edge_tol_px must be"),
    (lambda: render_ideal(RadTanCamera(np.eye(3), [0.0] * 4), np.eye(4), board=None), "board must be"),
])
def test_lens_input_errors(call, match):
    with pytest.raises(InputError, match=match):
        call()


def test_a_bent_board_is_drawn_between_its_moved_corners():
    # mrcal's board warp: every corner of the squares and the sheet moves out of the plane;
    # the pinhole image's dark area is that of the moved squares' projections, and the truth
    # is the moved junctions' projection.
    board = Board()
    warp = (0.01, -0.004)
    T = random_pose(K_REAL, board, rng=np.random.default_rng(3))
    levels = dict(background=200.0, white=200.0, black=50.0, gradient=0.0)
    I = render_ideal(K_REAL, T, board, blur_sigma=0.0, warp=warp, **levels)
    dark = np.sum(200.0 - I) / 150.0
    exact = sum(abs(shoelace(project(K_REAL, T, board.warped(Q, warp)))) for Q in _black_squares_world(board))
    assert dark == pytest.approx(exact, rel=1e-6)
    flat = sum(abs(shoelace(project(K_REAL, T, Q))) for Q in _black_squares_world(board))
    assert abs(dark - flat) > 100 * 1e-6 * flat  # the bend shows, far beyond the tolerance above
    r = render(K_REAL, T, board, noise_sigma=0.0, warp=warp)
    np.testing.assert_allclose(r.junctions, image_points(K_REAL, T, board.warped(board.world_points(), warp)))
    assert np.abs(r.junctions - image_points(K_REAL, T, board.world_points())).max() > 0.5

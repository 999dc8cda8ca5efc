"""graphpose.course: the course's four seed functions, each a shell over the library's steps,
under their seed names and shapes: saddle_point (one patch's saddle), cross_junctions (a whole
board's junctions, all or none), find_jacobian (one point's projection Jacobian) and
pose_estimate_nls (the Gauss-Newton pose, or a ConvergenceError)."""

import dataclasses
import json
import sys

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from graphpose import (
    Board,
    BoardNotFoundError,
    ConvergenceError,
    InputError,
    SaddleError,
    cross_junctions,
    extract_junctions,
    find_jacobian,
    pose_estimate_nls,
    saddle_point,
)
from graphpose.geometry import T_from_params, params_from_T, project
from tests.conftest import BOARD_WPTS as WPTS
from tests.conftest import PROJECT_K as K
from tests.conftest import real_file
from tests.detect.test_junctions import synthetic
from tests.detect.test_saddle import junction, quadric
from tests.helpers import facing_pose
from tests.pose.test_gauss_newton import numeric_jacobian, perturb


# ---- saddle_point: one patch's saddle, (2, 1) ---------------------------------------------------
def saddle_of(coeffs):
    a, b, g, d, e, _ = coeffs
    return np.linalg.solve([[2 * a, b], [b, 2 * g]], [-d, -e])


def test_exact_quadric_anywhere_in_the_patch():
    rng = np.random.default_rng(1)
    for _ in range(20):
        a, g = rng.uniform(-1, 1, 2)
        b = np.sqrt(abs(4 * a * g)) + rng.uniform(0.5, 2.0)  # 4ag - b^2 < 0
        centre = rng.uniform(0.5, 7.5, 2)
        d, e = -np.array([[2 * a, b], [b, 2 * g]]) @ centre
        coeffs = (a, b, g, d, e, rng.uniform(-1, 1))
        pt = saddle_point(quadric(9, 9, coeffs))
        assert pt.shape == (2, 1)
        np.testing.assert_allclose(pt[:, 0], saddle_of(coeffs), atol=1e-9)


def test_rectangular_patch_uses_u_as_column():
    coeffs = (0.0, 1.0, 0.0, -5.0, -2.0, 0.0)  # (u - 2)(v - 5) - 10
    np.testing.assert_allclose(saddle_point(quadric(8, 5, coeffs))[:, 0], [2.0, 5.0], atol=1e-9)


@pytest.mark.parametrize("angles", [(0.3, 1.9), (0.0, np.pi / 2), (0.7, 2.0), (-0.4, 1.0)])
@pytest.mark.parametrize("sigma", [0.8, 1.5])
def test_smoothed_synthetic_junction_centred_patch(angles, sigma):
    # A junction at the centre of a point-symmetric window: the fit is unbiased by symmetry,
    # whatever the angle between the edges (perspective makes them non-perpendicular).
    size = 11
    centre = np.array([5.0, 5.0])
    P = gaussian_filter(junction(size, centre, angles, sigma), 1.0)
    np.testing.assert_allclose(saddle_point(P)[:, 0], centre, atol=0.01)


def test_smoothed_synthetic_junction_off_centre_within_0_01_px():
    # Off the patch centre the quadric pulls towards the centre, so the patch is resampled
    # around the estimate until it is centred (what refinement does); a few rounds converge.
    rng = np.random.default_rng(7)
    for _ in range(5):
        truth = np.array([20.0, 20.0]) + rng.uniform(-0.5, 0.5, 2)
        angles = (rng.uniform(0, np.pi), 0.0)
        angles = (angles[0], angles[0] + rng.uniform(1.2, 1.9))
        estimate = np.array([20.0, 20.0])
        for _ in range(8):
            image = junction(41, truth - estimate + 20.0, angles)
            P = gaussian_filter(image, 1.0)[15:26, 15:26]
            estimate = estimate + saddle_point(P)[:, 0] - 5.0
        assert np.max(np.abs(estimate - truth)) < 0.01


def test_not_a_saddle_raises():
    with pytest.raises(SaddleError, match="not a saddle"):
        saddle_point(quadric(7, 7, (1.0, 0.0, 1.0, -6.0, -6.0, 0.0)))
    with pytest.raises(SaddleError, match="not a saddle"):
        saddle_point(np.ones((7, 7)))


def test_saddle_outside_the_patch_raises():
    with pytest.raises(SaddleError, match="outside"):
        saddle_point(quadric(7, 7, (0.0, 1.0, 0.0, -9.0, -1.0, 0.0)))


@pytest.mark.parametrize(
    "bad, message",
    [(np.zeros((0, 0)), "I is empty"), (np.zeros(9), "I must be 2-D"), (np.zeros((3, 3, 3)), "2-D"),
     (np.zeros((2, 5)), "at least 3 x 3"),
     (np.full((5, 5), np.nan), "NaN"), ([[1, 2, 3], [4, 5]], "I must be a rectangular array of real numbers")],
)
def test_bad_patch_raises_input_error(bad, message):
    with pytest.raises(InputError, match=message):
        saddle_point(bad)


# ---- cross_junctions: every junction of the board, or none ---------------------------------


@pytest.fixture(scope="module")
def small_case():
    return synthetic(31)


def test_cross_junctions_is_extract_junctions_points(real_images):
    case, image = real_images[1]
    J = extract_junctions(image, bounds=case.bounds)
    np.testing.assert_array_equal(cross_junctions(image, case.bounds, Board().world_points()), J.points)


def test_wpts_not_a_grid_raises_input_error(small_case):
    R, poly = small_case
    W = Board().world_points()
    with pytest.raises(InputError, match="grid"):
        cross_junctions(R.image, poly, W[:, ::-1])
    with pytest.raises(InputError, match="Wpts"):
        cross_junctions(R.image, poly, W[:2])


def test_cross_junctions_returns_the_whole_board_or_none(small_case, monkeypatch):
    # A board partly hidden (one junction unseen) is refused, naming how many are in view:
    # the seed shape is all n junctions; extract_junctions returns partial boards.
    R, poly = small_case
    whole = extract_junctions(R.image, bounds=poly)
    assert whole.seen.all()
    np.testing.assert_array_equal(cross_junctions(R.image, poly, WPTS), whole.points)
    seen = whole.seen.copy()
    seen[20] = False
    partial = dataclasses.replace(whole, seen=seen)
    monkeypatch.setattr(sys.modules["graphpose.course"], "extract_junctions", lambda *a, **k: partial)
    with pytest.raises(BoardNotFoundError, match="only 47 of the 48 junctions are in view"):
        cross_junctions(R.image, poly, WPTS)


# ---- find_jacobian and pose_estimate_nls -------------------------------------------------------


def test_jacobian_matches_reference_case_to_its_decimals():
    case = json.loads(real_file("jacobian_case.json").read_text())
    J = find_jacobian(case["K"], case["T_WC"], np.reshape(case["point"], (3, 1)))
    assert J.shape == (2, 6)
    np.testing.assert_array_equal(np.round(J, case["J_decimals"]), case["J"])


def test_jacobian_matches_central_differences_on_random_poses():
    rng = np.random.default_rng(1)
    for _ in range(100):
        T = facing_pose(rng=rng)
        p = params_from_T(T)
        W = WPTS[:, rng.integers(0, WPTS.shape[1], 1)] + rng.normal(0, 0.05, (3, 1)) * [[1], [1], [0]]
        J = find_jacobian(K, T, W)
        J_num = numeric_jacobian(K, p, W)
        np.testing.assert_allclose(J, J_num, rtol=1e-6, atol=1e-6 * np.max(np.abs(J)))


def test_find_jacobian_refuses_more_than_one_point_and_points_behind():
    T = T_from_params([0.2, 0.15, -1.0, 0.0, 0.0, 0.0])
    with pytest.raises(InputError, match="single point"):
        find_jacobian(K, T, WPTS[:, :2])
    with pytest.raises(InputError, match="behind"):
        find_jacobian(K, T, [0.0, 0.0, -2.0])
    with pytest.raises(InputError, match=r"Wpt must have shape \(3, N\), got \(4,\)"):
        find_jacobian(K, T, [0.0, 0.0, 0.0, 1.0])  # once a reshape ValueError
    with pytest.raises(InputError, match="Wpt must be a rectangular array"):
        find_jacobian(K, T, "origin")
    np.testing.assert_array_equal(find_jacobian(K, T, [0.1, 0.2, 0.0]), find_jacobian(K, T, [[0.1], [0.2], [0.0]]))


def test_exact_correspondences_give_the_exact_pose():
    rng = np.random.default_rng(4)
    for _ in range(20):
        T = facing_pose(rng=rng)
        I = project(K, T, WPTS)
        T_est = pose_estimate_nls(K, perturb(rng, T, 10, 0.2), I, WPTS)
        np.testing.assert_allclose(T_est, T, atol=1e-9)


def test_pose_estimate_nls_raises_when_it_does_not_converge(monkeypatch):
    rng = np.random.default_rng(10)
    T = facing_pose(rng=rng)
    monkeypatch.setattr(sys.modules["graphpose.course"], "MAX_ITERATIONS", 1)
    with pytest.raises(ConvergenceError, match="did not converge"):
        pose_estimate_nls(K, perturb(rng, T, 20, 0.3), project(K, T, WPTS), WPTS)

"""graphpose.synth.fuzz: each drawn case keeps its truth (the fuzz itself, through the detector
and the pose, is tests/test_fuzz.py's)."""

import numpy as np
import pytest
from skimage.measure import points_in_poly

from graphpose import project
from graphpose.synth.fuzz import BOARDS, ENTRIES, K_FUZZ, POLYGONS, fuzz_case

SIZE = (320, 240)  # half the real images' size: a quick render


def test_truth_is_the_projection_of_the_board_at_the_true_pose():
    case = fuzz_case(3, polygon="exact", partial=False, size=SIZE)
    assert case.image.shape == SIZE[::-1] and case.image.dtype == np.uint8
    assert case.board in BOARDS and case.entry in ENTRIES and case.polygon == "exact" and case.roll == 0
    # The camera is the real images' scaled to the size: f and the principal point halve.
    np.testing.assert_allclose(case.K, K_FUZZ * [[0.5], [0.5], [1.0]], rtol=1e-12)
    np.testing.assert_allclose(case.truth, project(case.K, case.T_WC, case.board.world_points()), atol=1e-9)
    # No occluder: every junction inside the image is visible; the exact polygon is the sheet.
    assert case.settings["occluders"] == ()
    inside = np.all((case.truth > -0.5) & (case.truth < np.array(SIZE)[:, None] - 0.5), axis=0)
    np.testing.assert_array_equal(case.visible, inside)
    sheet = project(case.K, case.T_WC, case.board.sheet_corners(case.settings["margin"]))
    np.testing.assert_allclose(case.bounds, sheet, atol=1e-9)
    assert points_in_poly(case.truth.T, case.bounds.T).all()


def test_a_rolled_polygon_names_another_corner_first():
    for seed in range(2):
        case = fuzz_case(seed, polygon="rolled", partial=True, size=SIZE)
        assert case.roll in (1, 2, 3) and case.settings["occluders"]
        sheet = project(case.K, case.T_WC, case.board.sheet_corners(case.settings["margin"]))
        # Unrolled, it is a loose outline: each vertex within 4 px of its sheet corner, per axis.
        assert np.abs(np.roll(case.bounds, -case.roll, axis=1) - sheet).max() <= 4.0 + 1e-9
        assert np.abs(case.bounds - sheet).max() > 4.0  # ...and rolled, it is not
        assert not case.visible.all()  # partial: some junction hidden or outside the image


def test_a_seed_draws_the_same_case_and_fixed_choices_are_kept():
    a = fuzz_case(11, entry="pose", polygon="none", partial=False, size=SIZE)
    b = fuzz_case(np.random.default_rng(11), entry="pose", polygon="none", partial=False, size=SIZE)
    np.testing.assert_array_equal(a.image, b.image)
    np.testing.assert_array_equal(a.T_WC, b.T_WC)
    assert a.settings == b.settings and a.entry == "pose" and a.bounds is None and a.roll == 0


@pytest.mark.parametrize("polygon", ["loose", "inset"])
def test_loose_and_inset_polygons_keep_their_vertex_order(polygon):
    case = fuzz_case(5, polygon=polygon, size=SIZE)
    assert polygon in POLYGONS and case.roll == 0
    outer = project(case.K, case.T_WC, case.board.sheet_corners(case.settings["margin"]))
    # Vertex i near corner i: nearer it than any other corner of the sheet.
    for i in range(4):
        d = np.hypot(*(outer - case.bounds[:, i : i + 1]))
        assert np.argmin(d) == i

"""graphpose.calibrate.crossval: two cameras' projection difference after the best rotation
(hand-derived for a zoom, zero for one camera), its first-order prediction from a covariance
against the difference of a finite step, and cross_validate's refusal of too few views."""

from types import SimpleNamespace

import numpy as np
import pytest

from graphpose import Board, InputError, K_from_params, PinholeCamera, RadTanCamera
from graphpose.calibrate.crossval import FOCUS_FRACTION, projection_diff, predicted_diff, cross_validate

LENS = RadTanCamera(K_from_params(530.0, 528.0, 322.5, 241.0), [-0.3, 0.11, 0.0008, -0.0005, -0.02], (640, 480))


def test_a_camera_against_itself_differs_by_nothing():
    d = projection_diff(LENS, LENS, step=32.0)
    assert d.diff_px.shape == (d.vs.size, d.us.size) == (15, 20)
    np.testing.assert_allclose(d.R, np.eye(3), atol=1e-12)
    assert np.nanmax(d.diff_px) < 1e-9 and d.median_px < 1e-9


def test_a_zoom_is_not_a_rotation_the_difference_grows_with_the_distance_from_the_centre():
    # Pinhole cameras on a grid symmetric about the principal point: the best rotation is the
    # identity, and fx (1 + e) moves the pixel at u by e |u - cx|.
    size, e = (641, 481), 1e-3
    zero = PinholeCamera(K_from_params(500.0, 500.0, 320.0, 240.0), size)
    zoom = PinholeCamera(K_from_params(500.0 * (1 + e), 500.0, 320.0, 240.0), size)
    d = projection_diff(zero, zoom, step=16.0)
    np.testing.assert_allclose(d.R, np.eye(3), atol=1e-12)
    u, _ = np.meshgrid(d.us, d.vs)
    np.testing.assert_allclose(d.diff_px, e * np.abs(u - 320.0), rtol=1e-9, atol=1e-9)
    assert d.median_px == pytest.approx(float(np.median(e * np.abs(u - 320.0))), rel=1e-9)


def test_a_principal_point_shift_is_mostly_a_rotation():
    # Shifting cx by 1 px moves every pixel by about 1 px, but turning the ray by about -1/fx
    # about y takes that up (camera 1 must see x - 1/fx where camera 0 sees x): what is left is
    # far smaller.
    p = LENS.parameters
    shifted = LENS.with_parameters(p + np.r_[0.0, 0.0, 1.0, np.zeros(6)])
    d = projection_diff(LENS, shifted, step=32.0)
    assert d.median_px < 0.1
    np.testing.assert_allclose(projection_diff(LENS, shifted, step=32.0, focus_radius_px=0).R @ [0, 0, 1],
                               [-1.0 / 530.0, 0, 1], atol=1e-4)  # camera 1 sees x - 1/fx at q


@pytest.mark.parametrize("name", LENS.parameter_names)
def test_the_prediction_is_the_first_order_difference_of_a_small_step(name):
    # A covariance of one parameter's step d, C = d d^T: the predicted RMS length is the first
    # order of the difference that step makes, rotation fit included.
    p = LENS.parameters
    k = LENS.parameter_names.index(name)
    d = np.zeros(p.size)
    d[k] = 1e-3 * max(abs(p[k]), 1e-2)
    diff = projection_diff(LENS, LENS.with_parameters(p + d), step=32.0)
    predicted = predicted_diff(LENS, np.outer(d, d), step=32.0).reshape(diff.diff_px.shape)
    np.testing.assert_allclose(diff.diff_px, predicted, rtol=0.05, atol=1e-3 * np.nanmax(predicted))


def test_bad_input_is_refused():
    with pytest.raises(InputError, match="two cameras of one known image size"):
        projection_diff(LENS, PinholeCamera(LENS.K, (320, 240)))
    with pytest.raises(InputError, match="two cameras of one known image size"):
        projection_diff(PinholeCamera(LENS.K), PinholeCamera(LENS.K))
    radius = min(LENS.size) * FOCUS_FRACTION
    assert radius == 80.0
    with pytest.raises(InputError, match=r"focus region \(radius 1 px\) holds [0-2] grid pixels"):
        projection_diff(LENS, LENS, step=64.0, focus_radius_px=1.0)
    five = SimpleNamespace(status=("used",) * 5 + ("no board",) * 3)
    with pytest.raises(InputError, match="each from at least 3; this calibration used 5"):
        cross_validate(five, board=Board())

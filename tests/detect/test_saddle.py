"""Tests of graphpose.detect.saddle: exact quadrics, synthetic cross-junctions, the batched form, errors."""

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter
from scipy.special import erf

from graphpose import InputError, SaddleError, fit_saddles, saddle_point


def quadric(h, w, coeffs):
    v, u = np.mgrid[0:h, 0:w].astype(float)
    a, b, g, d, e, z = coeffs
    return a * u * u + b * u * v + g * v * v + d * u + e * v + z


def saddle_of(coeffs):
    a, b, g, d, e, _ = coeffs
    return np.linalg.solve([[2 * a, b], [b, 2 * g]], [-d, -e])


def junction(size, centre, angles=(0.3, 1.9), sigma=1.0):
    """A blurred cross-junction: two straight edges through ``centre`` at the given angles."""
    v, u = np.mgrid[0:size, 0:size].astype(float)
    d = [(u - centre[0]) * np.sin(a) - (v - centre[1]) * np.cos(a) for a in angles]
    s = np.sqrt(2.0) * sigma
    return 0.5 + 0.4 * erf(d[0] / s) * erf(d[1] / s)


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


def test_batched_fit_matches_single_fits_and_flags_bad_patches():
    rng = np.random.default_rng(3)
    patches = [gaussian_filter(junction(9, rng.uniform(3.5, 4.5, 2)), 1.0) for _ in range(4)]
    bowl = quadric(9, 9, (1.0, 0.0, 1.0, -8.0, -8.0, 0.0))  # a minimum, not a saddle
    far = quadric(9, 9, (0.0, 1.0, 0.0, -20.0, -20.0, 0.0))  # saddle at (20, 20)
    fit = fit_saddles(np.stack(patches + [bowl, far]))
    assert fit.points.shape == (2, 6) and fit.valid.shape == (6,) and fit.residual.shape == (6,)
    np.testing.assert_array_equal(fit.valid, [True] * 4 + [False, False])
    for k, P in enumerate(patches):
        np.testing.assert_allclose(fit.points[:, k], saddle_point(P)[:, 0], atol=1e-12)
    np.testing.assert_allclose(fit.points[:, 5], [20.0, 20.0], atol=1e-9)
    assert fit.residual[5] < 1e-9 and np.all(fit.residual[:4] > 0)


def test_uniform_weights_give_the_unweighted_fit():
    rng = np.random.default_rng(4)
    patches = np.stack([junction(9, rng.uniform(3, 5, 2)) + rng.normal(0, 0.01, (9, 9)) for _ in range(3)])
    plain = fit_saddles(patches)
    weighted = fit_saddles(patches, weights=np.full((9, 9), 2.0))
    np.testing.assert_allclose(weighted.points, plain.points, atol=1e-9)
    np.testing.assert_allclose(weighted.coeffs, plain.coeffs, atol=1e-9)


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


def test_bad_batch_raises_input_error():
    with pytest.raises(InputError, match=r"\(m, h, w\)"):
        fit_saddles(np.zeros((5, 5)))


def test_weights_of_the_wrong_shape_raise_input_error():
    with pytest.raises(InputError, match="weights"):
        fit_saddles(np.zeros((2, 5, 5)), weights=np.ones((4, 4)))
    with pytest.raises(InputError, match="weights must be a rectangular array of real numbers"):
        fit_saddles(np.zeros((2, 5, 5)), weights="heavy")
    with pytest.raises(InputError, match="patches must be a rectangular array of real numbers"):
        fit_saddles([np.zeros((5, 5)), np.zeros((4, 4))])


def test_weighted_fit_minimises_the_weighted_residual():
    rng = np.random.default_rng(8)
    patches = np.stack([junction(9, rng.uniform(3, 5, 2)) + rng.normal(0, 0.02, (9, 9)) for _ in range(3)])
    weights = rng.uniform(0.0, 2.0, patches.shape)
    fit = fit_saddles(patches, weights)
    for k in range(3):
        model = quadric(9, 9, fit.coeffs[:, k])
        rms = np.sqrt(np.sum(weights[k] * (patches[k] - model) ** 2) / weights[k].sum())
        np.testing.assert_allclose(fit.residual[k], rms, rtol=1e-6)
        # Any other quadric leaves a larger weighted residual.
        nudged = quadric(9, 9, fit.coeffs[:, k] + rng.normal(0, 1e-3, 6))
        assert np.sum(weights[k] * (patches[k] - nudged) ** 2) > np.sum(weights[k] * (patches[k] - model) ** 2)

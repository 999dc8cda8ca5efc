"""Tests of graphpose.detect.saddle: the batched fit (against the course's one-patch saddle_point, whose
own tests of exact quadrics and synthetic cross-junctions are in tests/test_course.py), weights, errors."""

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter
from scipy.special import erf

from graphpose import InputError, fit_saddles, saddle_point


def quadric(h, w, coeffs):
    v, u = np.mgrid[0:h, 0:w].astype(float)
    a, b, g, d, e, z = coeffs
    return a * u * u + b * u * v + g * v * v + d * u + e * v + z


def junction(size, centre, angles=(0.3, 1.9), sigma=1.0):
    """A blurred cross-junction: two straight edges through ``centre`` at the given angles."""
    v, u = np.mgrid[0:size, 0:size].astype(float)
    d = [(u - centre[0]) * np.sin(a) - (v - centre[1]) * np.cos(a) for a in angles]
    s = np.sqrt(2.0) * sigma
    return 0.5 + 0.4 * erf(d[0] / s) * erf(d[1] / s)


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

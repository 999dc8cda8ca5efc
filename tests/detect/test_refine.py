"""The re-centred saddle refinement (graphpose.detect.refine) and the fits it batches."""

import numpy as np
import pytest

from graphpose import FisheyeCamera
from graphpose.detect.refine import refine_junctions
from graphpose.detect.saddle import fit_quadrics_at, fit_quadrics_moments, quadric_monomials


def weighted_lstsq(v, W, x, y):
    """The weighted quadric fit by a plain least-squares solve: coefficients (6,)."""
    A = np.column_stack([x * x, x * y, y * y, x, y, np.ones_like(x)])
    s = np.sqrt(W)
    return np.linalg.lstsq(A * s[:, None], v * s, rcond=None)[0]


def test_fit_from_monomials_is_the_weighted_least_squares_fit():
    rng = np.random.default_rng(3)
    m, n = 5, 300
    x, y = rng.uniform(-9, 9, (m, n)), rng.uniform(-9, 9, (m, n))
    u0, v0 = rng.uniform(-2, 2, (2, m, 1))
    values = (x - u0) * (y - v0) + 0.3 * (x - u0) ** 2 + rng.normal(0, 0.5, (m, n))
    W = rng.uniform(0, 1, (m, n))
    points, saddle, rms = fit_quadrics_moments(quadric_monomials(x, y), values, W, 9.0)
    for i in range(m):
        a, b, g, d, e, z = weighted_lstsq(values[i], W[i], x[i], y[i])
        expected = np.linalg.solve([[2 * a, b], [b, 2 * g]], [-d, -e])
        assert np.allclose(points[:, i], expected, atol=1e-9)
        r = values[i] - (a * x[i] ** 2 + b * x[i] * y[i] + g * y[i] ** 2 + d * x[i] + e * y[i] + z)
        assert rms[i] == pytest.approx(np.sqrt(np.sum(W[i] * r * r) / W[i].sum()), rel=1e-6)
    assert saddle.all()
    # The (m, h, w) form places the same pixels the same way.
    at = fit_quadrics_at(values.reshape(m, 15, 20), W.reshape(m, 15, 20), x.reshape(m, 15, 20), y.reshape(m, 15, 20))
    assert np.allclose(at[0], points, atol=1e-12) and np.array_equal(at[1], saddle)


def test_a_point_whose_ray_is_past_90_degrees_is_untrusted_not_an_error():
    # A fisheye sees rays past 90 degrees off its axis, which have no undistorted (pinhole)
    # position: the fit through the lens cannot place them, and once raised on the NaN.
    camera = FisheyeCamera([[203.0, 0.0, 321.0], [0.0, 203.0, 241.0], [0.0, 0.0, 1.0]],
                           [-0.013, -0.004, 0.0035, -0.001], size=(640, 480))
    assert np.isnan(camera.undistort_pixels([[2.0], [241.0]])).all()
    image = np.random.default_rng(0).integers(0, 256, (480, 640)).astype(np.uint8)
    start = np.array([[2.0, 320.0], [241.0, 240.0]])
    points, trusted, residual = refine_junctions(image, start, 6.0, camera=camera)
    assert not trusted[0] and np.isnan(residual[0]) and np.array_equal(points[:, 0], start[:, 0])

"""graphpose.synth.raster: exact polygon areas per pixel (Green's theorem), the sparse entries
they are built from, and the blur-and-pixel kernel."""

import numpy as np
import pytest
from scipy.integrate import dblquad
from scipy.ndimage import correlate1d
from skimage.measure import points_in_poly

from graphpose.synth.raster import (
    coverage,
    coverage_entries,
    pixel_kernel,
    polygon_coverage,
    sum_upwards,
    x_pass,
)


def test_coverage_axis_aligned_square_is_exact():
    # x in [1.5, 4.25]: pixel 2 and 3 full, pixel 4 ([3.5, 4.5]) three quarters; y in [0.0, 2.5].
    P = np.array([[1.5, 4.25, 4.25, 1.5], [0.0, 0.0, 2.5, 2.5]])
    A = polygon_coverage(P, (7, 5))
    assert A.sum() == pytest.approx(2.75 * 2.5, abs=1e-12)
    assert np.allclose(A[1:3, 2:4], 1.0, atol=1e-12)
    assert A[0, 2] == pytest.approx(0.5, abs=1e-12)  # row 0 spans [-0.5, 0.5]: half covered
    assert A[1, 4] == pytest.approx(0.75, abs=1e-12)
    assert A[3, 2] == pytest.approx(0.0, abs=1e-12)  # row 3 spans [2.5, 3.5]: untouched
    assert np.allclose(polygon_coverage(P[:, ::-1], (7, 5)), A, atol=1e-12)  # orientation-free


def test_coverage_rotated_square_matches_area_and_brute_force():
    angle = 0.37
    R = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    P = np.array([[9.3], [8.1]]) + R @ np.array([[-5.0, 5.0, 5.0, -5.0], [-3.0, -3.0, 3.0, 3.0]])
    A = polygon_coverage(P, (20, 18))
    assert A.sum() == pytest.approx(60.0, abs=1e-10)
    assert A.min() >= -1e-12 and A.max() <= 1 + 1e-12
    n = 64  # n x n point samples per pixel: error <~ perimeter / n per pixel
    g = (np.arange(18 * n) + 0.5) / n - 0.5, (np.arange(20 * n) + 0.5) / n - 0.5
    V, U = np.meshgrid(*g, indexing="ij")
    inside = points_in_poly(np.c_[U.ravel(), V.ravel()], P.T).reshape(18, n, 20, n).mean(axis=(1, 3))
    assert np.abs(inside - A).max() < 2.0 / n


def test_coverage_clips_to_the_image():
    P = np.array([[-3.0, 2.0, 2.0, -3.0], [1.0, 1.0, 30.0, 30.0]])  # covers u in [-0.5, 2], v in [1, 9.5]
    A = polygon_coverage(P, (6, 10))
    assert A.sum() == pytest.approx(2.5 * 8.5, abs=1e-12)


def test_weighted_coverage_is_the_weighted_sum_of_coverages():
    A = np.array([[1.2, 6.7, 4.1], [0.4, 2.3, 7.9]])
    B = np.array([[2.0, 8.5, 8.5, 2.0], [3.0, 3.0, 6.5, 6.5]])
    both = coverage([A, B], 9, 10, [2.0, -0.5])
    np.testing.assert_allclose(both, 2.0 * coverage([A], 9, 10) - 0.5 * coverage([B], 9, 10), atol=1e-12)


def test_coverage_is_the_upward_sum_of_full_entries_plus_the_partial_ones():
    P = np.array([[1.3, 7.2, 5.5, 0.6], [0.7, 1.9, 8.4, 6.1]])
    (frow, fcol, fval), (prow, pcol, pval) = coverage_entries([P], 10, 9)
    full = np.zeros((10, 9))
    np.add.at(full, (frow, fcol), fval)
    full = np.cumsum(full[::-1], axis=0)[::-1]  # the plain way of sum_upwards
    part = np.zeros((10, 9))
    np.add.at(part, (prow, pcol), pval)
    np.testing.assert_allclose(full + part, coverage([P], 10, 9), atol=1e-12)
    assert (full + part).sum() == pytest.approx(abs(0.5 * (P[0] @ np.roll(P[1], -1) - np.roll(P[0], -1) @ P[1])),
                                                abs=1e-10)


def test_sum_upwards_is_a_reversed_cumulative_sum():
    a = np.random.default_rng(3).normal(size=(7, 4))
    expected = np.cumsum(a[::-1], axis=0)[::-1]
    sum_upwards(a)
    np.testing.assert_allclose(a, expected, atol=1e-12)


def test_pixel_kernel_without_blur_is_the_pixels_box():
    k = pixel_kernel(0.0, 4, 2)
    assert k.shape == (5, 4)
    np.testing.assert_allclose(k[2], 0.25, atol=1e-15)  # the pixel's own four fine cells, 1/4 each
    assert np.all(np.delete(k, 2, axis=0) == 0)


def test_pixel_kernel_keeps_total_grey_and_is_mirror_symmetric():
    k = pixel_kernel(0.8, 3, 6)  # reach 6 px > 7 sigma: nothing of the Gaussian left out
    assert k.sum() == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(k, k[::-1, ::-1], atol=1e-14)  # cell d mirrors cell -(d + 1); tails cancel to ~1e-16
    assert np.argmax(k) // 3 == 6  # the largest weight is in the pixel itself
    # k's definition integrated numerically: fine cell b = 1 of pixel p against pixel p.
    G = lambda y, x: np.exp(-0.5 * ((x - y) / 0.8) ** 2) / (0.8 * np.sqrt(2 * np.pi))  # noqa: E731
    assert k[6, 1] == pytest.approx(dblquad(G, 0.0, 1.0, 1.0 / 3, 2.0 / 3, epsabs=1e-13)[0], rel=1e-9)


def test_x_pass_equals_a_dense_correlation():
    # Sparse entries of a fine image (h rows, w * S columns), blurred and integrated along u,
    # against the same image made dense and correlated with the kernel's columns.
    h, w, S, reach = 6, 8, 3, 3
    rng = np.random.default_rng(5)
    row, col = rng.integers(0, h, 40), rng.integers(0, w * S, 40)
    values = rng.normal(size=40)
    k = pixel_kernel(0.7, S, reach)
    fine = np.zeros((h, w * S))
    np.add.at(fine, (row, col), values)
    dense = sum(correlate1d(fine[:, b::S], k[:, b], axis=1, mode="constant") for b in range(S))
    (out,) = x_pass(row, col, [values], k, S, h, w)
    np.testing.assert_allclose(out, dense, atol=1e-12)

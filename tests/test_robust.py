"""graphpose.robust: the Huber threshold and the sigma from residuals, one home for every solver."""

import numpy as np
import pytest

from graphpose.robust import HUBER_K, MAD_TO_SIGMA, mad_sigma


def test_mad_sigma_estimates_a_gaussian_sigma_and_ignores_a_few_gross_outliers():
    rng = np.random.default_rng(3)
    r = rng.normal(scale=0.25, size=(2, 20000))
    r[:, :200] = 50.0  # 1 % gross outliers move the median little
    assert mad_sigma(r, floor=1e-12) == pytest.approx(0.25, rel=0.03)


def test_mad_sigma_is_the_median_absolute_coordinate_times_1_4826():
    r = np.array([[0.1, -0.3, 0.2], [-0.5, 0.4, 7.0]])  # |r| sorted: .1 .2 .3 .4 .5 7 -> median .35
    assert mad_sigma(r, floor=1e-12) == 1.4826 * 0.35
    assert MAD_TO_SIGMA == 1.4826


def test_mad_sigma_stacks_a_sequence_of_views():
    a, b = np.array([[0.1, -0.2], [0.3, 0.4]]), np.array([[-0.9], [0.5]])
    assert mad_sigma([a, b], floor=1e-12) == mad_sigma(np.hstack([a, b]), floor=1e-12)


def test_mad_sigma_is_never_below_its_floor():
    assert mad_sigma(np.zeros((2, 5)), floor=1e-6) == 1e-6
    assert mad_sigma(np.zeros((2, 5)), floor=1e-12) == 1e-12


def test_huber_k_is_the_95_percent_efficiency_constant():
    assert HUBER_K == 1.345

"""graphpose.synth.information: the noise-free image's gradients and the junctions' Fisher
information."""

import numpy as np

from graphpose.board import Board
from graphpose.geometry import K_from_params, T_from_params
from graphpose.synth.information import image_gradients, junction_information
from graphpose.synth.render import render_ideal


def fronto(u0, v0, f=500.0, square_px=40.0, board=Board()):
    """K and T_WC of a fronto-parallel view putting junction 0 at (u0, v0), squares square_px wide
    (the twin of tests/synth/test_render.py's)."""
    Z = f * board.square_m / square_px
    return K_from_params(f, f, u0, v0), T_from_params([0.0, 0.0, -Z, 0.0, 0.0, 0.0])


def test_image_gradients_match_a_translated_camera():
    K, T = fronto(150.3, 100.6)
    gu, _ = image_gradients(K, T, gradient=0.0, delta=0.1)
    eps = 0.1 * -T[2, 3] / K[0, 0]  # metres; moving the camera by +x moves the image by -f x / Z
    Tp, Tm = T.copy(), T.copy()
    Tp[0, 3] += eps
    Tm[0, 3] -= eps
    d = (render_ideal(K, Tm, gradient=0.0) - render_ideal(K, Tp, gradient=0.0)) / 0.2
    assert np.abs(d - gu).max() < 1e-9 * np.abs(gu).max()


def test_image_gradients_match_the_analytic_edge_derivative():
    # Vertical edge at u = 150.3 (white left, black right, contrast 180): a shift of the
    # image by du changes pixel u by 180 * mean of the Gaussian over the pixel's span.
    K, T = fronto(150.3, 100.6)
    x = np.linspace(-0.5, 0.5, 4001)
    density = [np.mean(np.exp(-0.5 * (150.3 - u - x) ** 2)) / np.sqrt(2 * np.pi) for u in range(146, 155)]
    expected = 180 * np.array(density)
    for S, tol in ((4, 0.01), (8, 0.002)):
        gu, _ = image_gradients(K, T, gradient=0.0, supersample=S)
        assert np.abs(gu[108, 146:155] - expected).max() < tol * max(expected)


def test_junction_information_is_symmetric_and_scales_with_noise():
    K, T = fronto(150.5, 100.5)
    F1 = junction_information(K, T, noise_sigma=1.0, half_width=5, gradient=0.0)
    F2 = junction_information(K, T, noise_sigma=2.0, half_width=5, gradient=0.0)
    assert F1.shape == (48, 2, 2)
    assert np.allclose(F1, np.swapaxes(F1, 1, 2))
    assert np.all(np.linalg.eigvalsh(F1) > 0)
    assert np.allclose(F2, F1 / 4)
    # Fronto-parallel and axis-aligned: u and v are equally well determined.
    assert np.allclose(F1[:, 0, 0], F1[:, 1, 1], rtol=1e-6)

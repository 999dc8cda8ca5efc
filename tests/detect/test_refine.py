"""The re-centred saddle refinement (graphpose.detect.refine) and the fits it batches."""

import numpy as np
import pytest

from graphpose import Board, FisheyeCamera, extract_junctions
from graphpose.geometry import to_camera
from graphpose.detect.refine import refine_junctions
from graphpose.detect.saddle import fit_quadrics_at, fit_quadrics_moments, quadric_monomials
from graphpose.synth.calibration import fisheye_camera
from graphpose.synth.render import render


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


def test_a_point_whose_ray_is_past_90_degrees_is_refined_through_the_lens():
    # A fisheye sees rays past 90 degrees off its axis, which have no undistorted (pinhole)
    # position; the fit through the lens works in each patch's own frame (the pinhole
    # looking along the patch's ray), so it places them and refines them as any other.
    camera = FisheyeCamera([[203.0, 0.0, 321.0], [0.0, 203.0, 241.0], [0.0, 0.0, 1.0]],
                           [-0.013, -0.004, 0.0035, -0.001], size=(640, 480))
    assert np.isnan(camera.undistort_pixels([[2.0], [241.0]])).all()
    board = Board(4, 3, 0.03)
    # The board facing the camera's +x, its centre 93 degrees off the axis: its columns of
    # junctions lie at 86, 90.5, 95 and 100 degrees (the last two beyond the image's edge).
    R = np.column_stack([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])  # board axes in the camera
    t = 0.35 * np.array([np.sin(np.radians(93.0)), 0.0, np.cos(np.radians(93.0))]) - R @ board.world_points().mean(axis=1)
    T_WC = np.eye(4)
    T_WC[:3, :3], T_WC[:3, 3] = R.T, -R.T @ t
    rendering = render(camera, T_WC, board, noise_sigma=0.0, rng=0)
    P_C = to_camera(T_WC, board.world_points())
    past = np.degrees(np.arctan2(np.hypot(P_C[0], P_C[1]), P_C[2])) > 90.0
    in_image = rendering.junctions[0] < 630.0
    assert np.any(past & in_image)
    points, trusted, residual = refine_junctions(rendering.image, rendering.junctions + 0.4, 5.0, camera=camera)
    assert trusted[in_image].all() and not trusted[~in_image].any()
    assert np.all(np.hypot(*(points - rendering.junctions))[in_image] < 0.05)
    # On noise the fit there fails as anywhere: untrusted, no residual, no error.
    image = np.random.default_rng(0).integers(0, 256, (480, 640)).astype(np.uint8)
    start = np.array([[2.0, 320.0], [241.0, 240.0]])
    points, trusted, residual = refine_junctions(image, start, 6.0, camera=camera)
    assert not trusted[0] and np.isnan(residual[0])

def test_junctions_near_a_fisheyes_rim_are_refined_without_bias():
    # A noise-free board 30-82 degrees off the axis of the 185-degree fisheye of the
    # calibration sets: the fit in each patch's own frame finds every junction to a few
    # thousandths of a pixel. (In the camera's distortion-free image, stretched by
    # 1 / cos^2 of the field angle along the radius, 14 of the 48 were not trusted and the
    # others were off by up to 0.065 px.)
    camera = fisheye_camera()
    board = Board()
    W = board.world_points()
    ray = np.array([np.sin(np.radians(60.0)), 0.0, np.cos(np.radians(60.0))])
    z = np.array([np.sin(np.radians(40.0)), 0.0, np.cos(np.radians(40.0))])  # 20 degrees off the ray
    R = np.column_stack([np.cross([0.0, 1.0, 0.0], z), [0.0, 1.0, 0.0], z])
    T_WC = np.eye(4)
    T_WC[:3, :3], T_WC[:3, 3] = R.T, -R.T @ (0.45 * ray - R @ W.mean(axis=1))
    P_C = to_camera(T_WC, W)
    assert np.degrees(np.arctan2(np.hypot(P_C[0], P_C[1]), P_C[2])).max() > 80.0
    rendering = render(camera, T_WC, board, noise_sigma=0.0, rng=0)
    J = extract_junctions(rendering.image, None, board, camera=camera)
    assert J.trusted.all()
    assert np.max(np.hypot(*(J.points - rendering.junctions))) < 0.01

"""Tests of the lens geometry behind distorted renders: the cone a model images, and the board's
curved outlines traced as polylines (closed, on the rim where clipped, enclosing the exact area)."""

import numpy as np
import pytest

from graphpose import Board, FisheyeCamera, RadTanCamera
from graphpose.geometry import T_from_params, to_camera
from graphpose.synth.lens import FAR_DIAGONALS, in_view, region_edges, view_limit
from graphpose.synth.poses import random_pose

SIZE = (640, 480)
WIDE = RadTanCamera([[400.0, 0.0, 322.5], [0.0, 400.0, 238.3], [0.0, 0.0, 1.0]],
                    [-0.3, 0.1, 0.001, -0.0005, 0.0], size=SIZE)
FISHEYE = FisheyeCamera([[165.0, 0.0, 321.0], [0.0, 165.0, 241.0], [0.0, 0.0, 1.0]],
                        [-0.013, -0.004, 0.0035, -0.001], size=SIZE)
K = [[400.0, 0.0, 320.0], [0.0, 400.0, 240.0], [0.0, 0.0, 1.0]]
BIG = (-1e9, -1e9, 1e9, 1e9)  # a window that takes in every outline


def test_view_limit_of_each_model():
    # The fisheye: its own theta_max (112 degrees for this lens); without a fold, all but the
    # backward axis.
    assert view_limit(FISHEYE, SIZE) == FISHEYE.theta_max
    assert np.degrees(FISHEYE.theta_max) > 95
    assert view_limit(FisheyeCamera(K, [0.0] * 4), SIZE) == pytest.approx(np.pi - 1e-6, abs=1e-12)
    # Radial-tangential with a fold: r (1 + k1 r^2) stops growing at r^2 = -1 / (3 k1).
    assert view_limit(RadTanCamera(K, [-0.3, 0.0, 0.0, 0.0]), SIZE) == pytest.approx(np.arctan(np.sqrt(1 / 0.9)),
                                                                                   abs=1e-12)
    # The rational model's pole: r / (1 + k4 r^2) peaks at r^2 = 1 / k4.
    rational = RadTanCamera(K, [0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0])
    assert view_limit(rational, SIZE) == pytest.approx(np.arctan(np.sqrt(2.0)), abs=1e-12)
    # No fold: followed until the rim's radial image is FAR_DIAGONALS image diagonals (+ 50 px)
    # out (the tangential terms are left out of the limit).
    for camera in (WIDE, RadTanCamera(K, [0.0] * 4)):
        limit = view_limit(camera, SIZE)
        assert limit < np.pi / 2
        k1, k2 = camera.distortion[:2]
        r = np.tan(limit)
        assert camera.fx * r * (1 + k1 * r**2 + k2 * r**4) == pytest.approx(FAR_DIAGONALS * (np.hypot(*SIZE) + 50.0),
                                                                           rel=1e-9)


def test_view_limit_is_one_to_one_up_to_the_rim():
    # Along a radial line the image radius grows all the way to the limit, for every model.
    for camera in (WIDE, FISHEYE, RadTanCamera(K, [-0.3, 0.0, 0.0, 0.0]), RadTanCamera(K, [0.0] * 4)):
        theta = np.linspace(0.0, view_limit(camera, SIZE), 2001)
        for phi in (0.3, 2.0, 4.0):
            rays = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
            radius = np.hypot(*(camera.project(rays) - [[camera.cx], [camera.cy]]))
            assert np.all(np.diff(radius) > 0)


def _edges(camera, T, polygon, tol=1e-4):
    return region_edges(camera, T, [polygon], [1.0], BIG, tol, view_limit(camera, SIZE))[0]


def _closed(segments):
    """Each segment's start is some segment's end (the outlines close)."""
    starts = segments[:2].T[np.lexsort(segments[:2][::-1])]
    ends = segments[2:].T[np.lexsort(segments[2:][::-1])]
    return np.abs(starts - ends).max()


def _image_area(camera, T, x0, x1, y0, y1, n=24):
    """Area of the image of the target rectangle, px^2: the integral of |det d uv / d(x, y)|
    by Gauss-Legendre quadrature (independent of the polylines)."""
    t, w = np.polynomial.legendre.leggauss(n)
    x = 0.5 * (x1 + x0) + 0.5 * (x1 - x0) * t
    y = 0.5 * (y1 + y0) + 0.5 * (y1 - y0) * t
    X, Y = np.meshgrid(x, y)
    P_W = np.vstack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    _, J = camera.project_jacobian(to_camera(T, P_W))
    J = J @ T[:3, :3].T[:, :2]  # d uv / d(x_W, y_W)
    det = np.abs(J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0])
    return 0.25 * (x1 - x0) * (y1 - y0) * np.sum(np.outer(w, w).ravel() * det)


@pytest.mark.parametrize("camera, distance", [(WIDE, (0.5, 0.8)), (FISHEYE, (0.25, 0.4))])
def test_outlines_close_and_enclose_the_exact_area(camera, distance):
    board = Board()
    rng = np.random.default_rng(1)
    s = board.square_m
    for _ in range(2):
        T = random_pose(camera, board, distance=distance, rng=rng)
        for x0, y0, side in ((-s, -s, s), (3 * s, 2 * s, s), (-1.5 * s, -1.5 * s, 10 * s)):
            rect = np.array([[x0, x0 + side, x0 + side, x0], [y0, y0, y0 + side, y0 + side], [0.0] * 4])
            seg = _edges(camera, T, rect)
            assert _closed(seg) == 0.0  # chords share their end points exactly
            area = 0.5 * np.sum(seg[0] * seg[3] - seg[2] * seg[1])
            perimeter = np.sum(np.hypot(seg[2] - seg[0], seg[3] - seg[1]))
            exact = _image_area(camera, T, x0, x0 + side, y0, y0 + side)
            # Each chord cuts off at most 2/3 of its length times its sagitta (<= 1e-4 px).
            assert abs(area - exact) <= 1e-4 * perimeter
            # The straight quadrilateral of the projected corners misses by far more: the test
            # can tell a curved outline from a straight one.
            u, v = camera.project(to_camera(T, rect))
            straight = 0.5 * (np.dot(u, np.roll(v, -1)) - np.dot(np.roll(u, -1), v))
            assert abs(area - exact) < 0.02 * abs(straight - exact)


def test_outline_clipped_to_the_fisheye_rim():
    # A large sheet beside and behind a fisheye looking along it: part of it lies beyond
    # theta_max (112 degrees); the outline is the sheet's edges inside the cone plus the rim.
    T = T_from_params([0.4, 0.3, -0.15, 0.3, 1.9, 0.2])
    rect = np.array([[-0.5, 1.5, 1.5, -0.5], [-0.5, -0.5, 1.2, 1.2], [0.0] * 4])
    limit = view_limit(FISHEYE, SIZE)
    corners_C = to_camera(T, rect)
    assert not np.all(in_view(corners_C, limit)) and np.any(corners_C[2] < 0)
    seg = _edges(FISHEYE, T, rect)
    assert _closed(seg) < 1e-9
    k1, k2, k3, k4 = FISHEYE.distortion
    t = limit**2
    rim = FISHEYE.fx * limit * (1 + t * (k1 + t * (k2 + t * (k3 + t * k4))))
    radius = np.hypot(seg[0] - FISHEYE.cx, seg[1] - FISHEYE.cy)
    on_rim = np.abs(radius - rim) < 1e-9
    assert 10 < on_rim.sum() < seg.shape[1]
    assert np.all(radius <= rim + 1e-9)
    # Positive orientation, as the rasteriser needs: a positive enclosed area.
    assert 0.5 * np.sum(seg[0] * seg[3] - seg[2] * seg[1]) > 1000


def test_camera_behind_or_in_the_board_plane():
    rect = np.array([[0.0, 0.3, 0.3, 0.0], [0.0, 0.0, 0.2, 0.2], [0.0] * 4])
    front = T_from_params([0.15, 0.1, -0.5, 0.0, 0.0, 0.0])
    back = T_from_params([0.15, 0.1, 0.5, np.pi, 0.0, 0.0])  # behind the board, looking at it
    a_front = _edges(WIDE, front, rect)
    a_back = _edges(WIDE, back, rect)
    area = [0.5 * np.sum(s[0] * s[3] - s[2] * s[1]) for s in (a_front, a_back)]
    assert area[0] > 0 and area[1] > 0  # seen mirrored from behind, still positively oriented
    assert area[1] == pytest.approx(area[0], rel=1e-3)  # the same view, mirrored
    edge_on = T_from_params([0.15, 0.1, 0.0, 0.0, np.pi / 2, 0.0])
    assert _edges(WIDE, edge_on, rect).shape == (4, 0)

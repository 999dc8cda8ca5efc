"""graphpose.synth.rig: rendered views of a camera rig, with their truth."""

import numpy as np
import pytest

from graphpose import Board
from graphpose.camera_models import PinholeCamera
from graphpose.geometry import T_from_params, to_camera
from graphpose.rig import Rig
from graphpose.synth.render import render
from graphpose.synth.rig import RigViews, rig_views

BOARD = Board(5, 4, 0.05)  # a small board: a quick render


def _rig():
    """Two small pinhole cameras (quick to render), the second 12 cm along x of the first."""
    first = PinholeCamera([[265.0, 0.0, 161.5], [0.0, 264.0, 120.5], [0.0, 0.0, 1.0]], size=(320, 240))
    second = PinholeCamera([[272.5, 0.0, 159.0], [0.0, 271.8, 122.0], [0.0, 0.0, 1.0]], size=(320, 240))
    return Rig([first, second], [np.eye(4), T_from_params([0.12, 0.002, -0.003, 0.01, -0.03, 0.005])])


def _sheet_inside(camera, T):
    uv = camera.project(to_camera(T, BOARD.sheet_corners()))
    w, h = camera.size
    return bool(np.all((uv[0] > 8) & (uv[0] < w - 9) & (uv[1] > 8) & (uv[1] < h - 9)))


@pytest.fixture(scope="module")
def views():
    return rig_views(_rig(), 6, rng=3, board=BOARD, solo_every=3, noise_sigma=0.0)


def test_each_view_shows_its_anchor_and_the_solo_views_only_it(views):
    assert isinstance(views, RigViews) and len(views.poses) == len(views.images) == 6
    assert views.seen.shape == (6, 2)
    for k in range(6):
        anchor = k % 2
        assert views.seen[k, anchor]
        if k % 3 == 0:  # views 0 and 3: solo
            assert views.seen[k].sum() == 1
        else:  # the other camera shows it where the whole sheet is in its image
            other = 1 - anchor
            T = views.poses[k] @ views.rig.T_C0_C[other]
            assert views.seen[k, other] == _sheet_inside(views.rig.cameras[other], T)
    assert views.seen[[1, 2, 4, 5]].sum() >= 5  # the rig's cameras look the same way: mostly both see it


def test_the_images_are_the_cameras_renders_at_the_rig_pose(views):
    rig = views.rig
    for k, T_WC0 in enumerate(views.poses):
        for c, camera in enumerate(rig.cameras):
            T = T_WC0 @ rig.T_C0_C[c]
            image = views.images[k][c]
            assert image.shape == (240, 320) and image.dtype == np.uint8
            if views.seen[k, c]:
                assert _sheet_inside(camera, T)
                expected = render(camera, T, BOARD, noise_sigma=0.0, blur_sigma=1.0, rng=0).image
                np.testing.assert_array_equal(image, expected)
            else:  # blank: the noise's mean grey, with no board in it
                assert np.all(image == 128)


def test_a_seed_repeats_the_views():
    a = rig_views(_rig(), 2, rng=5, board=BOARD, solo_every=0)
    b = rig_views(_rig(), 2, rng=np.random.default_rng(5), board=BOARD, solo_every=0)
    np.testing.assert_array_equal(a.poses, b.poses)
    for x, y in zip(a.images, b.images):
        np.testing.assert_array_equal(x[1], y[1])

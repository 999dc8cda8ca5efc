"""graphpose.synth.scenes: a board scene with occluders and clutter, and which junctions show.

The truth is the scene's own (every painted shape is known): these tests hold the visible
mask, the image and the refusals to what the module's docstring promises.
"""

import numpy as np
import pytest

from graphpose import Board, InputError
from graphpose.synth.scenes import OCCLUDERS, Scene, _coverage, _visible, random_scene
from tests.conftest import PROJECT_K as K

SIZE = (320, 240)


def _scene(seed, **kwargs):
    return random_scene(K / [[2], [2], [1]], board=Board(), size=SIZE, rng=seed, noise_sigma=0.0, **kwargs)


def test_a_plain_scene_shows_every_junction_inside_the_image():
    scene = _scene(0)
    assert isinstance(scene, Scene) and scene.image.dtype == np.uint8 and scene.image.shape == (240, 320)
    assert scene.occluders == [] and scene.clutter == []
    u, v = scene.rendering.junctions
    inside = (u >= 2) & (v >= 2) & (u <= SIZE[0] - 3) & (v <= SIZE[1] - 3)
    # Without occluders a junction is visible exactly when it lies a third of its square
    # (at least 2 px, the module's floor) inside the image; a plain scene keeps them all inside.
    assert scene.visible.all() and inside.all()


def test_a_scene_is_the_seeds_own():
    a, b = _scene(3, occluders=("bar",), clutter=("text",)), _scene(3, occluders=("bar",), clutter=("text",))
    np.testing.assert_array_equal(a.image, b.image)
    np.testing.assert_array_equal(a.visible, b.visible)


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
@pytest.mark.parametrize("kind", ["bar", "blob", "reflection"])
def test_an_occluder_hides_the_junctions_under_it_and_only_those(kind):
    for seed in range(4):
        scene = _scene(seed, occluders=(kind,))
        plain = _scene(seed)
        assert scene.occluders == [kind]
        # The scene without the occluder: the same pose (drawn first), every junction visible.
        np.testing.assert_array_equal(scene.rendering.junctions, plain.rendering.junctions)
        # The occluder is centred on a junction, so it hides at least that one.
        assert (~scene.visible).sum() >= 1
        # A visible junction has no coverage over 0.02 within its reach, so its own pixel
        # changes by at most 0.02 x 255 (5 grey levels) and rounding.
        changed = np.abs(scene.image.astype(int) - plain.image.astype(int)) > 6
        for (u, v), seen in zip(scene.rendering.junctions.T, scene.visible):
            if seen:
                assert not changed[int(round(v)), int(round(u))]


def test_the_edge_occluder_cuts_the_board_with_the_image_edge():
    cut = 0
    for seed in range(4):
        scene = _scene(seed, occluders=("edge",))
        u, v = scene.rendering.junctions
        outside = (u < 0) | (v < 0) | (u > SIZE[0] - 1) | (v > SIZE[1] - 1)
        assert not scene.visible[outside].any()
        cut += int(outside.any())
    assert cut == 4  # the pose is slid so that the edge cuts the board, seed after seed


def _inside_convex(polygon, points):
    """Points (N, 2) strictly inside a convex polygon (2, 4), either winding."""
    P = polygon.T
    sides = []
    for a, b in zip(P, np.roll(P, -1, axis=0)):
        sides.append((b[0] - a[0]) * (points[:, 1] - a[1]) - (b[1] - a[1]) * (points[:, 0] - a[0]))
    sides = np.array(sides)
    return np.all(sides > 0, axis=0) | np.all(sides < 0, axis=0)


@pytest.mark.parametrize("kind", ["text", "grid"])
def test_clutter_keeps_off_the_sheet(kind):
    scene = _scene(1, clutter=(kind,))
    plain = _scene(1)
    assert scene.clutter == [kind]
    assert scene.visible.all()
    # The clutter is painted away from the sheet grown by 30 % about its centre: no pixel
    # inside the sheet's outline changes.
    changed = np.argwhere(np.abs(scene.image.astype(int) - plain.image.astype(int)) > 0)[:, ::-1]
    assert len(changed) > 0
    assert not _inside_convex(scene.rendering.outline, changed.astype(float)).any()


@pytest.mark.parametrize("kwargs, text", [
    ({"occluders": ("cloud",)}, "occluder kinds"),
    ({"clutter": ("logo",)}, "clutter kinds"),
    ({"vignetting": 2.0}, "vignetting"),
])
def test_an_unknown_kind_or_a_bad_argument_is_refused(kwargs, text):
    with pytest.raises(InputError, match=text):
        _scene(0, **kwargs)


def test_the_occluder_kinds_are_the_four_documented():
    assert OCCLUDERS == ("bar", "blob", "reflection", "edge")


def test_coverage_is_the_area_fraction_of_a_shape():
    # 4 x 4 subsamples at offsets -0.375, -0.125, 0.125, 0.375 of each pixel: exact fractions.
    cover = _coverage(lambda x, y: x < 9.5, 5, 20)
    np.testing.assert_array_equal(cover[:, :10], 1.0)
    np.testing.assert_array_equal(cover[:, 10:], 0.0)
    np.testing.assert_array_equal(_coverage(lambda x, y: x < 10.0, 5, 20)[:, 10], 0.5)
    np.testing.assert_array_equal(_coverage(lambda x, y: x < 10.2, 5, 20)[:, 10], 0.75)


def test_a_junction_near_a_covered_pixel_is_not_visible():
    scene = _scene(2)
    J = scene.rendering.junctions
    square = np.full(J.shape[1], 12.0)  # reach: a third, 4 px
    cover = np.zeros((SIZE[1], SIZE[0]))
    pixel = np.rint(J[:, 5])
    cover[int(pixel[1]), int(pixel[0])] = 1.0
    u, v = J
    inside = (u >= 4) & (v >= 4) & (u <= SIZE[0] - 5) & (v <= SIZE[1] - 5)
    expected = inside & (np.hypot(u - pixel[0], v - pixel[1]) > 4.0)
    np.testing.assert_array_equal(_visible(scene.rendering, cover, square), expected)
    assert not expected[5]

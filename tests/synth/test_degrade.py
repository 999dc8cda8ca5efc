"""Tests of the degraded renders: each degradation measured doing what it says, the truth unchanged."""

import numpy as np
import pytest

from graphpose.board import Board
from graphpose.geometry import T_from_params, project
from graphpose.detect.refine import refine_junctions
from graphpose.errors import InputError
from graphpose.synth import (
    Degradation,
    defocus,
    degrade,
    disc_kernel,
    jpeg_roundtrip,
    motion_blur_ideal,
    render_degraded,
    sensor_noise,
    vignette,
)
from graphpose.synth.poses import random_pose
from graphpose.synth.render import render, render_ideal
from tests.conftest import PROJECT_K as K

QUANTISATION = 1.0 / 12.0  # variance of rounding to whole grey levels


def flat(level, shape=(200, 200)):
    return np.full(shape, float(level))


def junction_error(image, truth, half_width=8):
    """Largest distance of the saddle fit, started at the truth, from the truth (px)."""
    points, trusted, _ = refine_junctions(image, truth, half_width)
    assert trusted.all()
    return float(np.hypot(*(points - truth)).max())


@pytest.fixture(scope="module")
def pose():
    return random_pose(K, Board(), distance=(0.9, 1.1), rng=np.random.default_rng(3))


def test_read_noise_alone_is_the_renderers_noise(pose):
    ours = render_degraded(K, pose, degradation=Degradation(noise_sigma=2.0), rng=7)
    theirs = render(K, pose, noise_sigma=2.0, rng=7)
    assert np.array_equal(ours.image, theirs.image) and ours.image.dtype == np.uint8
    assert np.array_equal(ours.junctions, theirs.junctions) and np.array_equal(ours.outline, theirs.outline)
    assert np.array_equal(ours.T_WC, pose) and ours.noise_sigma == 2.0


@pytest.mark.parametrize("sigma", [3.0, 16.0])
def test_gaussian_noise_of_a_flat_patch_has_its_sigma(sigma):
    out = degrade(flat(128.0), Degradation(noise_sigma=sigma), rng=1).astype(float)
    assert abs(out.std() - np.sqrt(sigma**2 + QUANTISATION)) < 0.02 * sigma
    assert abs(out.mean() - 128.0) < 0.2


def test_shot_noise_variance_grows_with_the_signal():
    gain, read = 0.5, 2.0
    for level in (40.0, 200.0):
        out = degrade(flat(level), Degradation(noise_sigma=read, shot_gain=gain), rng=2).astype(float)
        expected = gain * level + read**2 + QUANTISATION
        assert abs(out.var() / expected - 1.0) < 0.04, (level, out.var(), expected)
        assert abs(out.mean() - level) < 0.2
    # Poisson counts: without read noise every value is a whole number of electrons.
    raw = sensor_noise(flat(30.0), 0.0, 0.25, rng=3)
    assert np.allclose(raw / 0.25, np.rint(raw / 0.25))


def test_a_dark_image_with_gain_keeps_its_mean_and_amplifies_its_noise_in_coarse_steps():
    d = Degradation(noise_sigma=1.0, shot_gain=0.2, exposure=0.25)  # gain 4 by default
    out = degrade(flat(160.0), d, rng=4).astype(float)
    assert np.all(out % 4 == 0)  # 8-bit levels at the sensor, times 4
    assert abs(out.mean() - 160.0) < 0.3
    sensor = 0.2 * 40.0 + 1.0 + QUANTISATION
    assert abs(out.std() / (4.0 * np.sqrt(sensor)) - 1.0) < 0.03
    brighter = degrade(flat(160.0), Degradation(noise_sigma=1.0, shot_gain=0.2, exposure=0.25, gain=2.0), rng=4)
    assert abs(brighter.mean() - 80.0) < 0.3


@pytest.mark.parametrize("radius", [0.4, 1.0, 2.5, 4.0])
def test_disc_kernel_holds_the_discs_area_symmetrically(radius):
    raw = disc_kernel(radius, normalise=False)
    h = raw.shape[0] // 2
    assert raw.shape == (2 * h + 1, 2 * h + 1) and h == int(np.ceil(radius - 0.5))
    assert abs(raw.sum() / (np.pi * radius**2) - 1.0) < 1e-12
    for k in (raw[::-1], raw[:, ::-1], raw.T):
        assert np.allclose(k, raw, rtol=0, atol=1e-14)
    dv, du = np.mgrid[-h:h + 1, -h:h + 1]
    far = np.hypot(np.abs(du) + 0.5, np.abs(dv) + 0.5)  # the cell's farthest corner
    near = np.hypot(np.maximum(np.abs(du) - 0.5, 0), np.maximum(np.abs(dv) - 0.5, 0))
    assert np.allclose(raw[far <= radius], 1.0, atol=1e-12)  # cells inside the disc
    assert np.all(raw[near >= radius] == 0.0)                # cells outside it
    assert abs(disc_kernel(radius).sum() - 1.0) < 1e-12


def test_defocus_spreads_a_step_edge_over_the_discs_width_and_keeps_flat_areas():
    assert np.allclose(defocus(flat(90.0, (40, 40)), 3.0), 90.0)
    step = np.zeros((40, 40))
    step[:, 20:] = 100.0  # the edge at u = 19.5
    blurred = defocus(step, 3.0)
    row = blurred[20]
    assert np.allclose(row[:17], 0, atol=1e-9) and np.allclose(row[23:], 100) and np.all((row[17:23] > 0) & (row[17:23] < 100))
    # The fraction of the disc beyond the edge: 1/2 at the edge, by symmetry.
    assert abs(row[19] + row[20] - 100.0) < 1e-9
    assert np.array_equal(defocus(step, 0.0), step)


def test_motion_blur_of_a_fronto_parallel_board_is_a_box_along_the_motion():
    T = T_from_params([0.1, 0.1, -1.2, 0.0, 0.0, 0.0])  # camera 1.2 m in front, looking along +z
    sharp = render_ideal(K, T, gradient=0.0)
    blurred = motion_blur_ideal(K, T, motion_px=3.0, subframe_px=1.0, gradient=0.0)
    # Three sub-frames: the board's image shifted by -1, 0 and +1 px along u.
    box = (np.roll(sharp, -1, axis=1) + sharp + np.roll(sharp, 1, axis=1)) / 3.0
    assert np.abs(blurred[:, 2:-2] - box[:, 2:-2]).max() < 1e-6
    down = motion_blur_ideal(K, T, motion_px=2.0, angle_deg=90.0, subframe_px=1.0, gradient=0.0)
    expected = (np.roll(sharp, 1, axis=0) + sharp) / 2.0  # shifts of -0.5 and +0.5 px: not whole pixels
    assert np.abs(down - expected).max() > 1.0
    assert abs(down[:, 300:340].sum(axis=0).mean() - sharp[:, 300:340].sum(axis=0).mean()) < 0.2


@pytest.mark.parametrize("kind, tolerance", [("defocus 4", 0.002), ("gaussian 4", 0.002), ("motion 4", 0.015),
                                             ("vignetting 0.6", 0.03)])
@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_the_truth_is_where_a_saddle_fit_of_the_blurred_image_lands(pose, kind, tolerance):
    # Without the renderer's illumination gradient, whose slope biases a saddle fit under a wide
    # blur (0.026 px at blur 4), so that only the degradation is measured. Measured: defocus
    # 0.0005 px, Gaussian 0.0002 px; motion 0.008 px (the blur's length varies with depth across a
    # tilted board); vignetting 0.023 px (its slope, like the gradient's).
    truth = project(K, pose, Board().world_points())
    if kind == "defocus 4":
        image = defocus(render_ideal(K, pose, blur_sigma=0.5, gradient=0.0), 4.0)
    elif kind == "motion 4":
        image = motion_blur_ideal(K, pose, motion_px=4.0, angle_deg=35.0, blur_sigma=0.5, gradient=0.0)
    elif kind == "gaussian 4":
        image = render_ideal(K, pose, blur_sigma=4.0, gradient=0.0)
    else:
        image = vignette(render_ideal(K, pose, gradient=0.0), 0.6)
    assert junction_error(image, truth) < tolerance


def test_vignetting_follows_the_cos4_law():
    out = vignette(np.ones((101, 201)), 0.4)
    assert out[50, 100] == 1.0
    assert np.allclose([out[0, 0], out[0, 200], out[100, 0], out[100, 200]], 0.6)
    # cos^4 of the angle off the axis, with the f the corners imply
    f = np.hypot(100, 50) / np.sqrt(0.6 ** -0.5 - 1.0)
    assert np.isclose(out[50, 160], np.cos(np.arctan(60 / f)) ** 4)
    assert np.all(np.diff(out[50, 100:]) < 0)
    shifted = vignette(np.ones((101, 201)), 0.4, centre=(0, 0))
    assert shifted[0, 0] == 1.0 and np.isclose(shifted[100, 200], 0.6)


def test_jpeg_round_trip_differs_but_stays_close_and_keeps_the_junctions(pose):
    clean = render(K, pose, noise_sigma=0.0, blur_sigma=1.0)
    truth = clean.junctions
    errors = {}
    for quality in (50, 90):
        out = jpeg_roundtrip(clean.image, quality)
        assert out.dtype == np.uint8 and out.shape == clean.image.shape
        diff = np.abs(out.astype(float) - clean.image)
        assert diff.max() > 0
        errors[quality] = diff.mean()
        assert junction_error(out.astype(float), truth) < 0.1
    assert errors[90] < errors[50] < 2.0
    via = render_degraded(K, pose, degradation=Degradation(jpeg_quality=50), blur_sigma=1.0)
    assert np.array_equal(via.image, jpeg_roundtrip(clean.image, 50))


def test_low_contrast_levels_are_the_scenes(pose):
    r = render_degraded(K, pose, degradation=Degradation(noise_sigma=0.0), black=100.0, white=135.0,
                        background=118.0, gradient=0.0, blur_sigma=1.0)
    # The middle of the square to the right of the upper-left one, which is black.
    centre = project(K, pose, np.array([[0.5], [-0.5], [0.0]]) * Board().square_m)
    u, v = np.rint(centre[:, 0]).astype(int)
    assert r.image[v, u] == 135
    centre = project(K, pose, np.array([[-0.5], [-0.5], [0.0]]) * Board().square_m)
    u, v = np.rint(centre[:, 0]).astype(int)
    assert r.image[v, u] == 100  # the upper-left square is black
    assert r.image.min() >= 100 and r.image.max() <= 135


@pytest.mark.parametrize("field, value", [
    ("noise_sigma", -1.0), ("shot_gain", float("nan")), ("defocus_px", 17.0), ("motion_px", -0.5),
    ("motion_angle_deg", float("inf")), ("subframe_px", 0.0), ("vignetting", 1.0), ("exposure", 0.0),
    ("exposure", 1.5), ("gain", 0.0), ("jpeg_quality", 96), ("jpeg_quality", 0), ("jpeg_quality", 50.0),
])
def test_a_setting_out_of_range_is_refused_by_name(field, value):
    with pytest.raises(InputError, match=field):
        degrade(flat(10.0, (8, 8)), Degradation(**{field: value}))


def test_bad_inputs_are_refused(pose):
    with pytest.raises(InputError, match="Degradation"):
        render_degraded(K, pose, degradation={"noise_sigma": 2.0})
    with pytest.raises(InputError, match="uint8"):
        jpeg_roundtrip(flat(10.0, (8, 8)), 80)
    with pytest.raises(InputError, match="radius_px"):
        disc_kernel(0.0)
    with pytest.raises(InputError, match="corner_loss"):
        vignette(flat(1.0, (8, 8)), 1.0)
    with pytest.raises(InputError, match="motion_px"):
        motion_blur_ideal(K, pose, motion_px=20.0)

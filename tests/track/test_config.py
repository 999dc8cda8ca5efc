"""Tracker settings: graphpose.track.config (no GTSAM)."""

import numpy as np
import pytest

from graphpose import InputError
from graphpose.track.config import (
    DEFAULT_LAG_S,
    MOTION_MODELS,
    TARGET_FORMS,
    MotionPrior,
    TrackerConfig,
)


@pytest.mark.parametrize(
    "kwargs, message",
    [({"model": "teleport"}, "motion model"), ({"sigma_rot_rad": 0.0}, "sigma_rot_rad"),
     ({"sigma_trans_m": float("nan")}, "sigma_trans_m"), ({"sigma_trans_m": "1"}, "sigma_trans_m"),
     ({"huber": -1.0}, "huber")],
)
def test_motion_prior_rejects(kwargs, message):
    with pytest.raises(InputError, match=message):
        MotionPrior(**kwargs)


def test_motion_prior_sigmas_are_rotation_then_translation():
    prior = MotionPrior(sigma_rot_rad=0.002, sigma_trans_m=0.0003, huber=None)
    np.testing.assert_array_equal(prior.sigmas(), [0.002] * 3 + [0.0003] * 3)


def test_every_model_and_form_is_accepted():
    for model in MOTION_MODELS:
        for target in TARGET_FORMS:
            config = TrackerConfig(motion=MotionPrior(model), target=target)
            assert config.motion.model == model and config.target == target


@pytest.mark.parametrize(
    "kwargs, message",
    [({"motion": "constant_velocity"}, "motion must be a MotionPrior"), ({"target": "points"}, "target must be"),
     ({"min_junctions": 3}, "min_junctions"), ({"min_junctions": 12.0}, "min_junctions"),
     ({"min_junctions": True}, "min_junctions"),
     ({"min_detected_fraction": 1.5}, "min_detected_fraction"), ({"window_px": 5.0}, r"window_px must be \(low"),
     ({"window_px": (1.0, 2.0)}, r"window_px\[0\]"), ({"window_px": (5.0, 4.0)}, r"window_px\[1\]"),
     ({"gate_px": 0.0}, "gate_px"), ({"robust": "yes"}, "robust must be True or False"),
     ({"max_rms_px": -1.0}, "max_rms_px"), ({"max_speed": float("inf")}, "max_speed"),
     ({"min_pixel_sigma_px": None}, "min_pixel_sigma_px"), ({"rms_floor_px": -0.1}, "rms_floor_px")],
)
def test_tracker_config_rejects(kwargs, message):
    with pytest.raises(InputError, match=message):
        TrackerConfig(**kwargs)


def test_settings_load_no_gtsam():
    # The track command's parser reads MOTION_MODELS and TARGET_FORMS: building it (and reading
    # settings, results and frames) must not pay for GTSAM; only the back end imports it.
    import subprocess
    import sys

    code = ("import argparse, sys, graphpose.track.config, graphpose.track.results, graphpose.track.frames, "
            "graphpose.cli.track as t; t.add_parser(argparse.ArgumentParser().add_subparsers()); "
            "print('gtsam' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_lag_is_none_or_positive():
    assert TrackerConfig().lag_s == DEFAULT_LAG_S
    assert TrackerConfig(lag_s=None).lag_s is None
    for bad in (0.0, -1.0, float("inf"), "2"):
        with pytest.raises(InputError, match="lag_s"):
            TrackerConfig(lag_s=bad)


def test_shortest_and_default_lags_follow_the_frames_a_motion_factor_spans():
    from graphpose.track.config import DEFAULT_LAG_S, default_lag_s, shortest_lag_s

    t = np.arange(10) * 2.0  # a time-lapse: a frame every 2 s
    assert shortest_lag_s("constant_velocity", t) == 4.0 and shortest_lag_s("random_walk", t) == 2.0
    assert default_lag_s("constant_velocity", t) == 8.0 and default_lag_s("wnoa", t) == 4.0
    assert default_lag_s("constant_velocity", np.arange(10) / 30.0) == DEFAULT_LAG_S
    assert shortest_lag_s("constant_velocity", [0.0]) == 0.0

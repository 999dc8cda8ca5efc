"""The command line's JSON records (graphpose.io.records): keys, units, and what a failure writes."""

import json
from types import SimpleNamespace

import numpy as np

from graphpose import T_from_params, project
from graphpose.io.records import POSE_KEYS, result_record
from tests.conftest import BOARD_WPTS, PROJECT_K

KEYS = {"image", *POSE_KEYS, "converged", "iterations", "junctions", "trusted", "cross_check", "orientation_ambiguous",
        "junction0_square"}


def test_result_record_of_a_failure_and_of_an_estimate():
    record = result_record("a.png", None, "no board")
    assert KEYS <= set(record) and record["message"] == "no board" and record["T_WC"] is None
    T = T_from_params([0.1, 0.2, -1.0, 0.0, 0.0, np.pi / 2])
    estimate = SimpleNamespace(
        T_WC=T, converged=True, iterations=4,
        cov=np.diag(np.concatenate([[1e-3, 2e-3, 3e-3], np.radians([0.1, 0.2, 0.3])]) ** 2),
        rms_px=0.2, mask=np.array([True, False]),
        junctions=SimpleNamespace(points=np.array([[1.0, np.nan], [2.0, np.nan]]),
                                  trusted=np.array([True, False])),
        cross_check=SimpleNamespace(translation_m=1e-6, rotation_deg=1e-4, agree=np.True_))
    record = result_record("a.png", estimate)
    json.dumps(record, allow_nan=False)
    np.testing.assert_allclose(record["xyz_m"], [0.1, 0.2, -1.0])
    np.testing.assert_allclose(record["rpy_deg"], [0.0, 0.0, 90.0], atol=1e-12)
    np.testing.assert_allclose(record["sigma_xyz_m"], [1e-3, 2e-3, 3e-3])
    np.testing.assert_allclose(record["sigma_rpy_deg"], [0.1, 0.2, 0.3])
    assert record["junctions"] == [[1.0, None], [2.0, None]] and record["trusted"] == [True, False]
    assert record["cross_check"]["agree"] is True and record["message"] is None
    assert record["status"] == "ok" and record["junctions_used"] == 1


def test_an_estimate_from_points_has_no_junctions_to_write_or_report():
    from graphpose.cli.estimate import format_report
    from graphpose.estimate import estimate_pose_from_points

    K, W = PROJECT_K, BOARD_WPTS
    T = T_from_params([0.2, 0.15, -1.0, 0.1, -0.2, 0.3])
    mask = np.arange(48) != 7
    estimate = estimate_pose_from_points(project(K, T, W), W, K, mask=mask)
    assert estimate.junctions is None
    record = result_record("points", estimate)
    json.dumps(record, allow_nan=False)
    assert record["junctions"] is None and record["trusted"] == mask.tolist()
    np.testing.assert_allclose(record["xyz_m"], [0.2, 0.15, -1.0], atol=1e-9)
    report = format_report("points", estimate, record)
    assert "over 48 junctions, 47 trusted" in report and "converged" in report
    assert record["orientation_ambiguous"] is False and "orientation" not in report
    assert result_record("a.png", None, "no board")["orientation_ambiguous"] is None
    assert record["junction0_square"] is None  # no junctions: nothing was seen
    assert result_record("a.png", None, "no board")["junction0_square"] is None


def test_an_orientation_ambiguous_estimate_says_so_in_record_and_report():
    import dataclasses

    from graphpose.cli.estimate import ORIENTATION_AMBIGUOUS, format_report
    from graphpose.estimate import estimate_pose_from_points

    K, W = PROJECT_K, BOARD_WPTS
    T = T_from_params([0.2, 0.15, -1.0, 0.1, -0.2, 0.3])
    estimate = dataclasses.replace(estimate_pose_from_points(project(K, T, W), W, K), orientation_ambiguous=True)
    record = result_record("board.png", estimate)
    assert record["orientation_ambiguous"] is True
    report = format_report("board.png", estimate, record)
    assert ("orientation     " + ORIENTATION_AMBIGUOUS) in report
    assert ORIENTATION_AMBIGUOUS == ("orientation ambiguous (half-turn symmetric board, no bounds): junction 0 is "
                                     "the corner nearest the image's upper left")

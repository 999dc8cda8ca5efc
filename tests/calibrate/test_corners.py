"""Calibrating from junctions written and read back (graphpose.calibrate.calibrate_corners
through graphpose.io.corners, end to end), and single outliers. The file formats themselves
are tested in tests/io/test_corners.py."""

import numpy as np
import pytest

import graphpose
from graphpose import Board, InputError
from graphpose.calibrate import calibrate_corners
from graphpose.io.corners import read_corners, write_corners
from graphpose.synth.calibration import calibration_set, radtan_camera


@pytest.fixture(scope="module")
def calibrated():
    views = calibration_set(radtan_camera(), 10, rng=3)
    return views, graphpose.calibrate(views.images, model="radtan", names=[f"v{i}.png" for i in range(10)])


@pytest.mark.slow  # two whole calibrations of OpenCV's samples
def test_the_same_camera_from_the_written_corners(calibrated, tmp_path):
    views, c = calibrated
    path = tmp_path / "corners.vnl"
    write_corners(path, c.images, c.detections, Board(), size=c.camera.size)
    again = calibrate_corners(read_corners(path, Board()), "radtan", board=Board(), size=c.camera.size)
    assert again.ok and again.status == c.status
    assert all(m.startswith("junctions read from the corners") for m in again.message)
    # The same junctions: the same camera, to a hundredth of its sigmas (the Huber threshold
    # comes from a median of residuals reached by another path: Zhang's start, not the passes').
    assert np.all(np.abs(again.parameters - c.parameters) < 0.01 * c.sigmas)
    np.testing.assert_allclose(again.sigmas, c.sigmas, rtol=0.02)
    with pytest.raises(InputError, match="size"):
        calibrate_corners(read_corners(path, Board()), "radtan", board=Board())


@pytest.mark.slow  # 2.0 s or so on two idle cores: a render, a calibration or a subprocess
def test_single_outliers_are_left_out_and_named(calibrated):
    views, c = calibrated
    rng = np.random.default_rng(0)
    moved, junctions = [], []
    for k, (uv, index) in enumerate(c.detections):
        uv = uv.copy()
        pick = rng.choice(index.size, size=max(1, round(0.02 * index.size)), replace=False)
        angle = rng.uniform(0, 2 * np.pi, pick.size)
        uv[:, pick] += rng.uniform(2.0, 5.0, pick.size) * np.stack([np.cos(angle), np.sin(angle)])
        moved.append(set(index[pick].tolist()))
        junctions.append((uv, index))
    bad = calibrate_corners(junctions, "radtan", board=Board(), size=c.camera.size)
    assert bad.ok and bad.status.count("used") == 10
    for k in range(10):
        assert set(bad.outliers[k].tolist()) == moved[k]
        assert f"{len(moved[k])} junction" in bad.message[k]
    truth = views.camera
    w, h = truth.size
    u, v = np.meshgrid(np.arange(0, w, 40.0), np.arange(0, h, 40.0))
    q = np.stack([u.ravel(), v.ravel()])
    err = lambda cam: np.sqrt(np.mean(np.sum((cam.project(truth.unproject(q)) - q) ** 2, axis=0)))
    assert err(bad.camera) < 1.2 * err(c.camera) + 0.002
    z = (bad.parameters - truth.parameters) / bad.sigmas
    assert np.all(np.abs(z) < 3.0), z

"""graphpose calibrate --rig and graphpose estimate --rig on OpenCV's stereo pair."""

import json

import numpy as np
import pytest

from graphpose import read_camera
from graphpose.rig import Rig
from tests.cli.test_estimate import graphpose
from tests.conftest import OPENCV_DIR, opencv_file


@pytest.fixture(scope="module")
def rig_file(tmp_path_factory):
    # About 4 s: the 13 pairs calibrated once for the tests below.
    opencv_file("left01.jpg")
    out = tmp_path_factory.mktemp("rig")
    done = graphpose("calibrate", "--rig", OPENCV_DIR / "left*.jpg", OPENCV_DIR / "right*.jpg", "--board", "9x6x0.025",
                     "--out", out / "rig.yml", "--format", "opencv", "--json", out / "report.json", "--plot",
                     out / "rig.png")
    assert done.returncode == 0, done.stderr
    return out, done


@pytest.mark.slow  # a whole rig calibration through the CLI
def test_calibrate_rig_writes_the_rig_the_report_and_the_plot(rig_file):
    out, done = rig_file
    rig = read_camera(out / "rig.yml")
    assert isinstance(rig, Rig) and len(rig) == 2
    report = json.loads((out / "report.json").read_text())
    (ext,) = report["extrinsics"]
    # The baseline scales with the square: at 25 mm it is about 83 mm (mrcal's 83.1 mm, per the issue).
    assert 80.0 < ext["baseline_mm"] < 86.0 and 0 < ext["baseline_sigma_mm"] < 1.0
    assert 0.0 < ext["rotation_deg"] < 2.0 and 0 < ext["rotation_sigma_deg"] < 0.5
    assert np.allclose(ext["T_C0_C"], rig.T_C0_C[1], atol=1e-12)
    assert [c["name"] for c in report["cameras"]] == ["cam0", "cam1"] and report["cameras"][0]["rms_px"] < 0.5
    assert len(report["views"]) == 13 and report["views"][6]["view"] == "07"
    assert "baseline" in done.stdout and (out / "rig.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow  # 3.7 s or so on two idle cores: a render, a calibration or a subprocess
def test_estimate_rig_reports_camera_0s_pose(rig_file, tmp_path):
    out, _ = rig_file
    done = graphpose("estimate", "--camera", out / "rig.yml", "--rig", OPENCV_DIR / "left05.jpg",
                     OPENCV_DIR / "right05.jpg", "--board", "9x6x0.025", "--json", tmp_path / "pose.json")
    assert done.returncode == 0, done.stderr
    record = json.loads((tmp_path / "pose.json").read_text())
    assert record["pose_of"] == "cam0" and record["ok"] and [c["status"] for c in record["cameras"]] == ["used"] * 2
    assert 0.2 < np.linalg.norm(np.array(record["T_WC"])[:3, 3]) < 1.0


@pytest.mark.slow  # a rig calibration through the CLI
@pytest.mark.parametrize("args,fragment", [
    (["--camera", OPENCV_DIR / "left.opencv.yml"], "holds one camera, not a rig"),
    (["--camera", OPENCV_DIR / "camchain.kalibr.yaml"], "holds one camera, not a rig"),
])
def test_a_rig_file_with_one_camera_given_to_rig_is_an_error(args, fragment):
    opencv_file("left01.jpg")
    done = graphpose("estimate", *args, "--rig", OPENCV_DIR / "left05.jpg", OPENCV_DIR / "right05.jpg")
    assert done.returncode == 2 and fragment in done.stderr and len(done.stderr.strip().splitlines()) == 1


@pytest.mark.slow  # rig calibrations through the CLI
def test_rig_usage_errors(rig_file, tmp_path):
    out, _ = rig_file
    done = graphpose("estimate", "--camera", out / "rig.yml", "--rig", OPENCV_DIR / "left05.jpg")
    assert done.returncode == 2 and "one image per camera" in done.stderr
    done = graphpose("estimate", OPENCV_DIR / "left05.jpg", "--camera", out / "rig.yml")
    assert done.returncode == 2 and "--camera-name" in done.stderr
    done = graphpose("calibrate", "--rig", OPENCV_DIR / "left*.jpg", OPENCV_DIR / "right*.jpg", "--board", "9x6x0.025",
                     "--out", tmp_path / "r.yaml", "--format", "ros")
    assert done.returncode == 2 and "a rig is written as json, opencv, kalibr" in done.stderr


@pytest.mark.slow  # tracks a rendered rig sequence through the CLI
def test_track_rig_writes_camera_0s_poses_frame_by_frame(rig_file, tmp_path):
    out, _ = rig_file
    done = graphpose("track", "--camera", out / "rig.yml", "--rig", OPENCV_DIR / "left0[1-4].jpg",
                     OPENCV_DIR / "right0[1-4].jpg", "--board", "9x6x0.025", "--tum", tmp_path / "rig.tum", "--json",
                     tmp_path / "rig.json")
    assert done.returncode == 0, done.stderr
    lines = [line for line in (tmp_path / "rig.tum").read_text().splitlines() if not line.startswith("#")]
    doc = json.loads((tmp_path / "rig.json").read_text())
    assert len(lines) == 4 and doc["pose_of"] == "cam0" and [f["status"] for f in doc["frames"]] == ["ok"] * 4
    assert np.allclose([float(v) for v in lines[0].split()[1:4]], np.array(doc["frames"][0]["T_WC"])[:3, 3], atol=1e-8)
    done = graphpose("track", "--camera", out / "rig.yml", "--rig", OPENCV_DIR / "left01.jpg", OPENCV_DIR / "right01.jpg",
                     "--smooth")
    assert done.returncode == 2 and "not available with --rig" in done.stderr

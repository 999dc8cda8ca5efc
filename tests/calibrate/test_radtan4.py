"""``radtan4``: the radial-tangential camera with k3 held at 0 (Kalibr's pinhole-radtan), in the
library and through ``graphpose calibrate --model radtan4 --format kalibr`` (issue 26)."""

import numpy as np
import pytest

from graphpose import read_camera
from graphpose.camera_models import RadTanCamera
from graphpose.camera_models import calibration_model
from graphpose.cli import main
from graphpose.io.files import write_png
from graphpose.synth.calibration import calibration_set

#: A Kalibr-style camera: four coefficients, k3 = 0.
TRUTH = RadTanCamera([[530.0, 0.0, 322.5], [0.0, 528.0, 241.0], [0.0, 0.0, 1.0]],
                     [-0.28, 0.09, 0.0008, -0.0005], size=(640, 480))


@pytest.fixture(scope="module")
def views(tmp_path_factory):
    folder = tmp_path_factory.mktemp("radtan4")
    for k, image in enumerate(calibration_set(TRUTH, 6, rng=7).images):
        write_png(folder / f"view_{k:02d}.png", image)
    return folder


def test_calibration_model_names_what_radtan4_holds():
    cls, held = calibration_model("radtan4")
    assert cls is RadTanCamera
    assert [n for n, h in zip(cls.parameter_names, held) if h] == ["k3"]
    assert not np.any(calibration_model("radtan")[1])


@pytest.mark.slow  # a whole calibration through the CLI
def test_radtan4_through_the_command_line_writes_a_kalibr_camchain_read_back(views, tmp_path, capsys):
    out = tmp_path / "camchain.yaml"
    code = main(["calibrate", str(views), "--board", "8x6x63.5mm", "--model", "radtan4",
                 "--out", str(out), "--format", "kalibr", "--json", str(tmp_path / "report.json")])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "distortion_model: radtan" in out.read_text()
    camera = read_camera(out)
    assert isinstance(camera, RadTanCamera) and camera.distortion.size == 4 and camera.size == (640, 480)
    np.testing.assert_allclose([camera.fx, camera.fy, camera.cx, camera.cy], [530.0, 528.0, 322.5, 241.0], atol=0.5)
    np.testing.assert_allclose(camera.distortion, TRUTH.distortion, atol=2e-3)
    # The report: k3 exactly 0 with no variance; the other parameters estimated.
    import json

    report = json.loads((tmp_path / "report.json").read_text())
    assert report["parameters"]["k3"] == 0.0
    cov = np.array(report["covariance"])
    assert np.all(cov[8] == 0.0) and np.all(cov[:, 8] == 0.0) and np.all(np.diag(cov)[:8] > 0)
    assert "k3" in captured.out


@pytest.mark.slow  # 0.9 s or so on two idle cores: a render, a calibration or a subprocess
def test_kalibr_still_refuses_the_five_coefficient_radtan_and_names_radtan4(views, tmp_path, capsys):
    assert main(["calibrate", str(views), "--board", "8x6x0.0635", "--model", "radtan",
                 "--out", str(tmp_path / "c.yaml"), "--format", "kalibr"]) == 2
    assert "--model radtan4" in capsys.readouterr().err

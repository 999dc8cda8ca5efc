"""Calibration files out: every model in every format, read back to 1e-12, and the refusals."""

import json

import numpy as np
import pytest
import yaml

from graphpose import InputError
from graphpose.camera_models import FisheyeCamera, PinholeCamera, RadTanCamera
from graphpose.io.cameras import read_camera, write_camera
from graphpose.io.cameras import FORMATS, covariance_note

K = [[533.51234567891, 0.0, 341.6000001], [0.0, 533.4987654321, 235.2], [0.0, 0.0, 1.0]]
K_SKEW = [[500.1, 1.5, 320.3], [0.0, 510.7, 240.1], [0.0, 0.0, 1.0]]
RATIONAL = [2.5, 1.2, 0.0005, -0.0004, 0.05, 2.8, 2.0, 0.3]

#: One camera of every model and coefficient count, each with numbers that need all 17 digits.
CAMERAS = {
    "pinhole": PinholeCamera(K, (640, 480)),
    "pinhole_skew": PinholeCamera(K_SKEW, (640, 480)),
    "radtan4": RadTanCamera(K, [-0.2881234567, 0.0971, 1e-5, -3.3e-4], (640, 480)),
    "radtan5": RadTanCamera(K, [-0.2881234567, 0.0971, 1e-5, -3.3e-4, 0.0123], (640, 480)),
    "radtan5_k3_zero": RadTanCamera(K, [-0.2881234567, 0.0971, 1e-5, -3.3e-4, 0.0], (640, 480)),
    "rational": RadTanCamera(K, RATIONAL, (640, 480)),
    "fisheye": FisheyeCamera([[300.1, 0.0, 640.2], [0.0, 310.3, 480.4], [0.0, 0.0, 1.0]],
                             [-0.013, -0.004, 0.0035, -1e-3 / 3], (1280, 960)),
    "fisheye_skew": FisheyeCamera([[300.1, 0.9, 640.2], [0.0, 310.3, 480.4], [0.0, 0.0, 1.0]],
                                  [-0.013, -0.004, 0.0035, -1e-3 / 3], (1280, 960)),
}

#: What each format cannot hold, with the refusal's message.
REFUSED = {
    ("pinhole_skew", "kalibr"): r"Kalibr's intrinsics \[fu, fv, pu, pv\] have no skew, and K\[0, 1\] is 1.5",
    ("fisheye_skew", "kalibr"): r"no skew, and K\[0, 1\] is 0.9",
    ("radtan5", "kalibr"): r"Kalibr's radtan model has four coefficients .* k3..k6 are \[0.0123\], not zero; "
                           r"a coefficient is never dropped",
    ("rational", "kalibr"): r"k3..k6 are \[0.05, 2.8, 2.0, 0.3\], not zero",
}

CASES = [(c, f) for c in CAMERAS for f in FORMATS]


@pytest.mark.parametrize("which, fmt", [case for case in CASES if case not in REFUSED])
def test_every_model_in_every_format_reads_back(tmp_path, which, fmt):
    camera = CAMERAS[which]
    path = tmp_path / f"camera.{fmt}"
    write_camera(path, camera, format=fmt)
    back = read_camera(path)
    assert type(back) is type(camera)
    np.testing.assert_allclose(back.K, camera.K, rtol=1e-12, atol=0)
    full = lambda c: getattr(c, "coefficients", c.distortion)  # noqa: E731  (4 and 5 with k3 = 0 alike)
    np.testing.assert_allclose(full(back), full(camera), rtol=1e-12, atol=0)
    assert back.size == camera.size
    assert back == camera  # repr floats: in fact to the last bit


@pytest.mark.parametrize("which, fmt", list(REFUSED))
def test_what_a_format_cannot_hold_is_refused(tmp_path, which, fmt):
    path = tmp_path / "camera.yaml"
    with pytest.raises(InputError, match=REFUSED[(which, fmt)]):
        write_camera(path, CAMERAS[which], format=fmt)
    assert not path.exists()


def test_kalibr_needs_the_size_and_other_refusals(tmp_path):
    with pytest.raises(InputError, match=r"needs the image size \(resolution\), and the camera has none"):
        write_camera(tmp_path / "k.yaml", PinholeCamera(K), format="kalibr")
    with pytest.raises(InputError, match=r"unknown calibration file format 'matlab'; graphpose writes "
                                         r"json, opencv, ros, kalibr"):
        write_camera(tmp_path / "m.yaml", PinholeCamera(K), format="matlab")
    with pytest.raises(InputError, match=r"holds one camera and no name: name='left'"):
        write_camera(tmp_path / "o.yaml", PinholeCamera(K), format="opencv", name="left")
    with pytest.raises(InputError, match="cannot write"):
        write_camera(tmp_path / "no" / "such.yaml", PinholeCamera(K), format="ros")


def test_names_and_unknown_sizes(tmp_path):
    camera = CAMERAS["radtan4"]
    write_camera(tmp_path / "chain.yaml", camera, format="kalibr", name="cam1")
    assert read_camera(tmp_path / "chain.yaml", "cam1") == camera
    write_camera(tmp_path / "ros.yaml", camera, format="ros", name="left: 1")
    assert read_camera(tmp_path / "ros.yaml", "left: 1") == camera
    assert yaml.safe_load((tmp_path / "ros.yaml").read_text())["camera_name"] == "left: 1"
    nosize = RadTanCamera(K, RATIONAL)
    for fmt in ("json", "opencv", "ros"):
        write_camera(tmp_path / f"n.{fmt}", nosize, format=fmt)
        assert read_camera(tmp_path / f"n.{fmt}") == nosize


def test_ros_file_is_what_ros_tools_expect(tmp_path):
    camera = CAMERAS["rational"]
    write_camera(tmp_path / "ros.yaml", camera, format="ros", name="left")
    doc = yaml.safe_load((tmp_path / "ros.yaml").read_text())
    assert doc["distortion_model"] == "rational_polynomial"
    assert (doc["image_width"], doc["image_height"]) == (640, 480)
    np.testing.assert_array_equal(np.reshape(doc["rectification_matrix"]["data"], (3, 3)), np.eye(3))
    P = np.reshape(doc["projection_matrix"]["data"], (3, 4))
    np.testing.assert_array_equal(P[:, :3], camera.K)
    np.testing.assert_array_equal(P[:, 3], 0.0)
    for which, model in (("fisheye", "equidistant"), ("radtan5", "plumb_bob"), ("pinhole", "plumb_bob")):
        write_camera(tmp_path / "m.yaml", CAMERAS[which], format="ros")
        assert yaml.safe_load((tmp_path / "m.yaml").read_text())["distortion_model"] == model


@pytest.mark.parametrize("which", list(CAMERAS))
def test_opencv_file_is_read_by_cv_filestorage(tmp_path, which):
    cv2 = pytest.importorskip("cv2")
    camera = CAMERAS[which]
    path = tmp_path / "camera.yml"
    write_camera(path, camera, format="opencv")
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        assert fs.isOpened()
        np.testing.assert_array_equal(fs.getNode("camera_matrix").mat(), camera.K)
        d = fs.getNode("distortion_coefficients").mat()
        if camera.distortion.size:
            np.testing.assert_array_equal(d.ravel(), camera.distortion)
        else:
            assert d is None or d.size == 0  # OpenCV's empty Mat: no distortion
        assert int(fs.getNode("fisheye_model").real()) == (camera.model == "fisheye")
        size = (int(fs.getNode("image_width").real()), int(fs.getNode("image_height").real()))
        assert size == camera.size
    finally:
        fs.release()


def test_opencv_round_trip_of_an_opencv_written_file(tmp_path):
    # OpenCV reads ours (above); ours read back by OpenCV and written again by it reads the same.
    cv2 = pytest.importorskip("cv2")
    camera = CAMERAS["radtan5"]
    write_camera(tmp_path / "ours.yml", camera, format="opencv")
    src = cv2.FileStorage(str(tmp_path / "ours.yml"), cv2.FILE_STORAGE_READ)
    out = cv2.FileStorage(str(tmp_path / "theirs.yml"), cv2.FILE_STORAGE_WRITE)
    for key in ("image_width", "image_height", "fisheye_model"):
        out.write(key, int(src.getNode(key).real()))
    for key in ("camera_matrix", "distortion_coefficients"):
        out.write(key, src.getNode(key).mat())
    src.release()
    out.release()
    assert read_camera(tmp_path / "theirs.yml") == camera


def test_covariance_note_only_where_it_is_lost():
    assert covariance_note(CAMERAS["radtan4"], "opencv") is None  # no covariance to lose


# ---- the covariance: kept by the JSON file -----------------------------------------------
def _with_covariance(camera, rng):
    A = rng.normal(size=(len(camera.parameter_names),) * 2) * 1e-3
    return camera.with_parameters(camera.parameters, A @ A.T)


@pytest.mark.parametrize("which", ["pinhole", "radtan4", "radtan5", "rational", "fisheye"])
def test_json_keeps_parameters_and_covariance(tmp_path, which):
    camera = _with_covariance(CAMERAS[which], np.random.default_rng(3))
    path = tmp_path / "camera.json"
    write_camera(path, camera)
    doc = json.loads(path.read_text())
    assert list(doc["parameters"]) == list(camera.parameter_names)
    np.testing.assert_array_equal(list(doc["parameters"].values()), camera.parameters)
    back = read_camera(path)
    assert back == camera and type(back) is type(camera)
    np.testing.assert_array_equal(back.covariance, camera.covariance)  # repr floats: to the bit
    for fmt in ("opencv", "ros"):
        write_camera(tmp_path / f"c.{fmt}", camera, format=fmt)
        other = read_camera(tmp_path / f"c.{fmt}")
        assert other == camera and other.covariance is None
        assert "no place for the intrinsics' covariance" in covariance_note(camera, fmt)
    assert covariance_note(camera, "json") is None


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.pop("parameters"), r"a covariance needs 'parameters', the mapping of the radtan camera's fx"),
    (lambda d: d.update(parameters=dict(reversed(list(d["parameters"].items())))),
     r"parameters must be fx, fy, cx, cy, k1, k2, p1, p2, k3 \(a radtan camera's, in this order\), got k3"),
    (lambda d: d["parameters"].update(fx=d["parameters"]["fx"] + 1e-6), r"disagree with K and distortion"),
    (lambda d: d.update(covariance=d["covariance"][:3]), r"covariance must hold 81 numbers"),
    (lambda d: d["covariance"][0].__setitem__(1, 1.0), r"covariance"),
])
def test_json_covariance_errors(tmp_path, edit, message):
    camera = _with_covariance(CAMERAS["radtan5"], np.random.default_rng(4))
    path = tmp_path / "camera.json"
    write_camera(path, camera)
    doc = json.loads(path.read_text())
    edit(doc)
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=message):
        read_camera(path)

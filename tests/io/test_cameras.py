"""graphpose.io.cameras: calibration files (OpenCV FileStorage YAML/XML, ROS camera_info, Kalibr
camchain, JSON) read as their writers mean them; every model in every format written and read
back to 1e-12; the refusals."""

import json
import os

import numpy as np
import pytest
import yaml

from graphpose import InputError
from graphpose.camera_models import (
    FisheyeCamera,
    PinholeCamera,
    RadTanCamera,
    check_image_size,
)
from graphpose.io.cameras import (
    FORMATS,
    camera_from_dict,
    camera_to_dict,
    covariance_note,
    read_camera,
    write_camera,
)
from tests.conftest import OPENCV_DIR as SAMPLES


K_FISHEYE = [[300.0, 0.9, 640.0], [0.0, 310.0, 512.0], [0.0, 0.0, 1.0]]
FISHEYE = [-0.013, -0.004, 0.0035, -0.001]
K = [[533.5, 0.0, 341.6], [0.0, 533.5, 235.2], [0.0, 0.0, 1.0]]
RATIONAL = [2.5, 1.2, 0.0005, -0.0004, 0.05, 2.8, 2.0, 0.3]


def sample(name):
    """A file of the OpenCV samples folder; skipped when absent (failed under
    GRAPHPOSE_REQUIRE_REAL=1)."""
    path = SAMPLES / name
    if not path.is_file():
        if os.environ.get("GRAPHPOSE_REQUIRE_REAL") == "1":
            pytest.fail(f"{path} is absent and GRAPHPOSE_REQUIRE_REAL=1")
        pytest.skip(f"{path} is absent")
    return path


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def opencv_file(tmp_path, name, **entries):
    """A file written by OpenCV's own cv::FileStorage (YAML or XML by the name)."""
    cv2 = pytest.importorskip("cv2")
    path = tmp_path / name
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for key, value in entries.items():
        fs.write(key, value)
    fs.release()
    return path


# ---- the samples: every file of one camera reads to the same model -------------------------
@pytest.mark.parametrize("files", [
    [("left.opencv.yml", None), ("left.ros.yaml", None), ("camchain.kalibr.yaml", None),
     ("left.ros.yaml", "left"), ("camchain.kalibr.yaml", "cam0")],
    [("right.opencv.xml", None), ("right.ros.yaml", None), ("camchain.kalibr.yaml", "cam1")],
])
def test_sample_files_read_to_the_same_camera(files):
    cams = [read_camera(sample(name), camera) for name, camera in files]
    assert all(isinstance(c, RadTanCamera) for c in cams)
    assert all(c == cams[0] for c in cams)  # same K, coefficients (k3 = 0 or absent), size
    assert cams[0].size == (640, 480)


@pytest.mark.parametrize("name", ["left.opencv.yml", "right.opencv.xml"])
def test_sample_opencv_files_read_as_opencv_reads_them(name):
    cv2 = pytest.importorskip("cv2")
    path = sample(name)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    K_cv = fs.getNode("camera_matrix").mat()
    d_cv = fs.getNode("distortion_coefficients").mat().ravel()
    size = (int(fs.getNode("image_width").real()), int(fs.getNode("image_height").real()))
    fs.release()
    camera = read_camera(path)
    np.testing.assert_array_equal(camera.K, K_cv)
    np.testing.assert_array_equal(camera.distortion, d_cv)
    assert camera.size == size


def test_sample_image_fits_its_calibration_and_another_size_is_refused():
    from graphpose.image import read_image

    camera = read_camera(sample("left.ros.yaml"))
    image = read_image(sample("left01.jpg"))
    check_image_size(camera, image.shape, what="left01.jpg")
    with pytest.raises(InputError, match=r"half.png is 320 x 240 pixels but the camera is "
                                         r"calibrated for 640 x 480"):
        check_image_size(camera, image[::2, ::2], what="half.png")


# ---- OpenCV FileStorage as OpenCV writes it ---------------------------------------------------
@pytest.mark.parametrize("suffix", ["yml", "xml"])
def test_opencv_written_fisheye_calibration(tmp_path, suffix):
    # The keys OpenCV's calibration sample writes, with its fisheye flag.
    path = opencv_file(
        tmp_path, f"fisheye.{suffix}", calibration_time="Thu 01 Jan 2024", image_width=1280,
        image_height=1024, flags=2048, fisheye_model=1, camera_matrix=np.array(K_FISHEYE),
        distortion_coefficients=np.array(FISHEYE).reshape(4, 1), avg_reprojection_error=0.21,
        image_points=np.zeros((3, 1, 2), np.float32))
    assert read_camera(path) == FisheyeCamera(K_FISHEYE, FISHEYE, (1280, 1024))


@pytest.mark.parametrize("suffix", ["yml", "xml"])
@pytest.mark.parametrize("coefficients", [[-0.2, 0.05, 0.001, 0.002], [-0.2, 0.05, 0.001, 0.002, -0.01],
                                          RATIONAL, RATIONAL + [0.0] * 6])
def test_opencv_written_radtan_calibrations(tmp_path, suffix, coefficients):
    path = opencv_file(tmp_path, f"cam.{suffix}", camera_matrix=np.array(K),
                       distortion_coefficients=np.array([coefficients]))
    camera = read_camera(path)
    # 14 coefficients whose thin-prism and tilt terms are zero are the rational model.
    assert camera == RadTanCamera(K, coefficients[:8])
    assert camera.size is None


def test_opencv_yaml_with_the_old_header(tmp_path):
    text = sample("left.opencv.yml").read_text()
    assert text.startswith("%YAML:1.0")
    assert read_camera(write(tmp_path, "a.yaml", text)) == read_camera(sample("left.ros.yaml"))


# ---- ROS and Kalibr ------------------------------------------------------------------------
def ros_text(model, coefficients, K=K, size=(640, 480)):
    return yaml.safe_dump({
        "image_width": size[0], "image_height": size[1], "camera_name": "cam",
        "camera_matrix": {"rows": 3, "cols": 3, "data": np.ravel(K).tolist()},
        "distortion_model": model,
        "distortion_coefficients": {"rows": 1, "cols": len(coefficients), "data": coefficients},
    })


@pytest.mark.parametrize("model, coefficients, expected", [
    ("rational_polynomial", RATIONAL, RadTanCamera(K, RATIONAL, (640, 480))),
    ("equidistant", FISHEYE, FisheyeCamera(K, FISHEYE, (640, 480))),
    ("plumb_bob", RATIONAL[:5], RadTanCamera(K, RATIONAL[:5], (640, 480))),
])
def test_ros_models(tmp_path, model, coefficients, expected):
    assert read_camera(write(tmp_path, "c.yaml", ros_text(model, coefficients))) == expected


def kalibr_text(drop=(), **cam0):
    """A camchain: cam0 a fisheye changed by ``cam0`` and without the keys ``drop``, cam1 a
    pinhole without distortion."""
    base = {"camera_model": "pinhole", "intrinsics": [533.5, 533.5, 341.6, 235.2],
            "distortion_model": "equidistant", "distortion_coeffs": FISHEYE,
            "resolution": [640, 480], "rostopic": "/cam0/image_raw"}
    first = {k: v for k, v in {**base, **cam0}.items() if k not in drop}
    return yaml.safe_dump({"cam0": first, "cam1": {**base, "distortion_model": "none"}})


def test_kalibr_models_and_names(tmp_path):
    path = write(tmp_path, "camchain.yaml", kalibr_text())
    assert read_camera(path) == FisheyeCamera(K, FISHEYE, (640, 480))
    assert read_camera(path, "cam1") == PinholeCamera(K, (640, 480))
    radtan = write(tmp_path, "radtan.yaml", kalibr_text(distortion_model="radtan"))
    assert read_camera(radtan) == RadTanCamera(K, FISHEYE, (640, 480))


# ---- graphpose's JSON ----------------------------------------------------------------------
@pytest.mark.parametrize("camera", [
    PinholeCamera([[500.0, 1.5, 320.0], [0.0, 510.0, 240.0], [0, 0, 1]]),
    RadTanCamera(K, RATIONAL, (640, 480)),
    RadTanCamera(K, RATIONAL[:4], (640, 480)),
    FisheyeCamera(K_FISHEYE, FISHEYE, (1280, 1024)),
])
def test_json_round_trip(tmp_path, camera):
    path = tmp_path / "camera.json"
    write_camera(path, camera)
    back = read_camera(path)
    assert back == camera and back.distortion.size == camera.distortion.size
    assert camera_from_dict(camera_to_dict(camera)) == camera


def test_write_camera_takes_a_K(tmp_path):
    write_camera(tmp_path / "k.json", K)
    assert read_camera(tmp_path / "k.json") == PinholeCamera(K)


# ---- every error once ------------------------------------------------------------------------
OPENCV_YAML = """%YAML:1.0
---
image_width: 640
image_height: 480
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 533.5, 0., 341.6, 0., 533.5, 235.2, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 1
   cols: {n}
   dt: d
   data: [ {data} ]
"""


def opencv_yaml(data, n=None):
    return OPENCV_YAML.format(n=len(data.split(",")) if n is None else n, data=data)


@pytest.mark.parametrize("name, text, message", [
    ("six.yml", opencv_yaml("0.1, 0.1, 0, 0, 0.1, 0.1"),
     r"six.yml: RadTanCamera got 6 distortion coefficients: 6 fits no model"),
    ("prism.yml", opencv_yaml("0.1, 0.1, 0, 0, 0, 0, 0, 0, 0.01, 0, 0, 0"),
     r"prism.yml: .*12 coefficients are OpenCV's thin-prism model"),
    ("nan.yml", opencv_yaml(".Nan, 0.1, 0, 0, 0"),
     r"nan.yml: distortion_coefficients contains NaN"),
    ("missing.yml", OPENCV_YAML.split("distortion_coefficients")[0],
     r"missing.yml: missing key 'distortion_coefficients' \(OpenCV FileStorage"),
    ("shape.yml", opencv_yaml("0.1, 0.1, 0, 0, 0", n=4), r"shape.yml: distortion_coefficients is 1 x 4 but holds 5"),
    ("fisheye5.yml", opencv_yaml("0.1, 0.1, 0, 0, 0") + "fisheye_model: 1\n",
     r"fisheye5.yml: FisheyeCamera got 5 distortion coefficients: RadTanCamera takes 5"),
    ("flag.yml", opencv_yaml("0.1, 0.1, 0, 0, 0") + "fisheye_model: 2\n", "fisheye_model must be 0 or 1"),
    ("size.yml", opencv_yaml("0.1, 0.1, 0, 0, 0").replace("image_height: 480", "image_height: -1"),
     "size.yml: image_width and image_height must be positive integers"),
    ("skew.yml", opencv_yaml("0.1, 0.1, 0, 0, 0").replace("533.5, 0., 341.6", "533.5, 2., 341.6"),
     "skew.yml: RadTanCamera: OpenCV's radial-tangential model has no skew"),
    ("ros.yaml", ros_text("fisheye_thing", FISHEYE), r"ROS distortion_model 'fisheye_thing' is not supported"),
    ("ros5.yaml", ros_text("equidistant", RATIONAL[:5]), r"ROS distortion_model equidistant takes 4 coefficients, got 5"),
    ("rosnan.yaml", ros_text("plumb_bob", [0.1] * 5, K=[[533.5, 0, float("nan")], [0, 533.5, 235.2], [0, 0, 1]]),
     r"rosnan.yaml: camera_matrix contains NaN"),
    ("omni.yaml", kalibr_text(camera_model="omni", intrinsics=[0.8, 533.5, 533.5, 341.6, 235.2]),
     r"cam0 has Kalibr camera_model 'omni' \(the unified omnidirectional model\), which is not supported"),
    ("ds.yaml", kalibr_text(camera_model="ds"), r"'ds' \(the double sphere model\)"),
    ("fov.yaml", kalibr_text(distortion_model="fov", distortion_coeffs=[0.9]),
     r"Kalibr distortion_model 'fov', which is not supported"),
    ("k5.yaml", kalibr_text(distortion_coeffs=[0.1] * 5), "takes 4 coefficients .*got 5"),
    ("nokey.yaml", kalibr_text(drop=["intrinsics"]),
     r"missing key 'intrinsics' \(Kalibr camchain camera cam0\)"),
    ("list.yaml", "- 1\n- 2\n", "not a camera calibration: expected a mapping"),
    ("other.yaml", "foo: 1\nbar: 2\n", r"no calibration format graphpose reads .*\['bar', 'foo'\]"),
    ("bad.yaml", "a: [1, 2\n", "cannot parse .*bad.yaml as YAML"),
    ("bad.xml", "<opencv_storage><a>", "cannot parse .*bad.xml as XML"),
    ("root.xml", "<calibration/>", r"must be OpenCV FileStorage \(<opencv_storage>\), got <calibration>"),
    ("model.json", '{"model": "omni", "K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}',
     r"model.json: camera model 'omni' is not supported; graphpose's camera models are pinhole"),
    ("nodist.json", '{"model": "radtan", "K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}',
     r"missing key 'distortion' \(a radtan camera\)"),
    ("pinhole.json", '{"model": "pinhole", "K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "distortion": [0.1]}',
     "a pinhole camera has no distortion"),
    ("k.json", '{"model": "pinhole", "K": [[1, 0], [0, 1]]}', r"K must hold 9 numbers"),
    ("text.json", '{"model": "pinhole", "K": "eye"}', r"K must be numbers"),
    ("sizes.json", '{"model": "pinhole", "K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "size": 640}',
     r"size must be \[width, height\]"),
])
def test_bad_files_are_clear_errors(tmp_path, name, text, message):
    path = write(tmp_path, name, text)
    with pytest.raises(InputError, match=message):
        read_camera(path)


def test_missing_unreadable_and_misnamed(tmp_path):
    with pytest.raises(InputError, match="calibration file not found: .*nope.yaml"):
        read_camera(tmp_path / "nope.yaml")
    (tmp_path / "latin.yaml").write_bytes(b"camera_name: \xe9\n")
    with pytest.raises(InputError, match="cannot read calibration file .*latin.yaml"):
        read_camera(tmp_path / "latin.yaml")
    ros = write(tmp_path, "ros.yaml", ros_text("plumb_bob", [0.1] * 5))
    with pytest.raises(InputError, match=r"asked for camera 'left', but .* camera_name 'cam'"):
        read_camera(ros, "left")
    chain = write(tmp_path, "chain.yaml", kalibr_text())
    with pytest.raises(InputError, match=r"no camera 'cam2' in this Kalibr camchain; it holds cam0, cam1"):
        read_camera(chain, "cam2")
    ocv = write(tmp_path, "ocv.yml", opencv_yaml("0.1, 0.1, 0, 0, 0"))
    with pytest.raises(InputError, match=r"holds one camera \(OpenCV FileStorage calibration\)"):
        read_camera(ocv, "cam0")
    js = tmp_path / "c.json"
    write_camera(js, K)
    with pytest.raises(InputError, match=r"holds one camera \(graphpose camera file\)"):
        read_camera(js, "cam0")
    with pytest.raises(InputError, match="cannot write"):
        write_camera(tmp_path / "no" / "such" / "c.json", K)


# ---- every model in every format (what graphpose writes), read back to 1e-12, and the refusals ----
#: A K whose numbers need all 17 digits.
K17 = [[533.51234567891, 0.0, 341.6000001], [0.0, 533.4987654321, 235.2], [0.0, 0.0, 1.0]]
K_SKEW = [[500.1, 1.5, 320.3], [0.0, 510.7, 240.1], [0.0, 0.0, 1.0]]

#: One camera of every model and coefficient count, each with numbers that need all 17 digits.
CAMERAS = {
    "pinhole": PinholeCamera(K17, (640, 480)),
    "pinhole_skew": PinholeCamera(K_SKEW, (640, 480)),
    "radtan4": RadTanCamera(K17, [-0.2881234567, 0.0971, 1e-5, -3.3e-4], (640, 480)),
    "radtan5": RadTanCamera(K17, [-0.2881234567, 0.0971, 1e-5, -3.3e-4, 0.0123], (640, 480)),
    "radtan5_k3_zero": RadTanCamera(K17, [-0.2881234567, 0.0971, 1e-5, -3.3e-4, 0.0], (640, 480)),
    "rational": RadTanCamera(K17, RATIONAL, (640, 480)),
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
        write_camera(tmp_path / "k.yaml", PinholeCamera(K17), format="kalibr")
    with pytest.raises(InputError, match=r"unknown calibration file format 'matlab'; graphpose writes "
                                         r"json, opencv, ros, kalibr"):
        write_camera(tmp_path / "m.yaml", PinholeCamera(K17), format="matlab")
    with pytest.raises(InputError, match=r"holds one camera and no name: name='left'"):
        write_camera(tmp_path / "o.yaml", PinholeCamera(K17), format="opencv", name="left")
    with pytest.raises(InputError, match="cannot write"):
        write_camera(tmp_path / "no" / "such.yaml", PinholeCamera(K17), format="ros")


def test_names_and_unknown_sizes(tmp_path):
    camera = CAMERAS["radtan4"]
    write_camera(tmp_path / "chain.yaml", camera, format="kalibr", name="cam1")
    assert read_camera(tmp_path / "chain.yaml", "cam1") == camera
    write_camera(tmp_path / "ros.yaml", camera, format="ros", name="left: 1")
    assert read_camera(tmp_path / "ros.yaml", "left: 1") == camera
    assert yaml.safe_load((tmp_path / "ros.yaml").read_text())["camera_name"] == "left: 1"
    nosize = RadTanCamera(K17, RATIONAL)
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

"""Each camera answers for its calibration parameters: names in OpenCV's order that match the
vector, round trips through ``from_parameters`` and ``with_parameters``, the analytic
``parameter_jacobian`` against central differences, the cameras' covariance, and the one
registry of model names (every ``--model`` the command line takes)."""

import dataclasses

import numpy as np
import pytest

from graphpose import FisheyeCamera, InputError, PinholeCamera, RadTanCamera, read_camera, write_camera
from graphpose.camera_models import HELD_MODELS, MODELS, RationalCamera, calibration_model, model_class
from graphpose.cli import build_parser

K = [[533.5, 0.0, 341.6], [0.0, 531.0, 235.2], [0.0, 0.0, 1.0]]
K_SKEW = [[300.0, 0.9, 640.0], [0.0, 310.0, 512.0], [0.0, 0.0, 1.0]]
RATIONAL = (2.5, 1.2, 0.0005, -0.0004, 0.05, 2.8, 2.0, 0.3)
CAMERAS = {
    "pinhole": PinholeCamera([[500.0, 1.5, 320.0], [0.0, 510.0, 240.0], [0, 0, 1]], (640, 480)),
    "radtan4": RadTanCamera(K, (-0.288, 0.097, 0.001, -0.0003), (640, 480)),
    "radtan5": RadTanCamera(K, (-0.35, 0.15, 0.001, -0.0003, -0.03), (640, 480)),
    "rational": RadTanCamera(K, RATIONAL, (640, 480)),
    "rational_model": RationalCamera(K, RATIONAL, (640, 480)),
    "fisheye": FisheyeCamera(K_SKEW, (-0.013, -0.004, 0.0035, -0.001), (1280, 1024)),
}


def points(camera, rng, n=40):
    """Camera-frame points in view: rays within 50 degrees (95 for the fisheye), 0.5-3 m."""
    limit = np.radians(95.0 if camera.model == "fisheye" else 50.0)
    theta = rng.uniform(0.0, limit, n)
    phi = rng.uniform(-np.pi, np.pi, n)
    ray = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    return ray * rng.uniform(0.5, 3.0, n)


def test_parameter_names_are_opencvs_order():
    assert MODELS["pinhole"].parameter_names == ("fx", "fy", "cx", "cy")
    assert MODELS["radtan"].parameter_names == ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
    assert MODELS["fisheye"].parameter_names == ("fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4")
    # An 8-coefficient RadTanCamera keeps k4..k6 fixed; model="rational" estimates them too.
    assert CAMERAS["rational"].parameter_names == MODELS["radtan"].parameter_names
    assert MODELS["rational"].parameter_names == MODELS["radtan"].parameter_names + ("k4", "k5", "k6")
    with pytest.raises(InputError, match="unknown camera model 'omni'.*pinhole, radtan, rational, fisheye"):
        model_class("omni")


def test_one_registry_covers_every_model_the_command_line_takes(tmp_path):
    # The registry is the model names of the camera file, the calibration and --model: one dict.
    assert {name: cls.model for name, cls in MODELS.items()} == {name: name for name in MODELS}
    by_model = {"pinhole": "pinhole", "radtan": "radtan5", "rational": "rational_model", "fisheye": "fisheye"}
    assert set(by_model) == set(MODELS)
    for name, key in by_model.items():  # the camera file reads each model's name as its class
        write_camera(tmp_path / f"{name}.json", CAMERAS[key])
        back = read_camera(tmp_path / f"{name}.json")
        assert type(back) is MODELS[name] and back == CAMERAS[key]
    (tmp_path / "omni.json").write_text('{"model": "omni", "K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}')
    with pytest.raises(InputError, match="models are pinhole, radtan, rational, fisheye$"):
        read_camera(tmp_path / "omni.json")
    parser = build_parser()
    calibrate = parser._subparsers._group_actions[0].choices["calibrate"]
    choices = next(a.choices for a in calibrate._actions if "--model" in a.option_strings)
    assert set(choices) == set(MODELS) | set(HELD_MODELS)
    for name in choices:
        cls, held = calibration_model(name)
        assert cls in MODELS.values() and held.shape == (len(cls.parameter_names),)
    with pytest.raises(InputError, match="unknown camera model 'omni'.*pinhole, radtan, rational, fisheye, radtan4"):
        calibration_model("omni")


@pytest.mark.parametrize("name", CAMERAS)
def test_parameters_match_their_names_and_round_trip(name):
    camera = CAMERAS[name]
    p = camera.parameters
    assert p.shape == (len(camera.parameter_names),) and p.dtype == float
    np.testing.assert_array_equal(p[:4], [camera.fx, camera.fy, camera.cx, camera.cy])
    p[0] = -1.0  # a new array each time: the camera stays as it was
    assert camera.parameters[0] == camera.fx
    p = camera.parameters
    again = camera.with_parameters(p)
    assert again == camera and type(again) is type(camera) and again.size == camera.size
    assert again.skew == camera.skew and again.covariance is None
    moved = camera.with_parameters(p * 1.01)
    np.testing.assert_allclose(moved.parameters, p * 1.01, rtol=1e-15)
    if name == "rational":  # k4..k6 are not parameters: kept
        np.testing.assert_array_equal(moved.coefficients[5:], camera.coefficients[5:])
    # The classmethod: this model's camera of the vector, the skew (not a parameter) given.
    made = type(camera).from_parameters(p, camera.size, skew=camera.skew)
    assert type(made) is type(camera) and made.size == camera.size
    np.testing.assert_array_equal(made.parameters, p)
    np.testing.assert_array_equal(made.K, camera.K)
    if name != "rational":  # an 8-coefficient RadTanCamera's k4..k6 come with rational=
        assert made == camera
    assert RadTanCamera.from_parameters(CAMERAS["rational"].parameters, (640, 480),
                                        rational=RATIONAL[5:]) == CAMERAS["rational"]


def test_radtan_parameters_are_opencvs_five():
    camera = CAMERAS["radtan4"]
    p = camera.parameters
    np.testing.assert_array_equal(p[4:], [-0.288, 0.097, 0.001, -0.0003, 0.0])
    p[8] = 0.02
    assert camera.with_parameters(p).distortion.tolist() == [-0.288, 0.097, 0.001, -0.0003, 0.02]


def central_difference(camera, P, h=1e-6):
    p = camera.parameters
    J = np.empty((P.shape[1], 2, p.size))
    for i in range(p.size):
        step = h * max(1.0, abs(p[i]))
        plus, minus = p.copy(), p.copy()
        plus[i] += step
        minus[i] -= step
        J[:, :, i] = ((camera.with_parameters(plus).project(P)
                       - camera.with_parameters(minus).project(P)) / (2 * step)).T
    return J


@pytest.mark.parametrize("name", CAMERAS)
def test_parameter_jacobian_matches_central_differences(name):
    camera = CAMERAS[name]
    P = points(camera, np.random.default_rng(5))
    J = camera.parameter_jacobian(P)
    assert J.shape == (P.shape[1], 2, len(camera.parameter_names))
    num = central_difference(camera, P)
    scale = np.max(np.abs(num), axis=(0, 1))  # per parameter
    np.testing.assert_allclose(J / scale, num / scale, rtol=0, atol=1e-7)


def test_parameter_jacobian_edges():
    # The pinhole's is the normalised point and the identity; the fisheye's forward axis has a
    # finite derivative (0 in the coefficients); points behind a radtan camera are NaN rows, as
    # project is NaN.
    J = PinholeCamera(K).parameter_jacobian([[0.1], [0.2], [1.0]])
    np.testing.assert_allclose(J[0], [[0.1, 0, 1, 0], [0, 0.2, 0, 1]])
    J = CAMERAS["fisheye"].parameter_jacobian([[0.0], [0.0], [2.0]])
    np.testing.assert_array_equal(J[0, :, 4:], 0.0)
    np.testing.assert_array_equal(J[0, :, 2:4], np.eye(2))
    J = CAMERAS["radtan5"].parameter_jacobian([[0.1, 0.1], [0.0, 0.0], [1.0, -1.0]])
    assert np.all(np.isfinite(J[0])) and np.all(np.isnan(J[1]))
    with pytest.raises(InputError, match=r"P_C must have shape \(3, N\)"):
        PinholeCamera(K).parameter_jacobian(np.zeros((2, 3)))


def spd(n, rng):
    A = rng.normal(size=(n, n))
    return A @ A.T + n * np.eye(n)


@pytest.mark.parametrize("name", CAMERAS)
def test_cameras_carry_a_read_only_covariance_outside_equality(name):
    camera = CAMERAS[name]
    n = len(camera.parameter_names)
    cov = spd(n, np.random.default_rng(n))
    with_cov = camera.with_parameters(camera.parameters, cov)
    np.testing.assert_array_equal(with_cov.covariance, cov)
    np.testing.assert_array_equal(type(camera).from_parameters(camera.parameters, covariance=cov,
                                                               skew=camera.skew).covariance, cov)
    with pytest.raises(ValueError):
        with_cov.covariance[0, 0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        with_cov.covariance = None
    # Equality is the projection's: a file format without a covariance reads back equal.
    assert with_cov == camera and hash(with_cov) == hash(camera)
    assert "covariance" not in repr(with_cov)


def test_covariance_checks():
    names = MODELS["radtan"].parameter_names
    good = np.diag([0.25, 0.25, 0.5, 0.5, 1e-6, 1e-5, 1e-8, 1e-8, 1e-4])
    RadTanCamera(K, [0, 0, 0, 0, 0], covariance=good)
    RadTanCamera(K, [0, 0, 0, 0, 0], covariance=np.zeros((9, 9)))  # a fixed parameter: 0 variance
    bad = [
        (np.eye(4), r"shape \(9, 9\)"),
        (np.full((9, 9), np.nan), "NaN"),
        (good - 2 * np.diag(np.diag(good)), "negative variances"),
        (good + np.triu(np.full((9, 9), 1e-6), 1), "not symmetric"),
        (good + 0.9 * np.sqrt(np.outer(np.diag(good), np.diag(good))) * (1 - np.eye(9)) * -1,
         "not positive semi-definite"),
        ([["a"] * 9] * 9, "real numbers"),
    ]
    for cov, message in bad:
        with pytest.raises(InputError, match=message):
            RadTanCamera(K, [0, 0, 0, 0, 0], covariance=cov)
    with pytest.raises(InputError, match=r"FisheyeCamera covariance \(of fx, fy, cx, cy, k1, k2, k3, k4\)"):
        FisheyeCamera(K, [0, 0, 0, 0], covariance=np.eye(9))
    with pytest.raises(InputError, match="PinholeCamera covariance"):
        PinholeCamera(K, covariance=np.eye(len(names)))


def test_from_parameters_refuses_bad_vectors():
    camera = CAMERAS["fisheye"]
    with pytest.raises(InputError, match="a fisheye camera has 8 parameters"):
        camera.with_parameters(np.ones(9))
    with pytest.raises(InputError, match="NaN"):
        camera.with_parameters([np.nan] * 8)
    with pytest.raises(InputError, match="focal lengths"):
        camera.with_parameters([-1.0, 1, 1, 1, 0, 0, 0, 0])
    with pytest.raises(InputError, match=r"a rational camera has 12 parameters \(fx, .*, k6\), got 9"):
        RationalCamera.from_parameters(CAMERAS["radtan5"].parameters)
    with pytest.raises(InputError, match="no skew"):
        RadTanCamera.from_parameters(CAMERAS["radtan5"].parameters, skew=0.5)

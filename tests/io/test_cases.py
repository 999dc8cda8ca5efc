import json

import numpy as np
import pytest

from graphpose import (
    Board,
    FisheyeCamera,
    InputError,
    PinholeCamera,
    RadTanCamera,
    T_from_params,
    load_cases,
)
from graphpose.io.cameras import write_camera
from graphpose.io.cases import load_pose


def test_real_images_load(real_images):
    assert len(real_images) == 6
    for case, image in real_images:
        assert image.shape == (480, 640)
        assert case.bounds.shape == (2, 4)


K = [[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]]
BOUNDS = [[0, 10, 10, 0], [0, 0, 10, 10]]


def _write(tmp_path, doc):
    path = tmp_path / "cases.json"
    path.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    return path


def test_load_cases_reads_every_field(tmp_path):
    T = T_from_params([0.1, 0.2, -1.0, 0.0, 0.1, 0.0])
    entry = {"image": "a.png", "bounds": BOUNDS, "guess_T_WC": T.tolist(), "ref_T_WC": T.tolist(),
             "true_T_WC": T.tolist(), "ref_junctions": [[1, 2], [3, 4]], "true_junctions": [[5.0], [6.0]]}
    cases = load_cases(_write(tmp_path, {"K": K, "square_m": 0.03, "grid": {"cols": 5, "rows": 4},
                                         "cases": [entry]}))
    assert cases.board == Board(5, 4, 0.03)
    (case,) = cases.cases
    assert case.image == (tmp_path / "a.png").resolve()
    np.testing.assert_array_equal(case.bounds, BOUNDS)
    np.testing.assert_array_equal(case.ref_junctions, [[1, 2], [3, 4]])
    np.testing.assert_array_equal(case.true_junctions, [[5], [6]])
    for pose in (case.guess_T_WC, case.ref_T_WC, case.true_T_WC):
        np.testing.assert_array_equal(pose, T)


@pytest.mark.parametrize("doc, message", [
    ("{not json", "cannot read case file"),
    ([1, 2], "must hold a JSON object, got list"),
    ({"cases": []}, "must give the camera's K .* got neither"),
    ({"K": K, "camera": "left.yml", "cases": []}, "must give the camera's K .* not both"),
    ({"camera": "none.yml", "cases": []}, "case file .*: calibration file not found: .*none.yml"),
    ({"camera": 3, "cases": []}, "camera must be a calibration file's path .* got 3"),
    ({"camera": {"model": "radtan", "K": K, "distortion": [0.1] * 6}, "cases": []},
     "case file .*: camera.*6 distortion coefficients"),
    ({"camera": {"model": "kannala", "K": K}, "cases": []}, "camera model 'kannala' is not supported"),
    ({"camera": {"model": "radtan", "K": K}, "cases": []}, "camera.*distortion"),
    ({"K": K}, "lacks the field 'cases'"),
    ({"K": K, "cases": [{"bounds": BOUNDS}]}, "lacks the field 'image'"),
    ({"K": K, "cases": {"image": "a.png"}}, "cases must be a list of objects"),
    ({"K": K, "cases": ["a.png"]}, "cases must be a list of objects"),
    ({"K": "abc", "cases": []}, "K must be a rectangular array"),
    ({"K": K, "grid": "8x6", "cases": []}, r"grid must be an object \{\"cols\": 8, \"rows\": 6\} or a list \[8, 6\]"),
    ({"K": K, "grid": [8, 6, 2], "cases": []}, "grid must be an object"),
    ({"K": K, "grid": {"cols": "many"}, "cases": []}, "grid cols must be an integer >= 2, got 'many'"),
    ({"K": K, "square_m": -1, "cases": []}, r"square_m \(metres\) must be a finite number > 0, got -1"),
    ({"K": K, "cases": [{"image": 3, "bounds": BOUNDS}]}, "image must be a path string"),
    ({"K": K, "cases": [{"image": "a.png", "bounds": [[0, 1, 2, 3]]}]},
     r"case file .*: bounds of a.png must have shape \(2, 4\) \(u and v of 4 vertices\), got \(1, 4\)"),
    ({"K": K, "cases": [{"image": "a.png", "bounds": [[0, 1], [2]]}]}, "bounds of a.png must be a rectangular array"),
    ({"K": K, "cases": [{"image": "a.png", "bounds": BOUNDS, "ref_junctions": [1, 2]}]},
     r"ref_junctions of a.png must have shape \(2, N\)"),
    ({"K": K, "cases": [{"image": "a.png", "bounds": BOUNDS, "true_junctions": [[1, None], [2, 3]]}]},
     "true_junctions of a.png must be a rectangular array"),
    ({"K": K, "cases": [{"image": "a.png", "bounds": BOUNDS, "ref_T_WC": np.eye(3).tolist()}]},
     r"ref_T_WC of a.png must have shape \(4, 4\)"),
    ({"K": K, "cases": [{"image": "a.png", "bounds": BOUNDS, "guess_T_WC": (2 * np.eye(4)).tolist()}]},
     "guess_T_WC of a.png.* not a rotation"),
])
def test_load_cases_rejects(tmp_path, doc, message):
    with pytest.raises(InputError, match=message):
        load_cases(_write(tmp_path, doc))


@pytest.mark.parametrize("grid, field, value", [
    ([8.9, 6], "cols", "8.9"), ({"cols": 8.9, "rows": 6}, "cols", "8.9"), ({"rows": 6.5}, "rows", "6.5"),
    ([8, 0], "rows", "0"), ({"cols": -8}, "cols", "-8"), ([8.0, 6], "cols", "8.0"), (["8", 6], "cols", "'8'"),
    ({"cols": True}, "cols", "True"), ([1, 6], "cols", "1"),
])
def test_load_cases_refuses_counts_that_are_not_integers_of_at_least_2(tmp_path, grid, field, value):
    # `grid: [8.9, 6]` was once read as 8 columns (and `{"cols": 8.9}` likewise).
    path = _write(tmp_path, {"K": K, "grid": grid, "cases": []})
    with pytest.raises(InputError) as info:
        load_cases(path)
    assert str(info.value) == f"case file {path}: grid {field} must be an integer >= 2, got {value}"


@pytest.mark.parametrize("grid", [[9, 7], {"cols": 9, "rows": 7}])
def test_load_cases_reads_the_grid_as_a_list_or_an_object(tmp_path, grid):
    assert load_cases(_write(tmp_path, {"K": K, "grid": grid, "cases": []})).board == Board(9, 7)
    assert load_cases(_write(tmp_path, {"K": K, "grid": {"rows": 5}, "cases": []})).board == Board(8, 5)
    assert load_cases(_write(tmp_path, {"K": K, "cases": []})).board == Board()


def test_bounds_are_optional(tmp_path):
    cases = load_cases(_write(tmp_path, {"K": K, "cases": [{"image": "a.png"}, {"image": "b.png", "bounds": None}]}))
    assert [c.bounds for c in cases.cases] == [None, None]
    assert cases.camera == PinholeCamera(K) and cases.camera.distortion.size == 0


def test_camera_from_a_file_beside_the_case_file_or_inline(tmp_path):
    camera = RadTanCamera(K, [-0.2, 0.05, 0.001, 0.0, 0.01], size=(640, 480))
    (tmp_path / "calib").mkdir()
    write_camera(tmp_path / "calib" / "cam.json", camera)
    from_file = load_cases(_write(tmp_path, {"camera": "calib/cam.json", "cases": [{"image": "a.png"}]}))
    assert from_file.camera == camera
    np.testing.assert_array_equal(from_file.K, camera.K)
    inline = {"model": "radtan", "K": K, "distortion": [-0.2, 0.05, 0.001, 0.0, 0.01], "size": [640, 480]}
    assert load_cases(_write(tmp_path, {"camera": inline, "cases": []})).camera == camera
    fisheye = {"model": "fisheye", "K": K, "distortion": [0.01, 0.0, 0.0, 0.0]}
    assert load_cases(_write(tmp_path, {"camera": fisheye, "cases": []})).camera == FisheyeCamera(K, [0.01, 0, 0, 0])


def test_camera_file_with_nan_or_missing_keys_is_refused_naming_both_files(tmp_path):
    (tmp_path / "cam.json").write_text(json.dumps({"model": "radtan", "K": K, "distortion": [0.1, float("nan"), 0, 0]}))
    path = _write(tmp_path, {"camera": "cam.json", "cases": []})
    with pytest.raises(InputError, match=r"case file .*cases.json: .*cam.json.*NaN"):
        load_cases(path)
    (tmp_path / "cam.json").write_text(json.dumps({"model": "radtan", "distortion": [0.1, 0, 0, 0]}))
    with pytest.raises(InputError, match=r"case file .*cases.json: .*cam.json.*K"):
        load_cases(path)


def test_load_cases_missing_file(tmp_path):
    with pytest.raises(InputError, match="case file not found"):
        load_cases(tmp_path / "none.json")


def test_load_pose_forms(tmp_path):
    T = T_from_params([0.1, 0.2, -1.0, 0.1, -0.2, 0.3])
    plain, wrapped = tmp_path / "plain.json", tmp_path / "wrapped.json"
    plain.write_text(json.dumps(T.tolist()))
    wrapped.write_text(json.dumps({"T_WC": T.tolist()}))
    np.testing.assert_allclose(load_pose(plain), T)
    np.testing.assert_allclose(load_pose(wrapped), T)
    wrapped.write_text(json.dumps([{"image": "a.png", "T_WC": T.tolist()}]))  # --json of one image
    np.testing.assert_allclose(load_pose(wrapped), T)
    for text, message in [('{"pose": 1}', "without the key T_WC"), ("[[1, 2]", "cannot read"),
                          ('[["a"]]', "4 x 4"), (json.dumps((2 * T).tolist()), "not a rotation")]:
        plain.write_text(text)
        with pytest.raises(InputError, match=message):
            load_pose(plain)
    with pytest.raises(InputError, match="not found"):
        load_pose(tmp_path / "none.json")

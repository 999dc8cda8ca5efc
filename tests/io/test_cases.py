import json

import numpy as np
import pytest

from graphpose import Board, InputError, T_from_params, as_grey, load_cases, read_image


def test_as_grey_scales_dtypes():
    assert as_grey(np.full((2, 2), 255, np.uint8)).max() == 1.0
    assert as_grey(np.full((2, 2), 65535, np.uint16)).max() == 1.0
    rgb = np.zeros((2, 2, 3), np.uint8)
    rgb[..., 1] = 255
    np.testing.assert_allclose(as_grey(rgb), 0.587)
    rgba = np.concatenate([rgb, np.full((2, 2, 1), 7, np.uint8)], axis=2)
    np.testing.assert_allclose(as_grey(rgba), 0.587)


@pytest.mark.parametrize(
    "image, message",
    [(np.zeros((0, 0)), "empty"), (np.full((2, 2), np.nan), "NaN"), (np.zeros((2, 2, 2)), "shape")],
)
def test_as_grey_rejects(image, message):
    with pytest.raises(InputError, match=message):
        as_grey(image)


def test_read_image_errors(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_image(tmp_path / "missing.png")
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"not a png")
    with pytest.raises(InputError, match="cannot read"):
        read_image(junk)


def test_real_images_load(real_images):
    assert len(real_images) == 6
    for case, image in real_images:
        assert image.shape == (480, 640)
        assert case.bounds.shape == (2, 4)


@pytest.mark.parametrize(
    "image", [np.zeros((2, 2), complex), np.array([["a", "b"]]), np.zeros((2, 2), "datetime64[s]")])
def test_as_grey_rejects_unsupported_dtypes(image):
    with pytest.raises(InputError, match="unsupported dtype"):
        as_grey(image)


def test_as_grey_keeps_floats_and_maps_bools():
    np.testing.assert_array_equal(as_grey(np.array([[0.25, 1.5]], np.float32)), [[0.25, 1.5]])
    assert as_grey(np.array([[True, False]])).tolist() == [[1.0, 0.0]]


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
    ({"cases": []}, "lacks the field 'K'"),
    ({"K": K}, "lacks the field 'cases'"),
    ({"K": K, "cases": [{"bounds": BOUNDS}]}, "lacks the field 'image'"),
    ({"K": K, "cases": [{"image": "a.png"}]}, "lacks the field 'bounds'"),
    ({"K": K, "cases": {"image": "a.png"}}, "cases must be a list of objects"),
    ({"K": K, "cases": ["a.png"]}, "cases must be a list of objects"),
    ({"K": "abc", "cases": []}, "K must be a rectangular array"),
    ({"K": K, "grid": [8, 6], "cases": []}, "grid must be an object"),
    ({"K": K, "grid": {"cols": "many"}, "cases": []}, "many"),
    ({"K": K, "square_m": -1, "cases": []}, "square_m must be a positive number"),
    ({"K": K, "cases": [{"image": 3, "bounds": BOUNDS}]}, "image must be a path string"),
    ({"K": K, "cases": [{"image": "a.png", "bounds": [[0, 1, 2, 3]]}]}, r"bounds of a.png must be 2 x 4, got \(1, 4\)"),
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


def test_load_cases_missing_file(tmp_path):
    with pytest.raises(InputError, match="case file not found"):
        load_cases(tmp_path / "none.json")


def test_as_grey_passes_float64_grey_through_without_a_copy():
    image = np.random.default_rng(0).random((4, 5))
    assert as_grey(image) is image
    assert as_grey(image.astype(np.float32)).dtype == np.float64

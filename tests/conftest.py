"""Shared fixtures: the real ROB501 images beside the checkout, skipped only when absent.

GRAPHPOSE_ROB501 points at another copy of the folder, GRAPHPOSE_OPENCV_SAMPLES at another
copy of OpenCV's samples. With GRAPHPOSE_REQUIRE_REAL=1 a
missing folder or file fails the tests that need it instead of skipping them (for CI
machines that are meant to have the data).
"""

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
REAL_DIR = Path(os.environ.get("GRAPHPOSE_ROB501", REPO.parent / "shared" / "data" / "rob501"))
#: OpenCV's raw calibration samples (9 x 6 board) and their camera files.
OPENCV_DIR = Path(os.environ.get("GRAPHPOSE_OPENCV_SAMPLES", REPO.parent / "shared" / "data" / "opencv_samples"))


def _data_file(path: Path) -> Path:
    """``path``, or skip the test (fail it under GRAPHPOSE_REQUIRE_REAL=1) when it is absent."""
    if not path.is_file():
        message = f"real data file {path} is absent"
        if os.environ.get("GRAPHPOSE_REQUIRE_REAL") == "1":
            pytest.fail(f"{message} and GRAPHPOSE_REQUIRE_REAL=1")
        pytest.skip(message)
    return path


def real_file(name: str) -> Path:
    """Path of a file of the real (ROB501) data folder; skips the test (fails it under
    GRAPHPOSE_REQUIRE_REAL=1) when the file is absent."""
    return _data_file(REAL_DIR / name)


def opencv_file(name: str) -> Path:
    """Path of a file of OpenCV's calibration samples, skipped or failed as :func:`real_file`."""
    return _data_file(OPENCV_DIR / name)


@pytest.fixture(scope="session")
def real_cases():
    """The parsed real case file (:class:`graphpose.io.CaseFile`)."""
    from graphpose.io.cases import load_cases

    return load_cases(real_file("cases.json"))


@pytest.fixture(scope="session")
def real_images(real_cases):
    """List of (case, grey float image) for the six real images."""
    from graphpose.image import read_image

    return [(case, read_image(case.image, as_float=True)) for case in real_cases.cases]


# --- shared constants: the project's camera and target (appended; graphpose.geometry loads
# no GTSAM) ---------------------------------------------------

from graphpose import Board as _Board  # noqa: E402
from graphpose.geometry import K_from_params as _K_from_params  # noqa: E402

#: The project's camera (the ROB501 images'), (3, 3) pixels; read-only. Its fx, fy, cx, cy are
#: ``graphpose.cli.options.DEFAULT_K``'s (what ``render-sequence`` draws with), written here so
#: that the tests take the project's K from this module, not from the command line's.
PROJECT_K = _K_from_params(564.9, 564.3, 337.3, 226.5)
PROJECT_K.setflags(write=False)
#: The project's board's junctions (8 x 6, 63.5 mm), (3, 48) metres, row-major; read-only.
BOARD_WPTS = _Board().world_points()
BOARD_WPTS.setflags(write=False)

from graphpose.camera_models import FisheyeCamera as _Fisheye  # noqa: E402
from graphpose.camera_models import PinholeCamera as _Pinhole  # noqa: E402
from graphpose.camera_models import RadTanCamera as _RadTan  # noqa: E402

#: One camera of each model on the project's K. GTSAM has a calibration (Cal3_S2, Cal3DS2,
#: Cal3Fisheye) for "pinhole", "radtan" and "fisheye", not for k3 or the rational model's
#: k4..k6 (graphpose then uses a custom factor).
LENS_CAMERAS = {
    "pinhole": _Pinhole(PROJECT_K),
    "radtan": _RadTan(PROJECT_K, [-0.288, 0.097, 0.001, -0.0003]),
    "radtan_k3": _RadTan(PROJECT_K, [-0.288, 0.097, 0.001, -0.0003, 0.02]),
    "rational": _RadTan(PROJECT_K, [-0.25, 0.08, 0.001, -0.0003, 0.02, 0.05, 0.01, 0.002]),
    "fisheye": _Fisheye(PROJECT_K, [0.03, -0.01, 0.002, -0.0005]),
}


# --- a rendered clip for the tracker's tests (appended; tests/track, tests/cli) -----------


@pytest.fixture(scope="session")
def track_clip():
    """45 rendered frames of the project's board (:func:`graphpose.render_sequence`, cheap
    rendering), with one whip pan out of view and back."""
    from graphpose.synth.sequence import render_sequence

    return render_sequence(PROJECT_K, 45, rng=4, excursions=1, supersample=1)

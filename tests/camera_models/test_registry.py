"""graphpose.camera_models.registry: the one registry of model names (the camera file's, the
calibration's, every ``--model`` the command line takes)."""

import pytest

from graphpose import InputError, read_camera, write_camera
from graphpose.camera_models import HELD_MODELS, MODELS, calibration_model
from graphpose.cli import build_parser
from tests.camera_models.helpers import CAMERAS


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

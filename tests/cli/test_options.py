"""graphpose.cli.options: what every command's options share."""

import io
import json

import numpy as np

from graphpose.cli.options import write_json_option
from graphpose.io.files import dumps_json


def test_write_json_option_writes_a_file_standard_output_or_nothing(tmp_path, monkeypatch):
    value = {"T_WC": np.eye(4), "rms_px": 0.25, "message": None}
    write_json_option(tmp_path / "out.json", value)
    assert (tmp_path / "out.json").read_text() == dumps_json(value)
    assert json.loads((tmp_path / "out.json").read_text())["rms_px"] == 0.25
    out = io.StringIO()
    monkeypatch.setattr("sys.stdout", out)
    write_json_option("-", value)
    assert out.getvalue() == dumps_json(value)
    write_json_option(None, value)
    assert out.getvalue() == dumps_json(value) and sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]

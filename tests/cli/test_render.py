"""``graphpose render-sequence``'s usage errors (moved from tests/track/test_tracker.py; the
command's output is tracked in tests/cli/test_track.py)."""

import pytest

from graphpose.cli import main


@pytest.mark.parametrize(
    "args, message",
    [(["--frames", "1"], "--frames: expected an integer >= 2, got '1'"),
     (["--seed", "-1"], "--seed: expected an integer >= 0, got '-1'"),
     (["--excursions", "-1"], "--excursions: expected an integer >= 0, got '-1'"),
     (["--noise", "-1"], "--noise: expected a number >= 0, got '-1'"),
     (["--blur", "nan"], "--blur: expected a number >= 0, got 'nan'"),
     (["--fps", "0"], "--fps: expected a positive number, got '0'"),
     (["--distance", "1"], "--distance: expected NEAR,FAR in metres, got '1'"),
     (["--distance", "1.3,0.6"], "--distance: expected 0 < NEAR <= FAR, got '1.3,0.6'")],
)
def test_render_sequence_usage_errors(tmp_path, capsys, args, message):
    assert main(["render-sequence", str(tmp_path / "seq"), *args]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "seq").exists()


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_render_sequence_into_a_file_is_a_usage_error(tmp_path, capsys):
    (tmp_path / "seq").write_text("in the way")
    assert main(["render-sequence", str(tmp_path / "seq"), "--frames", "2", "--excursions", "0", "-q"]) == 2
    assert "cannot create folder" in capsys.readouterr().err

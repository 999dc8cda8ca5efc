"""A new user's frictions (issue 26), each through the command line (``main([...])``): the
board's units, calibrate past an unreadable image and without a dangling message, each lost
frame's reason said once, every failure's reason on stderr under one ``graphpose COMMAND:``
prefix, one spelling of an option across commands (old names kept), exit codes in every help,
file names in the calibration plot."""

import json
import re

import numpy as np
import pytest

from graphpose.cli import build_parser, main
from graphpose.io.files import write_png
from tests.conftest import REPO
from tests.helpers import PROJECT_K_OPTION as K_OPTION

BUNDLED = REPO / "graphpose" / "data"


def err_lines(capsys):
    captured = capsys.readouterr()
    return captured.out, [line for line in captured.err.splitlines() if line.strip()]


# --- the board's units --------------------------------------------------------------------


def test_a_square_in_millimetres_typed_as_metres_exits_2_with_the_hint(capsys):
    assert main(["estimate", str(BUNDLED / "synthetic_01.png"), "--K", K_OPTION, "--board", "9x6x25"]) == 2
    _, err = err_lines(capsys)
    assert len(err) == 1 and err[0].startswith("graphpose estimate: error: argument --board:")
    assert "did you mean 25 mm (0.025)?" in err[0]


def test_millimetres_and_metres_give_the_same_pose(capsys):
    records = []
    for board in ("8x6x63.5mm", "8x6x0.0635", "8x6x6.35cm"):
        assert main(["estimate", str(BUNDLED / "synthetic_01.png"), "--K", K_OPTION, "--board", board,
                     "--json", "-"]) == 0
        records.append(json.loads(capsys.readouterr().out))
    assert records[0] == records[1] == records[2]
    assert records[0][0]["board"] == {"cols": 8, "rows": 6, "square_m": 0.0635}


# --- calibrate ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def views(tmp_path_factory):
    """Six rendered raw views and a file that is not an image among them (name order)."""
    from graphpose.synth.calibration import calibration_set, radtan_camera

    folder = tmp_path_factory.mktemp("views")
    for k, image in enumerate(calibration_set(radtan_camera(), 6, rng=5).images):
        write_png(folder / f"view_{k:02d}.png", image)
    (folder / "view_03b.png").write_bytes(b"\x89PNG\r\n\x1a\n cut short")
    return folder


@pytest.mark.slow  # a whole calibration through the CLI
def test_calibrate_goes_on_past_an_unreadable_image_and_names_it(views, tmp_path, capsys):
    report = tmp_path / "report.json"
    assert main(["calibrate", str(views), "--board", "8x6x0.0635", "--model", "pinhole", "--out",
                 str(tmp_path / "cam.json"), "--report", str(report)]) == 0
    out, err = err_lines(capsys)
    assert err == [f"graphpose calibrate: warning: cannot read image {views / 'view_03b.png'}: not a readable "
                   "image (truncated or corrupt) (left out)"]
    assert "6 used, 0 rejected, 0 without a board, 1 unreadable" in out
    (entry,) = [e for e in json.loads(report.read_text())["images"] if e["image"].endswith("view_03b.png")]
    assert entry["status"] == "unreadable" and "view_03b.png" in entry["message"]


@pytest.mark.slow  # 0.7 s or so on two idle cores: a render, a calibration or a subprocess
def test_calibrate_with_two_images_says_why_without_a_dangling_list(views, tmp_path, capsys):
    two = [str(views / "view_00.png"), str(views / "view_01.png")]
    assert main(["calibrate", *two, "--board", "8x6x0.0635", "--out", str(tmp_path / "c.json")]) == 2
    _, err = err_lines(capsys)
    assert len(err) == 1 and err[0].startswith("graphpose calibrate: error: fewer than 3 images show the board")
    assert "No board in" not in err[0] and err[0].endswith("views at different tilts")


@pytest.mark.slow  # a whole calibration through the CLI
def test_calibrate_report_has_its_old_name_json_too(views, tmp_path, capsys, monkeypatch):
    import graphpose.calibrate as package

    cached = {}
    real = package.calibrate
    monkeypatch.setattr(package, "calibrate", lambda files, *a, **k: cached.setdefault("c", real(files, *a, **k)))
    for option in ("--report", "--json"):
        path = tmp_path / f"{option[2:]}.json"
        assert main(["calibrate", str(views), "--board", "8x6x0.0635", "--model", "pinhole", "-q",
                     "--out", str(tmp_path / "cam.json"), option, str(path)]) == 0
        assert json.loads(path.read_text())["model"] == "pinhole"
    capsys.readouterr()


@pytest.mark.slow  # 1.5 s or so on two idle cores: a render, a calibration or a subprocess
def test_the_calibration_plot_labels_images_by_file_name(views):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from graphpose.calibrate.result import STATUSES
    from graphpose.viz.calibration import _per_image

    names = [str(views / f"view_{k:02d}.png") for k in range(3)] + [str(views / "view_03b.png")]

    class Calibration:  # what the bars read
        images = tuple(names)
        status = ("used", "used", "rejected", "unreadable")
        image_rms_px = np.array([0.1, 0.2, 0.9, np.nan])
        rms_px = 0.15

    assert set(Calibration.status) <= set(STATUSES)
    figure, ax = plt.subplots()
    try:
        _per_image(ax, Calibration)
        assert [t.get_text() for t in ax.get_xticklabels()] == [
            "view_00.png", "view_01.png", "view_02.png", "view_03b.png"]
    finally:
        plt.close(figure)


# --- track: each reason once, and on stderr -------------------------------------------------


@pytest.fixture(scope="module")
def lost_frames(tmp_path_factory):
    """30 rendered frames (two whip pans out of view: the issue's sequence) tracked, as JSON."""
    folder = tmp_path_factory.mktemp("seq")
    assert main(["render-sequence", str(folder), "--frames", "30", "-q"]) == 0
    out = folder.parent / f"{folder.name}.json"
    assert main(["track", str(folder), "--json", str(out), "-q"]) == 0
    return [f for f in json.loads(out.read_text())["frames"] if f["status"] == "lost"]


def _phrases(text, n=5):
    words = re.sub(r"[\d.,;:()-]+", " ", text).split()
    return [" ".join(words[i:i + n]) for i in range(len(words) - n + 1)]


@pytest.mark.slow  # tracks a rendered sequence with lost frames through the CLI
def test_each_lost_frame_says_each_phrase_once(lost_frames):
    assert len(lost_frames) >= 10  # the sequence's excursions
    for frame in lost_frames:
        message = frame["message"]
        phrases = _phrases(message)
        assert len(phrases) == len(set(phrases)), message
        assert message.count("no checkerboard") <= 2 and len(message) <= 260, message


def test_a_track_without_any_pose_says_why_on_stderr(tmp_path, capsys):
    folder = tmp_path / "blank"
    folder.mkdir()
    for k in range(2):
        write_png(folder / f"f{k}.png", np.full((48, 64), 128, np.uint8))
    assert main(["track", str(folder), "--K", K_OPTION]) == 1
    out, err = err_lines(capsys)
    assert "lost 2" in out
    assert len(err) == 1 and err[0].startswith("graphpose track: error: no pose in any of the 2 frames; the "
                                               "first lost, frame 0: ")
    assert "junction-like points" in err[0] or "no checkerboard" in err[0]


# --- one prefix, every help's exit codes ----------------------------------------------------


@pytest.mark.parametrize("command", [
    ["estimate", "missing.png", "--K", K_OPTION],
    ["track", "missing.png", "--K", K_OPTION],
    ["batch", "images/", "--out", "r.txt", "--K", K_OPTION],
    ["calibrate", "missing.png", "--board", "9x6x25mm", "--out", "c.json"],
    ["render-sequence", "seq", "--frames", "1"],
])
def test_every_command_prefixes_its_errors_with_its_name(command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(command) == 2
    _, err = err_lines(capsys)
    assert len(err) == 1 and err[0].startswith(f"graphpose {command[0]}: error: "), err
    if command[0] in ("estimate", "track", "calibrate"):
        assert "image file not found: missing.png" in err[0]  # one spelling


def test_every_help_gives_the_exit_codes_with_130(capsys):
    parser = build_parser()
    helps = [parser.format_help()] + [sub.format_help() for sub in
                                      next(a for a in parser._actions if a.dest == "command").choices.values()]
    for text in helps:
        text = " ".join(text.split())
        assert re.search(r"exit codes: 0 success,.* 2 bad usage or input.*130 interrupted", text), text



@pytest.mark.parametrize("columns", [None, "50", "120", "junk"])
def test_help_is_wrapped_as_argparse_wraps_it(columns, monkeypatch):
    """graphpose's formatter sizes help without shutil, by argparse's own rule ($COLUMNS, else
    the terminal, else 80; less 2): the same help, word for word, as argparse's formatter."""
    import argparse

    from graphpose.cli import HelpFormatter

    if columns is None:
        monkeypatch.delenv("COLUMNS", raising=False)
    else:
        monkeypatch.setenv("COLUMNS", columns)

    def help_with(formatter):
        parser = argparse.ArgumentParser(prog="graphpose x", formatter_class=formatter, description="A\n  raw line")
        parser.add_argument("--long", metavar="VALUE", help=" ".join(["a word of help"] * 30))
        return parser.format_help()

    ours = help_with(HelpFormatter)
    assert ours == help_with(argparse.RawDescriptionHelpFormatter)
    assert "A\n  raw line" in ours

"""``graphpose batch`` as a user runs it: its options and errors, the default local cluster, and
a second run that has nothing left to do. The cluster behaviour itself (many images, lost
workers, stopped clients) is tested in tests/batch/."""

import json
import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest

from graphpose import Board
from graphpose.batch import read_results
from graphpose.cli import main
from graphpose.image import read_image
from graphpose.estimate import estimate_pose
from graphpose.synth.poses import loose_polygon, random_pose
from graphpose.synth.render import render
from tests.batch.helpers import SIZE, assert_same_pose, half_K
from tests.conftest import opencv_file

pytest.importorskip("distributed")


def graphpose(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "graphpose", *map(str, args)], cwd=cwd, check=False,
                          capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def same_pose_images(tmp_path_factory):
    """Three 320 x 240 images of one pose (their noise differs), one polygon for all, and the
    single-image estimate of each."""
    folder = tmp_path_factory.mktemp("same-pose")
    K, board = half_K(), Board()
    rng = np.random.default_rng(11)
    T = random_pose(K, board, SIZE, rng=rng)
    poly = None
    for k in range(3):
        rendering = render(K, T, board, SIZE, rng=rng)
        poly = loose_polygon(rendering, rng=rng) if poly is None else poly
        iio.imwrite(folder / f"frame_{k}.png", rendering.image)
    expected = {str(p): estimate_pose(read_image(p, as_float=False), K, bounds=poly, board=board) for p in sorted(folder.glob("*.png"))}
    return folder, K, poly, expected


@pytest.mark.slow  # 0.6 s or so on two idle cores: a render, a calibration or a subprocess
def test_importing_and_parsing_loads_no_dask_nor_pyarrow():
    code = ("import sys, graphpose, graphpose.batch, graphpose.cli.batch; from graphpose.cli import build_parser; "
            "build_parser(); heavy = sorted({m.split('.')[0] for m in sys.modules} & {'dask', 'distributed', "
            "'pyarrow'}); print(heavy); sys.exit(1 if heavy else 0)")
    done = subprocess.run([sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr


def test_help_names_the_options(capsys):
    assert main(["batch", "--help"]) == 0
    text = capsys.readouterr().out
    for option in ("--out", "--K", "--board", "--bounds-file", "--workers", "--scheduler", "--images-per-task",
                   "--flush-seconds", "dask scheduler"):
        assert option in text


@pytest.mark.parametrize("extra, fragment", [
    (["--out", "r.csv"], "must end in .parquet"),
    (["--out", "nowhere/r.jsonl"], "does not exist"),
    (["--out", "r.jsonl", "--workers", "0"], "--workers: expected a whole number >= 1"),
    (["--out", "r.jsonl", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "not allowed with"),
    (["--out", "r.jsonl", "--bounds", "0,0,1,0,1,1,0,1", "--bounds-file", "b.json"], "not allowed with"),
    (["--out", "r.jsonl", "--bounds-file", "b.json"], "names none of the 3 images"),
    (["--out", "r.jsonl", "--images-per-task", "x"], "--images-per-task"),
])
def test_usage_errors_stop_before_any_cluster(same_pose_images, tmp_path, monkeypatch, capsys, extra, fragment):
    folder = same_pose_images[0]
    monkeypatch.chdir(tmp_path)
    (tmp_path / "b.json").write_text('{"elsewhere.png": null}')
    assert main(["batch", str(folder), "--K", "300,300,160,120", *extra]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0], lines
    assert not (tmp_path / "r.jsonl").exists()


def test_missing_inputs_are_an_error(tmp_path, capsys):
    assert main(["batch", str(tmp_path / "*.png"), "--out", str(tmp_path / "r.jsonl"), "--K", "300,300,160,120"]) == 2
    assert "matches no file" in capsys.readouterr().err


@pytest.mark.slow  # a local Dask cluster run twice
def test_local_cluster_run_then_a_second_run_with_nothing_left(same_pose_images, tmp_path):
    folder, K, poly, expected = same_pose_images
    out = tmp_path / "r.jsonl"
    k_option = ",".join(repr(float(v)) for v in (K[0, 0], K[1, 1], K[0, 2], K[1, 2]))
    bounds = ",".join(repr(float(x)) for x in poly.T.ravel())
    args = ["batch", folder, "--out", out, "--K", k_option, "--bounds", bounds, "--workers", "1"]
    first = graphpose(*args)
    assert first.returncode == 0, first.stderr
    assert first.stdout.startswith("3 images: 3 ok; 0 skipped"), first.stdout
    rows = read_results(out)
    assert sorted(r["image"] for r in rows) == sorted(expected)
    for row in rows:
        assert_same_pose(row, expected[row["image"]])
    second = graphpose(*args)
    assert second.returncode == 0, second.stderr
    assert second.stdout.startswith("0 images: 0 ok; 3 skipped"), second.stdout
    assert read_results(out) == rows


# --- the resume key and the exit code, from rows already in a result set (no cluster needed) --


def _k_text(K):
    return ",".join(repr(float(v)) for v in (K[0, 0], K[1, 1], K[0, 2], K[1, 2]))


@pytest.fixture
def done_before(same_pose_images, tmp_path):
    """A result set holding the three images' rows, made with their K, the default board and
    the polygon, plus a blank image's row (no board: board_not_found); the command that made it."""
    from graphpose.batch import open_results
    from graphpose.batch.work import estimate_images
    from graphpose.io.files import encode_png

    folder, K, poly, _ = same_pose_images
    blank = tmp_path / "blank" / "blank.png"
    blank.parent.mkdir()
    blank.write_bytes(encode_png(np.full((240, 320), 128, np.uint8)))
    paths = [str(p) for p in sorted(folder.glob("*.png"))] + [str(blank)]
    out = tmp_path / "r.jsonl"
    with open_results(out) as results:
        for row in estimate_images([(p, poly) for p in paths], K, Board()):
            results.write(row)
    bounds = ",".join(repr(float(x)) for x in poly.T.ravel())
    return out, ["batch", str(folder), str(blank), "--out", str(out), "--K", _k_text(K), "--bounds", bounds]


def test_a_rerun_with_the_same_parameters_skips_and_exits_1_while_an_image_has_no_pose(done_before, capsys):
    out, command = done_before
    assert main(command) == 1  # the blank image has no pose, from the first run as from this one
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"0 images: 0 ok; 4 skipped (already in {out}: 3 ok, board_not_found 1)"
    assert lines[1].startswith("camera: --K: pinhole, fx 282.4") and "board: 8 x 6 junctions, 63.5 mm" in lines[1]


@pytest.mark.parametrize("change, words", [
    (["--board", "9x6x0.03"], "made with another board (8x6x0.0635 there, 9x6x0.03 now)"),
    (["--robust"], "made with another --robust"),
    (["--K", "300,300,160,120"], "made with another camera"),
    (["--bounds", "0,0,319,0,319,239,0,239"], "made with another bounds"),
])
@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
def test_a_rerun_with_other_parameters_is_refused_never_reported_as_done(done_before, capsys, change, words):
    out, command = done_before
    option, *value = change
    if option in command:  # another value for an option given
        command = [*command[:command.index(option) + 1], *value, *command[command.index(option) + 2:]]
    else:
        command = [*command, *change]
    assert main(command) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert f"results {out} hold 4 of these 4 images {words}" in line, line
    assert f"give another --out for these parameters, or remove {out} to redo them" in line
    assert len(read_results(out)) == 4  # nothing written


@pytest.mark.slow  # a batch of raw images on a Dask cluster
def test_raw_images_with_a_kalibr_camchain_and_a_case_file_without_bounds(tmp_path):
    # OpenCV's raw samples through the batch's own local cluster: the right camera is cam1 of the
    # camchain; the case file's cases have no bounds (searched whole). 26 of 26 in the report.
    chain = opencv_file("camchain.kalibr.yaml")
    images = [opencv_file(n) for n in ("right01.jpg", "right02.jpg")]
    cases = tmp_path / "cases.json"
    cases.write_text(json.dumps({"cases": [{"image": str(p)} for p in images]}))
    out = tmp_path / "r.jsonl"
    done = graphpose("batch", *images, "--camera", chain, "--camera-name", "cam1", "--board", "9x6x0.03",
                     "--bounds-file", cases, "--out", out, "--workers", "1")
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("2 images: 2 ok; 0 skipped"), done.stdout
    assert f"camera: {chain} (cam1): radtan lens, fx 536.8" in done.stdout
    rows = read_results(out)
    assert {r["status"] for r in rows} == {"ok"} and {r["bounds"] is None for r in rows} == {True}
    assert rows[0]["camera"]["file"] == str(chain) and rows[0]["camera"]["name"] == "cam1"
    assert rows[0]["board"] == {"cols": 9, "rows": 6, "square_m": 0.03}

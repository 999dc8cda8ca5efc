"""``graphpose track`` as a user runs it (in process): frames in, TUM, JSON, picture and summary out."""

import json
import shutil

import numpy as np
import pytest
from skimage.io import imread

from graphpose import read_tum, render_sequence, write_sequence
from graphpose.cli import main
from graphpose.io.files import write_png
from graphpose.io.tum import write_tum
from graphpose.estimate import pose_difference
from tests.conftest import opencv_file
from tests.conftest import PROJECT_K
from tests.helpers import PROJECT_K_OPTION as K_OPTION


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """A folder written by 'graphpose render-sequence' (8 frames, no pan) and its --bounds."""
    folder = tmp_path_factory.mktemp("rendered") / "seq"
    assert main(["render-sequence", str(folder), "--frames", "8", "--excursions", "0", "--seed", "1", "-q"]) == 0
    meta = json.loads((folder / "bounds.json").read_text())
    return folder, ",".join(f"{u},{v}" for u, v in zip(*meta["bounds"]))


#: The rendered frames' camera (render-sequence's, the project's) as --K: frames copied out of
#: their folder no longer bring it.


def _copy_frames(folder, to):
    """The frames of ``folder`` alone (no truth.tum, no bounds.json) in a new folder ``to``."""
    to.mkdir()
    for path in sorted(folder.glob("frame_*.png")):
        shutil.copy(path, to / path.name)
    return to


@pytest.mark.slow  # renders and tracks a sequence through the CLI
def test_render_sequence_then_track(rendered, tmp_path, capsys):
    folder, bounds = rendered
    tum, out = tmp_path / "est.tum", tmp_path / "est.json"
    assert main(["track", str(folder), "--bounds", bounds, "--tum", str(tum), "--json", str(out), "--smooth"]) == 0
    summary = capsys.readouterr().out
    assert summary.startswith("8 frames: tracked ") and ", lost 0 (smoothed)" in summary
    est, truth = read_tum(tum), read_tum(folder / "truth.tum")
    np.testing.assert_allclose(est.timestamps, truth.timestamps, atol=1e-6)
    assert max(pose_difference(E, T)[0] for E, T in zip(est.poses, truth.poses)) < 1e-3
    frames = json.loads(out.read_text())["frames"]
    assert frames[0]["status"] == "detected" and "tracked" in [f["status"] for f in frames[1:]]
    assert all(f["junctions_used"] == 48 and len(f["sigma_xyz_m"]) == 3 for f in frames)
    # The folder's own truth is picked up, said so, and measured against.
    line = next(s for s in summary.splitlines() if s.startswith("truth:"))
    assert f"{folder / 'truth.tum'} (the rendered sequence's own" in line and "over 8 frames" in line


@pytest.mark.slow  # tracks a rendered folder through the CLI
def test_an_unreadable_frame_is_lost_and_the_rest_written(rendered, tmp_path, capsys):
    # One corrupt frame used to end the run with exit 2 and nothing written.
    frames = _copy_frames(rendered[0], tmp_path / "frames")
    tum, out = tmp_path / "est.tum", tmp_path / "est.json"
    assert main(["track", str(frames), "--bounds", rendered[1], "--K", K_OPTION, "--json", str(out), "-q"]) == 0
    intact = [r["status"] for r in json.loads(out.read_text())["frames"]]
    (frames / "frame_00004.png").write_bytes(b"\x89PNG\r\n\x1a\n cut short")
    assert main(["track", str(frames), "--bounds", rendered[1], "--K", K_OPTION, "--tum", str(tum),
                 "--json", str(out)]) == 0
    summary = capsys.readouterr().out
    assert "lost frames: 4" in summary and "unreadable frame files (lost): 4" in summary
    records = json.loads(out.read_text())["frames"]
    # The frame after the loss is found again by extraction; the others as in the intact run.
    assert [r["status"] for r in records] == intact[:4] + ["lost", "detected"] + intact[6:]
    assert "unreadable" in records[4]["message"] and "frame_00004.png" in records[4]["message"]
    assert len(read_tum(tum)) == 7
    # Nothing readable at all: every frame lost, exit 1, the files still written.
    for path in frames.glob("*.png"):
        path.write_bytes(b"garbage")
    assert main(["track", str(frames), "--K", K_OPTION, "--tum", str(tum), "-q"]) == 1
    assert len(read_tum(tum)) == 0


@pytest.mark.slow  # 0.7 s or so on two idle cores: a render, a calibration or a subprocess
def test_counter_clockwise_bounds_are_the_same_input_error_in_estimate_and_track(rendered, capsys):
    folder, bounds = rendered
    values = bounds.split(",")
    reverse = ",".join(",".join(values[2 * i:2 * i + 2]) for i in (3, 2, 1, 0))
    first = folder / "frame_00000.png"
    assert main(["estimate", str(first), "--bounds", reverse, "--K", K_OPTION]) == 2
    estimate_error = capsys.readouterr().err.strip().splitlines()[-1]
    assert main(["track", str(folder), "--bounds", reverse]) == 2
    track_error = capsys.readouterr().err.strip().splitlines()[-1]
    assert ("bounds must run clockwise (in the image, v down), starting at the corner nearest junction 0; "
            "these corners run counter-clockwise") in track_error
    assert estimate_error.endswith(track_error.split("error: ", 1)[1])


@pytest.mark.slow  # 1.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_plot_draws_the_truth_where_it_is_known(rendered, tmp_path, capsys, monkeypatch):
    # --plot never drew the truth, although the picture's title promised it. (That a truth
    # given to plot_track is drawn: tests/viz/test_plot.py.)
    from graphpose.viz import plot

    drawn = []
    monkeypatch.setattr(plot, "plot_track", lambda track, path, **kw: drawn.append((path, kw)))
    folder, bounds = rendered
    truth = read_tum(folder / "truth.tum")
    assert main(["track", str(folder), "--bounds", bounds, "--plot", str(tmp_path / "own.png"), "-q"]) == 0
    np.testing.assert_array_equal(drawn[-1][1]["truth"], truth.poses)
    assert "truth" in drawn[-1][1]["title"]
    # The same frames without the folder's truth: nothing to draw, nothing said.
    frames = _copy_frames(folder, tmp_path / "frames")
    assert main(["track", str(frames), "--bounds", bounds, "--K", K_OPTION, "--plot", str(tmp_path / "bare.png")]) == 0
    assert drawn[-1][1]["truth"] is None and "truth:" not in capsys.readouterr().out
    # The truth given by hand, shuffled and with a line of no frame: matched by timestamp.
    order = np.r_[8, np.arange(8)[::-1]]
    write_tum(tmp_path / "truth.tum", np.r_[truth.timestamps, 99.0][order],
              np.concatenate([truth.poses, truth.poses[:1]])[order])
    assert main(["track", str(frames), "--bounds", bounds, "--K", K_OPTION, "--plot", str(tmp_path / "given.png"), "--truth",
                 str(tmp_path / "truth.tum")]) == 0
    np.testing.assert_allclose(drawn[-1][1]["truth"], truth.poses, atol=1e-8)
    assert "(8 of 8 frames matched by timestamp)" in capsys.readouterr().out


@pytest.mark.slow  # tracks a sequence and draws it with matplotlib
def test_plot_is_written(rendered, tmp_path):
    folder, bounds = rendered
    out = tmp_path / "track.png"
    assert main(["track", str(folder), "--bounds", bounds, "--plot", str(out), "-q"]) == 0
    assert imread(out).shape[:2] == (750, 1100)


def test_a_truth_matching_no_frame_is_an_input_error(rendered, tmp_path, capsys):
    folder = rendered[0]
    truth = read_tum(folder / "truth.tum")
    write_tum(tmp_path / "late.tum", truth.timestamps + 100.0, truth.poses)
    assert main(["track", str(folder), "--truth", str(tmp_path / "late.tum"), "-q"]) == 2
    assert "none of its 8 poses has the timestamp of a frame" in capsys.readouterr().err
    assert main(["track", str(folder), "--truth", str(tmp_path / "missing.tum"), "-q"]) == 2
    assert "missing.tum" in capsys.readouterr().err


def test_usage_errors(tmp_path, capsys):
    assert main(["track", str(tmp_path)]) == 2
    assert "no image files" in capsys.readouterr().err
    assert main(["track", str(tmp_path / "a.png"), "--bounds", "1,2,3"]) == 2
    assert "bounds needs 8 numbers" in capsys.readouterr().err
    assert main(["track", str(tmp_path / "a.png"), str(tmp_path / "b.png")]) == 2
    assert "image file not found: " in capsys.readouterr().err
    assert main(["track", str(tmp_path), "--fps", "0"]) == 2
    assert "--fps: expected a positive number, got '0'" in capsys.readouterr().err


@pytest.fixture
def blank_frames(tmp_path):
    """Two frames without a board."""
    folder = tmp_path / "blank"
    folder.mkdir()
    for k in range(2):
        write_png(folder / f"f{k}.png", np.full((48, 64), 128, np.uint8))
    return folder


def test_exits_1_when_every_frame_is_lost(blank_frames, tmp_path, capsys):
    tum = tmp_path / "est.tum"
    assert main(["track", str(blank_frames), "--K", K_OPTION, "--tum", str(tum)]) == 1
    assert "2 frames: tracked 0, detected 0, lost 2" in capsys.readouterr().out
    assert len(read_tum(tum)) == 0


@pytest.mark.parametrize(
    "document, message",
    [(None, "--polygons file not found"), ("{not json", "cannot read --polygons file"),
     ('{"0": null}', "must hold a JSON list"), ('[[[1, 2, 3, 4], [1, 2]], null]', "entry 0 must be a rectangular"),
     ('[null, [["a", "b", "c", "d"], [1, 2, 3, 4]]]', "entry 1 must be a rectangular"),
     ('[[[1, 2, 3], [1, 2, 3]], null]', "polygons[0] must have shape (2, 4)"),
     ('[null, [[60, 10, 10, 60], [5, 5, 40, 40]]]', "polygons[1] must run clockwise"),
     ("[null]", "polygons has 1 entries for 2 frames")],
)
def test_rejects_bad_polygons_files(blank_frames, tmp_path, capsys, document, message):
    path = tmp_path / "polygons.json"
    if document is not None:
        path.write_text(document)
    assert main(["track", str(blank_frames), "--polygons", str(path), "--K", K_OPTION]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("option", ["--tum", "--json", "--plot"])
def test_refuses_output_into_a_missing_folder(blank_frames, tmp_path, capsys, option):
    assert main(["track", str(blank_frames), option, str(tmp_path / "no" / "out")]) == 2
    assert f"{option}: folder {tmp_path / 'no'} does not exist" in capsys.readouterr().err


@pytest.mark.slow  # tracks a rendered sequence three times
def test_all_cpp_back_end_and_robust_fit_match_the_default(tmp_path):
    # frame_landmarks + wnoa (every factor in GTSAM's C++), and --robust (the single-image
    # fit's Huber gate), through the whole tracker on rendered frames: same statuses, and
    # poses within what the motion priors and the pixel sigmas allow.
    K = PROJECT_K
    seq = render_sequence(K, 8, rng=5, excursions=0)
    folder = write_sequence(seq, tmp_path / "seq")
    bounds = ",".join(f"{u:.3f},{v:.3f}" for u, v in seq.bounds.T)
    runs = {}
    for name, extra in (("default", []), ("cpp", ["--motion", "wnoa", "--target", "frame_landmarks"]),
                        ("robust", ["--robust"])):
        out = tmp_path / f"{name}.tum"
        assert main(["track", str(folder), "--bounds", bounds, "--tum", str(out), "-q", *extra]) == 0
        runs[name] = read_tum(out)
    for name in ("cpp", "robust"):
        np.testing.assert_array_equal(runs[name].timestamps, runs["default"].timestamps)
        assert len(runs[name].timestamps) == 8
        # Regression guard, from an earlier run of this test: 5 um apart (the priors differ), 0.1 mm from the truth.
        np.testing.assert_allclose(runs[name].poses[:, :3, 3], runs["default"].poses[:, :3, 3], atol=2e-5)
        np.testing.assert_allclose(runs[name].poses[:, :3, 3], seq.T_WC[:, :3, 3], atol=3e-4)


def test_raw_frames_with_their_calibration_file(tmp_path, capsys):
    # Three of OpenCV's raw samples as a (jumpy) sequence: each frame found again, through the
    # left camera's lens model, and the JSON names the camera.
    frames = [opencv_file(f"left0{k}.jpg") for k in (1, 2, 3)]
    out = tmp_path / "out.json"
    code = main(["track", *map(str, frames), "--camera", str(opencv_file("left.opencv.yml")), "--board", "9x6x0.03",
                 "--json", str(out), "-q"])
    assert code == 0, capsys.readouterr().err
    doc = json.loads(out.read_text())
    assert doc["camera"]["model"] == "radtan" and doc["camera"]["size"] == [640, 480]
    assert doc["K"] == doc["camera"]["K"]
    for record in doc["frames"]:
        assert record["status"] in ("tracked", "detected") and record["junctions_used"] == 54
        assert record["reprojection_rms_px"] < 0.2
    assert main(["track", *map(str, frames), "--camera", str(opencv_file("left.opencv.yml")), "--K", "533,533,341,235"]) == 2
    assert "not both" in capsys.readouterr().err


def test_lag_is_recorded_and_none_gives_the_whole_sequence_graph(rendered, tmp_path, capsys):
    folder, bounds = rendered
    poses = {}
    for lag in ("0.1", "none"):
        out = tmp_path / f"lag_{lag}.json"
        assert main(["track", str(folder), "--bounds", bounds, "--lag", lag, "--json", str(out), "-q"]) == 0
        doc = json.loads(out.read_text())
        assert doc["lag_s"] == (None if lag == "none" else 0.1)
        poses[lag] = np.array([f["T_WC"] for f in doc["frames"]])
    # A lag of three frames marginalises most of this 8-frame clip; the online poses differ
    # from the whole graph's only by the linearisation frozen in the marginal priors.
    np.testing.assert_allclose(poses["0.1"], poses["none"], atol=1e-5)
    # A slow sequence gets a lag long enough for its motion prior: twice the 3 frames'
    # span of the constant-velocity prior at 0.5 fps.
    out = tmp_path / "slow.json"
    assert main(["track", str(folder), "--bounds", bounds, "--fps", "0.5", "--json", str(out), "-q"]) == 0
    assert json.loads(out.read_text())["lag_s"] == 8.0
    assert main(["track", str(folder), "--bounds", bounds, "--fps", "0.5", "--lag", "1"]) == 2
    assert "lag_s = 1 s is shorter than" in capsys.readouterr().err
    for bad in ("0", "-1", "soon"):
        assert main(["track", str(folder), "--bounds", bounds, "--lag", bad]) == 2
        assert "--lag" in capsys.readouterr().err

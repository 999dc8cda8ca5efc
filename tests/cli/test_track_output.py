"""``graphpose track``'s outputs as they stream: the same bytes as the whole-sequence writers,
whole files or none, and the kind of sigma in every record."""

import io
import json

import numpy as np
import pytest

from graphpose import K_from_params
from graphpose.camera_models import PinholeCamera
from graphpose.cli import main
from graphpose.cli.track_output import JsonStream, TrackSummary
from graphpose.io.tum import TumStream
from graphpose.errors import InputError
from graphpose.geometry import T_from_params
from graphpose.io.cameras import write_camera
from graphpose.io.files import write_json, write_png
from graphpose.io.tum import write_tum
from graphpose.track.results import FrameResult


def _poses(n, rng):
    return [T_from_params(np.r_[rng.normal(size=3), rng.uniform(-3, 3, size=3)]) for _ in range(n)]


@pytest.mark.parametrize("n", [0, 1, 7])
def test_tum_stream_writes_write_tums_bytes(tmp_path, n):
    rng = np.random.default_rng(n)
    t, T = np.sort(rng.uniform(0, 100, n)), _poses(n, rng)
    write_tum(tmp_path / "whole.tum", t, T, header="a header\nof two lines")
    stream = TumStream(tmp_path / "stream.tum")
    for tk, Tk in zip(t, T):
        stream.add(tk, Tk)
    assert not (tmp_path / "stream.tum").exists()  # whole or not at all
    stream.close("a header\nof two lines")
    assert (tmp_path / "stream.tum").read_bytes() == (tmp_path / "whole.tum").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stream.tum", "whole.tum"]  # no temporary left


def test_tum_stream_refuses_a_bad_pose_and_leaves_nothing(tmp_path):
    stream = TumStream(tmp_path / "bad.tum")
    with pytest.raises(InputError, match="T_WC"):
        stream.add(0.0, np.ones((4, 4)))
    stream.abort()
    assert list(tmp_path.iterdir()) == []


def test_json_stream_writes_write_jsons_bytes(tmp_path, monkeypatch):
    records = [{"index": k, "T_WC": np.eye(4) * k, "message": None, "xyz_m": [0.1, float("nan"), k]} for k in range(3)]
    rest = {"smoothed": True, "K": np.eye(3), "camera": {"model": "pinhole", "size": [640, 480]}, "lag_s": None}
    for frames in (records, []):
        write_json(tmp_path / "whole.json", {"frames": frames, **rest})
        stream = JsonStream(tmp_path / "stream.json")
        for r in frames:
            stream.add(r)
        stream.close(rest)
        assert (tmp_path / "stream.json").read_text() == (tmp_path / "whole.json").read_text()
    out = io.StringIO()
    monkeypatch.setattr("sys.stdout", out)
    stream = JsonStream("-")
    for r in records:
        stream.add(r)
    stream.close(rest)
    write_json(tmp_path / "whole.json", {"frames": records, **rest})
    assert out.getvalue() == (tmp_path / "whole.json").read_text()
    aborted = JsonStream(tmp_path / "aborted.json")
    aborted.add(records[0])
    aborted.abort()
    assert not (tmp_path / "aborted.json").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stream.json", "whole.json"]


def test_summary_counts_as_it_goes():
    summary = TrackSummary()
    summary.add(FrameResult(0, 0.0, "detected", np.eye(4), np.eye(6) * 1e-8, 48, 0.01, frontend_s=0.004,
                            update_s=0.001))
    summary.add(FrameResult(1, 0.1, "lost", message="unreadable frame file: x.png"))
    text = summary.text(False)
    assert text.splitlines()[0] == "2 frames: tracked 0, detected 1, lost 1"
    assert "median 5.0 ms a frame" in text and "lost frames: 1" in text and "unreadable frame files (lost): 1" in text


@pytest.mark.slow  # tracks a rendered sequence through the CLI
def test_records_say_the_kind_of_sigma(tmp_path, capsys):
    # A rendered sequence with a calibrated camera file: each record says its sigmas include
    # the calibration, with the pixel noise's share beside them, and the sigmas are larger.
    folder = tmp_path / "seq"
    assert main(["render-sequence", str(folder), "--frames", "4", "--excursions", "0", "--seed", "2", "-q"]) == 0
    K = np.array(json.loads((folder / "bounds.json").read_text())["K"])
    plain = PinholeCamera(K)
    camera = plain.with_parameters(plain.parameters, np.diag([0.25, 0.25, 0.16, 0.16]))
    write_camera(tmp_path / "camera.json", camera)
    docs = {}
    for name, option in (("plain", ["--K", ",".join(f"{v}" for v in (K[0, 0], K[1, 1], K[0, 2], K[1, 2]))]),
                         ("calibrated", ["--camera", str(tmp_path / "camera.json")])):
        out = tmp_path / f"{name}.json"
        assert main(["track", str(folder), *option, "--json", str(out), "-q"]) == 0, capsys.readouterr().err
        docs[name] = json.loads(out.read_text())["frames"]
    for p, c in zip(docs["plain"], docs["calibrated"]):
        assert p["sigma_kind"] == "pixel noise" and p["sigma_pixel_xyz_m"] == p["sigma_xyz_m"]
        assert c["sigma_kind"] == "pixel noise and calibration"
        np.testing.assert_allclose(c["sigma_pixel_xyz_m"], p["sigma_xyz_m"], rtol=1e-6)
        assert np.all(np.array(c["sigma_xyz_m"]) > np.array(c["sigma_pixel_xyz_m"]))
        assert np.all(np.array(c["sigma_rpy_deg"]) > np.array(c["sigma_pixel_rpy_deg"]))


@pytest.mark.slow  # tracks a rendered sequence through the CLI
def test_a_run_stopped_by_an_error_leaves_no_file(tmp_path, capsys):
    # Frame 2 of another size stops the run when it is reached, after two frames were written
    # to the temporary files: exit 2, and neither file nor temporary is left.
    folder = tmp_path / "seq"
    assert main(["render-sequence", str(folder), "--frames", "4", "--excursions", "0", "--seed", "2", "-q"]) == 0
    K = np.array(json.loads((folder / "bounds.json").read_text())["K"])
    write_camera(tmp_path / "camera.json", PinholeCamera(K, size=(640, 480)))
    write_png(folder / "frame_00002.png", np.zeros((240, 320), dtype=np.uint8))
    out = tmp_path / "out"
    out.mkdir()
    code = main(["track", str(folder), "--camera", str(tmp_path / "camera.json"), "--tum", str(out / "t.tum"),
                 "--json", str(out / "t.json")])
    assert code == 2
    assert "frame 2" in capsys.readouterr().err
    assert list(out.iterdir()) == []


def test_abort_on_error_leaves_no_output_and_raises_again(tmp_path):
    from graphpose.cli.track_output import abort_on_error

    class Line:
        cleared = 0

        def clear(self):
            self.cleared += 1

    progress, tum, doc = Line(), TumStream(tmp_path / "t.tum"), None
    with pytest.raises(KeyboardInterrupt):
        with abort_on_error(progress, lambda: (tum, doc)):
            doc = JsonStream(tmp_path / "t.json")  # opened inside the block: aborted too
            tum.add(0.0, np.eye(4))
            raise KeyboardInterrupt
    assert progress.cleared == 1 and list(tmp_path.iterdir()) == []
    with abort_on_error(progress, lambda: (tum,)):
        pass
    assert progress.cleared == 1  # nothing to undo without an error

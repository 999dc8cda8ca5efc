import json

import numpy as np
import pytest

from graphpose import Board, InputError, project
from graphpose.io.tum import read_tum
from graphpose.synth.sequence import (
    HandHeldMotion,
    render_sequence,
    visible_junctions,
    write_sequence,
)
from tests.conftest import PROJECT_K as K


@pytest.fixture(scope="module")
def short():
    return render_sequence(K, 6, rng=3, excursions=0, supersample=1)


@pytest.mark.slow  # renders a sequence
def test_short_sequence_truth(short):
    assert short.images.shape == (6, 480, 640) and short.images.dtype == np.uint8
    np.testing.assert_allclose(short.timestamps, np.arange(6) / 30.0)
    assert np.all(short.visible == 48) and short.in_view.all() and not short.out_of_view.any()
    assert np.all(short.subframes >= 1)
    # The first polygon hugs the first frame's sheet, and the board is in front at 0.6-1.3 m.
    centre = Board().world_points().mean(axis=1, keepdims=True)
    for T in short.T_WC:
        d = np.linalg.norm(T[:3, 3] - centre[:, 0])
        assert 0.55 < d < 1.35
    uv = project(K, short.T_WC[0], Board().world_points())
    assert np.all((uv.min(axis=1) > short.bounds.min(axis=1)) & (uv.max(axis=1) < short.bounds.max(axis=1)))


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
def test_board_is_dark_where_truth_says(short):
    # Grey level at the middle of the upper-left (black) square is darker than the next (white).
    s = Board().square_m
    uv = project(K, short.T_WC[2], np.array([[-s / 2, s / 2], [-s / 2, -s / 2], [0, 0]]))
    grey = short.images[2][np.rint(uv[1]).astype(int), np.rint(uv[0]).astype(int)]
    assert grey[0] + 80 < grey[1]


def test_motion_is_smooth_and_excursions_leave_view():
    rng = np.random.default_rng(5)
    motion = HandHeldMotion(K, Board(), (640, 480), 10.0, excursions=2, rng=rng)
    poses = np.array([motion(k / 30) for k in range(300)])
    steps = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1)
    assert steps.max() < 0.03  # < 0.9 m/s
    W = Board().world_points()
    visible = np.array([visible_junctions(K, T, W, (640, 480)) for T in poses])
    out = np.flatnonzero(visible == 0)
    assert out.size >= 4
    # Two separate runs of out-of-view frames, full view before and after each.
    runs = np.split(out, np.flatnonzero(np.diff(out) > 1) + 1)
    assert len(runs) == 2
    for run in runs:
        assert visible[run[0] - 10] == 48 and visible[run[-1] + 10] == 48


@pytest.mark.slow  # renders a long sequence with excursions out of view
def test_out_of_view_frames_render(tmp_path):
    seq = render_sequence(K, 40, rng=1, excursions=1, supersample=1, noise_sigma=0.0)
    assert seq.out_of_view.any()
    # With the board out of view the image is background only: smooth, no dark squares.
    k = np.flatnonzero(seq.out_of_view)[len(np.flatnonzero(seq.out_of_view)) // 2]
    assert seq.images[k].min() > 40


@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
def test_write_sequence_round_trip(short, tmp_path):
    out = write_sequence(short, tmp_path / "seq")
    assert sorted(p.name for p in out.glob("*.png")) == [f"frame_{k:05d}.png" for k in range(6)]
    truth = read_tum(out / "truth.tum")
    np.testing.assert_allclose(truth.poses, short.T_WC, atol=1e-8)
    np.testing.assert_allclose(truth.timestamps, short.timestamps, atol=1e-6)
    meta = json.loads((out / "bounds.json").read_text())
    np.testing.assert_allclose(meta["bounds"], short.bounds)
    np.testing.assert_allclose(meta["K"], K)
    assert Board.parse(meta["board"]) == Board() and meta["out_of_view"] == []
    from graphpose.image import read_image

    np.testing.assert_array_equal(read_image(out / "frame_00003.png"), short.images[3])  # uint8, as written


@pytest.mark.parametrize(
    "kwargs, message",
    [({"n_frames": 1}, "n_frames"), ({"n_frames": 5.0}, "n_frames"), ({"fps": 0.0}, "fps"),
     ({"excursions": -1}, "excursions"), ({"noise_sigma": -1.0}, "noise_sigma"),
     ({"blur_sigma": float("nan")}, "blur_sigma"), ({"blur_threshold_px": -2.0}, "blur_threshold_px"),
     ({"size": (640,)}, "size"), ({"size": (640, 0)}, "size height"), ({"distance": (1.3, 0.6)}, "low <= high, low > 0"),
     ({"distance": (0.0, 1.0)}, "low <= high, low > 0"), ({"distance": 1.0}, r"distance must be a pair \(near, far\)"),
     ({"distance": ("a", 1.0)}, "distance must be a pair \\(near, far\\)"), ({"max_subframes": 0}, "max_subframes"),
     ({"supersample": 0}, "supersample"), ({"rng": -1}, "rng must be"), ({"board": "8x6"}, "board must be")],
)
def test_render_sequence_rejects(kwargs, message):
    with pytest.raises(InputError, match=message):
        render_sequence(K, **{"n_frames": 5, **kwargs})


def test_write_sequence_failures_are_input_errors(short, tmp_path):
    (tmp_path / "file").write_text("in the way")
    with pytest.raises(InputError, match="cannot create folder .*file"):
        write_sequence(short, tmp_path / "file")
    (tmp_path / "seq" / "frame_00002.png").mkdir(parents=True)  # a folder where a frame goes
    with pytest.raises(InputError, match="cannot write .*frame_00002.png"):
        write_sequence(short, tmp_path / "seq")
    assert not (tmp_path / "seq" / "truth.tum").exists()

"""The trajectory picture (graphpose.viz.plot, the plot extra); ``graphpose track --plot`` in
tests/cli/test_track.py."""

import sys

import numpy as np
import pytest
from skimage.io import imread

from graphpose import InputError
from graphpose.geometry import T_from_params
from graphpose.track.config import TrackerConfig
from graphpose.track.results import FrameResult, Track
from graphpose.viz.plot import plot_track


def small_track(n=12, lost=(5, 6)):
    frames = []
    for k in range(n):
        T = T_from_params([0.1 + 0.01 * k, 0.1, -1.0, 0.0, 0.0, 0.01 * k])
        if k in lost:
            frames.append(FrameResult(k, k / 30.0, "lost", message="out of view"))
        else:
            frames.append(FrameResult(k, k / 30.0, "detected" if k in (0, 7) else "tracked", T_WC=T,
                                      cov=np.eye(6) * 1e-8, junctions=48, rms_px=0.01 + 1e-3 * k))
    return Track(tuple(frames), None, TrackerConfig())


@pytest.mark.slow  # a trajectory picture through matplotlib
def test_plot_track_writes_a_png_with_truth(tmp_path):
    track = small_track()
    truth = np.array([T_from_params([0.1 + 0.01 * k, 0.1, -1.0, 0.0, 0.0, 0.01 * k]) for k in range(12)])
    out = tmp_path / "track.png"
    plot_track(track, out, truth=truth, title="test")
    picture = imread(out)
    assert picture.shape[:2] == (750, 1100)
    plot_track(track, tmp_path / "no_truth.png")
    bare = imread(tmp_path / "no_truth.png")
    # Each status's colour is drawn (the path and tracked RMS blue, detected green, lost red
    # marks) and the truth adds its grey line: measured 560, 399, 165 pixels, and 469
    # against 280 grey pixels (axes text) without the truth.
    count = {name: _pixels_of(picture, name) for name in ("tracked", "detected", "lost", "truth")}
    assert min(count.values()) > 100, count
    assert count["truth"] > _pixels_of(bare, "truth") + 100


def _pixels_of(picture, status):
    from matplotlib.colors import to_rgb

    from graphpose.viz.plot import _COLOURS

    colour = np.rint(np.array(to_rgb(_COLOURS[status])) * 255)
    return int(np.sum(np.abs(picture[..., :3].astype(float) - colour).max(axis=2) <= 2))


def test_plot_track_refuses_truth_of_another_length(tmp_path):
    with pytest.raises(InputError, match="one 4 x 4 pose per frame"):
        plot_track(small_track(), tmp_path / "x.png", truth=np.zeros((3, 4, 4)))
    with pytest.raises(InputError, match="truth must be a rectangular array"):
        plot_track(small_track(), tmp_path / "x.png", truth=[np.eye(4), np.eye(3)])
    assert not (tmp_path / "x.png").exists()


def test_plot_track_without_matplotlib_says_how_to_get_it(tmp_path, monkeypatch):
    for name in [m for m in sys.modules if m.startswith("matplotlib")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # makes "import matplotlib..." fail
    with pytest.raises(InputError, match=r"pip install -e \"\.\[plot\]\""):
        plot_track(small_track(), tmp_path / "x.png")

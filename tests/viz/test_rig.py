"""graphpose.viz.rig: the rig calibration picture (the plot extra), drawn from a stand-in holding
the fields it reads; ``graphpose rig --plot`` in tests/cli/test_rig.py draws one from a real rig
calibration."""

import sys
from types import SimpleNamespace

import numpy as np
import pytest
from skimage.io import imread

from graphpose import InputError
from graphpose.camera_models import PinholeCamera
from graphpose.geometry import T_from_params
from graphpose.rig import Rig
from graphpose.viz.rig import plot_rig


def _count(picture, colour):
    """Pixels of a matplotlib colour (within 2 grey levels) in an RGB(A) picture."""
    from matplotlib.colors import to_rgb

    rgb = np.rint(np.array(to_rgb(colour)) * 255)
    return int(np.sum(np.abs(picture[..., :3].astype(float) - rgb).max(axis=2) <= 2))


class _RigCalibration(SimpleNamespace):
    """A stand-in of graphpose.calibrate.rig.RigCalibration: its fields, and its extrinsics asked."""

    def extrinsics(self):
        self.asked += 1
        return [{"camera": c, "baseline_m": float(np.linalg.norm(T[:3, 3])), "baseline_sigma_m": 1e-4}
                for c, T in enumerate(self.rig.T_C0_C) if c]


def _calibration(n_cameras, used_views):
    camera = PinholeCamera([[265.0, 0.0, 160.0], [0.0, 265.0, 120.0], [0.0, 0.0, 1.0]], size=(320, 240))
    rig = Rig([camera] * n_cameras, [T_from_params([0.1 * c, 0.0, 0.0, 0.0, 0.05 * c, 0.0]) for c in range(n_cameras)])
    rng = np.random.default_rng(1)
    views = SimpleNamespace(points=[rng.uniform(20, 300, (2, 120)) for _ in range(used_views)] + [np.zeros((2, 0))],
                            status=["used"] * used_views + ["no board"])
    return _RigCalibration(rig=rig, calibrations=[views] * n_cameras, camera_rms_px=[0.1] * n_cameras, asked=0)


@pytest.mark.slow  # two rig pictures through matplotlib (1-3 s on two loaded cores)
def test_one_panel_per_camera_and_the_rig_from_above(tmp_path):
    two = _calibration(2, used_views=1)
    plot_rig(two, tmp_path / "two.png")
    picture = imread(tmp_path / "two.png")
    assert picture.shape[:2] == (400, 1260)  # 4.2 inches a panel, a camera's each and the rig's, at 100 dpi
    assert two.asked == 1
    # Each used view in its own colour of the cycle: one view, blue dots only (orange is camera
    # 1's marker in the rig's panel, measured 232 against 51 pixels); two views, orange dots too.
    assert _count(picture, "C0") > 150 and _count(picture, "C1") < 100
    three = _calibration(3, used_views=2)
    plot_rig(three, tmp_path / "three.png")
    wide = imread(tmp_path / "three.png")
    assert wide.shape[:2] == (400, 1680)
    assert _count(wide, "C1") > 200


def test_without_matplotlib_the_picture_says_how_to_get_it(tmp_path, monkeypatch):
    for name in [m for m in sys.modules if m.startswith("matplotlib")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # makes "import matplotlib..." fail
    with pytest.raises(InputError, match=r"the rig picture needs matplotlib: pip install"):
        plot_rig(_calibration(2, used_views=1), tmp_path / "rig.png")
    assert not list(tmp_path.iterdir())

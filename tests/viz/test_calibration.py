"""graphpose.viz.calibration: the calibration and cross-validation pictures (the plot extra), drawn
from stand-ins that hold exactly the fields the pictures read; ``graphpose calibrate --plot`` in
tests/cli/test_calibrate.py draws one from a real calibration."""

import sys
from types import SimpleNamespace

import numpy as np
import pytest
from skimage.io import imread

from graphpose import InputError
from graphpose.viz.calibration import _COLOURS, plot_calibration, plot_cross_validation


def _count(picture, colour):
    """Pixels of a matplotlib colour (within 2 grey levels) in an RGB(A) picture."""
    from matplotlib.colors import to_rgb

    rgb = np.rint(np.array(to_rgb(colour)) * 255)
    return int(np.sum(np.abs(picture[..., :3].astype(float) - rgb).max(axis=2) <= 2))


def _map(step, size=(320, 240)):
    """A (us, vs, sigma) map over the image growing away from its centre, pixels."""
    us, vs = np.arange(0.0, size[0], step), np.arange(0.0, size[1], step)
    sigma = 0.02 + 1e-5 * ((us[None, :] - 160.0) ** 2 + (vs[:, None] - 120.0) ** 2)
    return us, vs, sigma


class _Calibration(SimpleNamespace):
    """A stand-in of graphpose.calibrate.result.Calibration: its fields, and which map was asked."""

    def uncertainty_map(self, step):
        self.asked.append(("intrinsics", step))
        return _map(step)

    def projection_uncertainty_map(self, step):
        self.asked.append(("projection", step))
        return _map(step)


def _calibration(joint_cov=None):
    rng = np.random.default_rng(0)
    status = ["used", "used", "rejected", "no board"]
    points = [rng.uniform(20, 300, (2, 30)) for _ in range(3)] + [np.zeros((2, 0))]
    residuals = [rng.normal(0, 0.1, (2, 30)), rng.normal(0, 0.1, (2, 30)), rng.normal(0, 0.8, (2, 30)),
                 np.zeros((2, 0))]
    return _Calibration(camera=SimpleNamespace(size=(320, 240)), status=status, points=points, residuals=residuals,
                        rms_px=0.1, image_rms_px=[0.1, 0.1, 0.8, np.nan], images=[f"/x/view_{k}.png" for k in range(4)],
                        joint_cov=joint_cov, board_distance_m=0.8, asked=[])


@pytest.mark.slow  # two calibration pictures through matplotlib (1-3 s on two loaded cores)
def test_plot_calibration_draws_each_status_and_the_map_it_has(tmp_path):
    calibration = _calibration()
    plot_calibration(calibration, tmp_path / "c.png", title="test", step=16.0)
    picture = imread(tmp_path / "c.png")
    assert picture.shape[:2] == (520, 1400)  # 14 x 5.2 inches at 100 dpi
    assert calibration.asked == [("intrinsics", 16.0)]  # no joint covariance: the intrinsics-only map
    # Used residuals and bars in blue, the rejected image's in red.
    assert _count(picture, _COLOURS["used"]) > 100
    assert _count(picture, _COLOURS["rejected"]) > 100
    # With a finite joint covariance the projection map is drawn instead.
    joint = _calibration(np.eye(3))
    plot_calibration(joint, tmp_path / "j.png", step=32.0)
    assert joint.asked == [("projection", 32.0)]
    with pytest.raises(InputError, match="missing"):  # a missing folder: no file, a clear error
        plot_calibration(_calibration(), tmp_path / "missing" / "c.png")


@pytest.mark.slow  # a cross-validation picture through matplotlib
def test_plot_cross_validation_draws_both_maps(tmp_path):
    us, vs, sigma = _map(16.0)
    half = SimpleNamespace(camera=SimpleNamespace(size=(320, 240)), status=["used"] * 5 + ["rejected"])
    cv = SimpleNamespace(diff=SimpleNamespace(us=us, vs=vs, diff_px=sigma), predicted_px=2 * sigma, median_px=0.05,
                         predicted_median_px=0.1, halves=(half, half))
    plot_cross_validation(cv, tmp_path / "cv.png")
    picture = imread(tmp_path / "cv.png")
    assert picture.shape[:2] == (460, 1200)  # 12 x 4.6 inches at 100 dpi
    # Both maps on one logarithmic viridis scale: its lowest colour (the difference map's
    # minimum) and its highest (the prediction's maximum) both appear.
    from matplotlib import colormaps

    low, high = (np.rint(np.array(colormaps["viridis"](x)[:3]) * 255) for x in (0.0, 1.0))
    assert _count(picture, low / 255) > 20 and _count(picture, high / 255) > 20


def test_without_matplotlib_each_picture_says_how_to_get_it(tmp_path, monkeypatch):
    for name in [m for m in sys.modules if m.startswith("matplotlib")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # makes "import matplotlib..." fail
    with pytest.raises(InputError, match=r"the calibration picture needs matplotlib: pip install"):
        plot_calibration(_calibration(), tmp_path / "c.png")
    with pytest.raises(InputError, match=r"the cross-validation picture needs matplotlib"):
        plot_cross_validation(SimpleNamespace(), tmp_path / "cv.png")
    assert not list(tmp_path.iterdir())

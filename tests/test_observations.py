"""graphpose.observations: check_observations, the pose problem's check at its public edge (a
camera or K, image points NaN only where the mask leaves them out, target points, a mask)."""

import numpy as np
import pytest

from graphpose import InputError
from graphpose.camera_models import PinholeCamera, RadTanCamera
from graphpose.geometry import T_from_params, project
from graphpose.observations import check_observations
from tests.conftest import BOARD_WPTS as WPTS
from tests.conftest import PROJECT_K as K

T = T_from_params([0.2, 0.15, -1.0, 0.1, -0.2, 0.3])
IPTS = project(K, T, WPTS)


def test_a_K_becomes_its_pinhole_camera_and_the_mask_defaults_to_all():
    camera, I, W, mask = check_observations(K.tolist(), IPTS.tolist(), WPTS)
    assert camera == PinholeCamera(K)
    np.testing.assert_array_equal(I, IPTS)
    np.testing.assert_array_equal(W, WPTS)
    assert mask.dtype == bool and mask.shape == (48,) and mask.all()
    lens = RadTanCamera(K, [-0.2, 0.05, 0.0, 0.0, 0.0], (640, 480))
    assert check_observations(lens, IPTS, WPTS)[0] is lens  # a camera is used as given


def test_nan_is_allowed_only_where_the_mask_leaves_the_point_out():
    I = IPTS.copy()
    I[:, [3, 9]] = np.nan  # two junctions the image does not show
    mask = np.ones(48, dtype=bool)
    mask[[3, 9]] = False
    _, I_out, _, mask_out = check_observations(K, I, WPTS, mask)
    np.testing.assert_array_equal(mask_out, mask)
    assert np.isnan(I_out[:, [3, 9]]).all()  # returned as given, not filled in
    np.testing.assert_array_equal(I_out[:, mask], IPTS[:, mask])
    mask[9] = True
    with pytest.raises(InputError, match=r"NaN or infinite values at 1 used point\(s\) \(first index 9\)"):
        check_observations(K, I, WPTS, mask)
    I[0, 20] = np.inf
    with pytest.raises(InputError, match=r"at 3 used point\(s\) \(first index 3\)"):
        check_observations(K, I, WPTS)


@pytest.mark.parametrize("change, match", [
    (lambda a: {**a, "Ipts": a["Ipts"][:, :40]}, "same number of points, got 40 and 48"),
    (lambda a: {**a, "Ipts": a["Ipts"].T}, "Ipts"),
    (lambda a: {**a, "Wpts": a["Wpts"][:2]}, r"Wpts must have shape \(3, N\)"),
    (lambda a: {**a, "mask": np.ones(47, dtype=bool)}, r"mask must be a boolean array of shape \(48,\)"),
    (lambda a: {**a, "mask": np.arange(48) < 3}, "at least 4 trusted points, got 3"),
    (lambda a: {**a, "camera": np.diag([0.0, 564.3, 1.0])}, "focal"),
])
def test_malformed_observations_are_refused(change, match):
    args = dict(camera=K, Ipts=IPTS, Wpts=WPTS, mask=None)
    with pytest.raises(InputError, match=match):
        check_observations(**change(args))

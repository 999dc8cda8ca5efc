"""graphpose.pose.rig: the rig's points and their derivatives (estimate_rig_pose on rendered rig
frames is tested in tests/test_pipeline_rig.py)."""

import numpy as np

from graphpose.geometry import T_from_params
from graphpose.pose.rig import rig_points


def test_rig_points_derivatives_match_finite_differences():
    rng = np.random.default_rng(3)
    W = rng.uniform(-0.3, 0.3, (3, 5))
    q = np.array([0.1, -0.2, -1.5, 0.3, -0.2, 0.5])
    e = np.array([0.2, 0.01, -0.03, 0.05, 0.1, -0.2])
    p, Jq, Je = rig_points(q, W, e=e)
    for k in range(6):
        d = np.zeros(6)
        d[k] = 1e-6
        num_q = (rig_points(q + d, W, e=e)[0] - rig_points(q - d, W, e=e)[0]) / 2e-6
        num_e = (rig_points(q, W, e=e + d)[0] - rig_points(q, W, e=e - d)[0]) / 2e-6
        assert np.allclose(Jq[:, :, k].T, num_q, atol=1e-8) and np.allclose(Je[:, :, k].T, num_e, atol=1e-8)
    # With the extrinsics as a matrix, the same points.
    assert np.allclose(rig_points(q, W, T_from_params(e))[0], p, atol=1e-14)

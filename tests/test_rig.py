"""graphpose.rig: a rig of cameras fixed to one another (frames, OpenCV's stereo pair, the
parameter names of its calibration) and stereo_rectify, checked against what the matrices mean:
epipolar lines through matching pixels, rows aligned after rectification, depth back from
disparity."""

import numpy as np
import pytest

from graphpose import InputError, PinholeCamera
from graphpose.geometry import T_from_params, invert_transform
from graphpose.rig import EXTRINSIC_NAMES, Rig, rig_parameter_names, stereo_rectify
from tests.io.test_rig_files import K, _rig


def points_before_both(rig, n, rng):
    """(3, n) points in camera 0's frame, 1-3 m ahead, in front of every camera of the rig."""
    P = np.vstack([rng.uniform(-0.3, 0.3, (2, n)), rng.uniform(1.0, 3.0, n)])
    for T in rig.T_C0_C:
        assert np.all((invert_transform(T) @ np.vstack([P, np.ones(n)]))[2] > 0.5)
    return P


def in_camera(rig, i, P):
    """Points of camera 0's frame in camera i's."""
    return (invert_transform(rig.T_C0_C[i]) @ np.vstack([P, np.ones(P.shape[1])]))[:3]


def test_stereo_rectify_makes_the_pair_row_aligned():
    rig = _rig(2)
    rect = stereo_rectify(rig)
    pair = rig.stereo()
    # Rectified, camera 2's origin lies on camera 1's x axis.
    t = rect["R2"] @ pair["T"]
    assert abs(t[1]) < 1e-12 and abs(t[2]) < 1e-12
    assert np.allclose(rect["R2"], rect["R1"] @ pair["R"].T, atol=1e-12)
    assert rect["P2"][0, 3] == pytest.approx(rect["P1"][0, 0] * t[0])


def test_frames_compose_as_the_docstring_says():
    rig = _rig(3)
    T01, T02 = rig.T_C0_C[1], rig.T_C0_C[2]
    np.testing.assert_allclose(rig.T_Ci_Cj(1, 2), invert_transform(T01) @ T02, atol=1e-15)
    np.testing.assert_allclose(rig.T_Ci_Cj("cam2", "cam1") @ rig.T_Ci_Cj(1, 2), np.eye(4), atol=1e-14)
    np.testing.assert_allclose(rig.T_cn_cnm1(2), rig.T_Ci_Cj(2, 1), atol=0)  # Kalibr: n-1's frame into n's
    with pytest.raises(InputError, match="camera 0 has no predecessor"):
        rig.T_cn_cnm1(0)
    # T_C0_C[1] = T_from_params([0.3, 0.01, -0.02, 0.02, -0.05, 0.01]): its length and angle.
    assert rig.baseline_m(1) == pytest.approx(np.sqrt(0.3 ** 2 + 0.01 ** 2 + 0.02 ** 2), rel=1e-14)
    T = T_from_params([0.0, 0.0, 0.0, 0.0, 0.0, 0.4])
    assert Rig(rig.cameras[:2], [np.eye(4), T]).rotation_deg(1) == pytest.approx(np.degrees(0.4), rel=1e-12)


def test_cameras_by_name_or_index():
    rig = Rig(_rig(2).cameras, _rig(2).T_C0_C, names=["left", "right"])
    assert rig.index("right") == 1 and rig.index(np.int64(0)) == 0 and len(rig) == 2
    assert rig.camera("left") is rig.cameras[0]
    with pytest.raises(InputError, match="no camera 'middle' in this rig; it holds left, right"):
        rig.index("middle")
    with pytest.raises(InputError, match="no camera 2"):
        rig.index(2)
    with pytest.raises(InputError, match="no camera True"):
        rig.index(True)  # a bool is not an index
    with pytest.raises(InputError, match="name each camera once"):
        Rig(rig.cameras, rig.T_C0_C, names=["a", "a"])
    with pytest.raises(InputError, match="at least two cameras"):
        Rig(rig.cameras[:1], rig.T_C0_C[:1])


def test_stereo_R_T_move_points_and_F_holds_matching_pixels():
    rig = _rig(3)
    P0 = points_before_both(rig, 30, np.random.default_rng(2))
    for i, j in ((0, 1), (1, 2), (2, 0)):
        pair = rig.stereo(i, j)
        Pi, Pj = in_camera(rig, i, P0), in_camera(rig, j, P0)
        np.testing.assert_allclose(pair["R"] @ Pi + pair["T"][:, None], Pj, atol=1e-13)  # p_j = R p_i + T
        # Pixels of the distortion-free cameras: x_j^T F x_i = 0 (in pixels, so relative to |F|).
        ui = rig.camera(i).pinhole().project(Pi)
        uj = rig.camera(j).pinhole().project(Pj)
        xi, xj = np.vstack([ui, np.ones(30)]), np.vstack([uj, np.ones(30)])
        residual = np.einsum("in,ij,jn->n", xj, pair["F"], xi)
        line = pair["F"] @ xi  # the epipolar line in image j: the distance of x_j from it, px
        assert np.max(np.abs(residual) / np.hypot(line[0], line[1])) < 1e-9
        # The other direction's F (the pair's transpose) does not hold these pixels: F's
        # direction, i to j, matters.
        back = rig.stereo(j, i)["F"]
        np.testing.assert_allclose(back, pair["F"].T, rtol=1e-12, atol=1e-12 * np.abs(pair["F"]).max())
        wrong = back @ xi
        off = np.abs(np.einsum("in,ij,jn->n", xj, back, xi)) / np.hypot(wrong[0], wrong[1])
        assert np.median(off) > 1.0


def test_rig_parameter_names_are_the_intrinsics_then_the_extrinsics():
    cameras = _rig(3).cameras
    names = rig_parameter_names(cameras)
    n0, n1, n2 = (len(c.parameter_names) for c in cameras)
    assert len(names) == n0 + n1 + n2 + 2 * 6
    assert names[:3] == ("cam0.fx", "cam0.fy", "cam0.cx") and names[n0] == "cam1.fx"
    assert names[-12:] == tuple(f"cam{i}.{n}" for i in (1, 2) for n in EXTRINSIC_NAMES)
    assert len(set(names)) == len(names)


@pytest.mark.parametrize("zero_disparity", [True, False])
def test_rectified_pixels_share_rows_and_disparity_gives_depth(zero_disparity):
    # Two pinhole cameras (no distortion): rectified, a point's rows agree, and Q turns its
    # pixel and disparity back into the point in camera 0's rectified frame.
    left = PinholeCamera(K, (640, 480))
    right = PinholeCamera(K + [[4.0, 0, -6.0], [0, 3.0, 5.0], [0, 0, 0]], (640, 480))
    rig = Rig([left, right], [np.eye(4), T_from_params([0.12, 0.004, -0.003, 0.01, -0.02, 0.015])])
    rect = stereo_rectify(rig, zero_disparity=zero_disparity)
    P0 = points_before_both(rig, 25, np.random.default_rng(3))
    R1P = rect["R1"] @ P0  # the point in camera 0's rectified frame
    h1 = rect["P1"] @ np.vstack([R1P, np.ones(25)])
    h2 = rect["P2"] @ np.vstack([R1P, np.ones(25)])
    u1, u2 = h1[:2] / h1[2], h2[:2] / h2[2]
    np.testing.assert_allclose(u1[1], u2[1], atol=1e-9)  # the same row
    # And P2 is camera 1 itself, turned by R2: the same pixel as its rectified ray.
    P1 = in_camera(rig, 1, P0)
    ray = rect["R2"] @ P1
    np.testing.assert_allclose(u2, rect["P2"][:2, :3] @ ray / ray[2], atol=1e-9)
    d = u1[0] - u2[0]
    X = rect["Q"] @ np.vstack([u1, d, np.ones(25)])
    np.testing.assert_allclose(X[:3] / X[3], R1P, atol=1e-9)
    if zero_disparity:
        assert rect["P1"][0, 2] == rect["P2"][0, 2]

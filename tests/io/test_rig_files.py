"""Rig files: Kalibr camchain (T_cn_cnm1), OpenCV's stereo FileStorage, graphpose JSON."""

import numpy as np
import pytest
import yaml

from graphpose import FisheyeCamera, InputError, PinholeCamera, RadTanCamera
from graphpose.geometry import T_from_params
from graphpose.io.cameras import read_camera, write_camera
from graphpose.rig import Rig, rig_parameter_names

K = np.array([[500.0, 0.0, 320.0], [0.0, 501.0, 240.0], [0.0, 0.0, 1.0]])


def _rig(n=3, cov=False):
    cameras = [RadTanCamera(K, [-0.2, 0.05, 0.001, -0.002], (640, 480)),
               FisheyeCamera(K * [[0.7], [0.7], [1]], [0.01, -0.002, 0.0003, -0.00001], (640, 480)),
               PinholeCamera(K + [[3.0, 0, 1.5], [0, 2.0, -1], [0, 0, 0]], (640, 480))][:n]
    Ts = [np.eye(4), T_from_params([0.3, 0.01, -0.02, 0.02, -0.05, 0.01]),
          T_from_params([-0.12, 0.2, 0.03, -0.3, 0.1, 1.2])][:n]
    if not cov:
        return Rig(cameras, Ts)
    names = rig_parameter_names(cameras)
    A = np.random.default_rng(1).standard_normal((len(names), len(names)))
    return Rig(cameras, Ts, cov=A @ A.T * 1e-6, parameter_names=names)


@pytest.mark.parametrize("fmt,n", [("json", 3), ("kalibr", 3), ("opencv", 2)])
def test_each_format_round_trips_to_1e_12(tmp_path, fmt, n):
    rig = _rig(n, cov=fmt == "json")
    path = tmp_path / f"rig.{fmt}"
    write_camera(path, rig, fmt)
    back = read_camera(path)
    assert isinstance(back, Rig) and len(back) == n
    assert back.cameras == rig.cameras
    for a, b in zip(back.T_C0_C, rig.T_C0_C):
        assert np.max(np.abs(a - b)) <= 1e-12
    if fmt == "json":
        assert back.parameter_names == rig.parameter_names
        assert np.max(np.abs(back.cov - rig.cov)) <= 1e-12
    # name picks one camera of the rig file
    assert read_camera(path, name="cam1") == rig.cameras[1]
    with pytest.raises(InputError, match="no camera 'cam7'"):
        read_camera(path, name="cam7")


def test_kalibr_T_cn_cnm1_against_a_camchain_written_by_hand(tmp_path):
    # The rig: cam1 is 0.1 m along cam0's x and turned 90 degrees about its z axis; cam2 is 0.2 m
    # along cam1's y axis, not turned. Kalibr's T_cn_cnm1 takes a point from camera n-1's frame
    # into camera n's: a point at cam0's origin is, in cam1's frame, p1 = R^T (0 - t) with R = Rz(90):
    # R^T (-0.1, 0, 0) = (0, 0.1, 0); cam1's origin is at (0, -0.2, 0) in cam2's frame.
    chain = {
        "cam0": {"camera_model": "pinhole", "intrinsics": [500.0, 501.0, 320.0, 240.0], "distortion_model": "none",
                 "distortion_coeffs": [], "resolution": [640, 480]},
        "cam1": {"camera_model": "pinhole", "intrinsics": [500.0, 501.0, 320.0, 240.0], "distortion_model": "none",
                 "distortion_coeffs": [], "resolution": [640, 480],
                 "T_cn_cnm1": [[0.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.1], [0.0, 0.0, 1.0, 0.0], [0, 0, 0, 1]]},
        "cam2": {"camera_model": "pinhole", "intrinsics": [500.0, 501.0, 320.0, 240.0], "distortion_model": "none",
                 "distortion_coeffs": [], "resolution": [640, 480],
                 "T_cn_cnm1": [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, -0.2], [0.0, 0.0, 1.0, 0.0], [0, 0, 0, 1]]},
    }
    path = tmp_path / "camchain.yaml"
    path.write_text(yaml.safe_dump(chain))
    rig = read_camera(path)
    # cam1 in cam0's frame: at (0.1, 0, 0), its x axis along cam0's y.
    assert np.allclose(rig.T_C0_C[1], [[0, -1, 0, 0.1], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], atol=1e-15)
    # cam2 is 0.2 m along cam1's y, which is cam0's -x: at (-0.1, 0, 0) in cam0's frame.
    assert np.allclose(rig.T_C0_C[2][:3, 3], [-0.1, 0.0, 0.0], atol=1e-15)
    # Written back, the transforms are the hand-written ones.
    write_camera(tmp_path / "out.yaml", rig, "kalibr")
    out = yaml.safe_load((tmp_path / "out.yaml").read_text())
    for key in ("cam1", "cam2"):
        assert np.allclose(out[key]["T_cn_cnm1"], chain[key]["T_cn_cnm1"], atol=1e-15)
    assert out["cam1"]["cam_overlaps"] == [0, 2]


def test_a_camchain_without_extrinsics_is_one_camera_as_before():
    from tests.conftest import opencv_file

    chain = opencv_file("camchain.kalibr.yaml")
    assert not isinstance(read_camera(chain), Rig)
    assert read_camera(chain, "cam1").fx == 536.8


def test_opencv_reads_the_stereo_file_and_R_T_agree(tmp_path):
    cv2 = pytest.importorskip("cv2")
    rig = Rig([RadTanCamera(K, [-0.2, 0.05, 0.001, -0.002, 0.01], (640, 480)),
               RadTanCamera(K + [[4.0, 0, -3], [0, 3, 2], [0, 0, 0]], [-0.21, 0.06, 0.0, 0.001, 0.0], (640, 480))],
              [np.eye(4), T_from_params([0.08, 0.001, -0.002, 0.004, -0.006, 0.003])])
    path = tmp_path / "stereo.yml"
    write_camera(path, rig, "opencv")
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    R, T = fs.getNode("R").mat(), fs.getNode("T").mat().ravel()
    # p2 = R p1 + T: camera 0's origin lands at camera 0's position in camera 1's frame.
    T_C1_C0 = np.linalg.inv(rig.T_C0_C[1])
    assert np.allclose(R, T_C1_C0[:3, :3], atol=1e-14) and np.allclose(T, T_C1_C0[:3, 3], atol=1e-14)
    M1, D1, M2, D2 = (fs.getNode(k).mat() for k in ("M1", "D1", "M2", "D2"))
    assert np.allclose(M1, rig.cameras[0].K) and np.allclose(D2.ravel(), rig.cameras[1].distortion)
    E, F = fs.getNode("E").mat(), fs.getNode("F").mat()
    # Epipolar constraint on a point seen by both (pixels of the distortion-free cameras).
    p1 = np.array([0.1, -0.05, 1.3])
    p2 = R @ p1 + T
    x1, x2 = rig.cameras[0].K @ (p1 / p1[2]), rig.cameras[1].K @ (p2 / p2[2])
    assert abs(x2 @ F @ x1) < 1e-9 and abs((p2 / p2[2]) @ E @ (p1 / p1[2])) < 1e-12
    # R1 R2 P1 P2 Q as OpenCV's own stereoRectify (its corners undistorted in 5 float iterations).
    out = cv2.stereoRectify(M1, D1, M2, D2, (640, 480), R, T.reshape(3, 1))
    for key, theirs in zip(("R1", "R2", "P1", "P2", "Q"), out[:5]):
        assert np.allclose(fs.getNode(key).mat(), theirs, atol=0.05 if key[0] in "PQ" else 1e-12), key


def test_rig_formats_refuse_what_they_cannot_hold(tmp_path):
    with pytest.raises(InputError, match="holds two cameras and this rig has 3"):
        write_camera(tmp_path / "x.yml", _rig(3), "opencv")
    with pytest.raises(InputError, match="a rig is written as json, opencv, kalibr"):
        write_camera(tmp_path / "x.yml", _rig(2), "ros")
    rig5 = Rig([RadTanCamera(K, [-0.2, 0.05, 0.001, -0.002, 0.01], (640, 480))] * 2, [np.eye(4), np.eye(4)])
    with pytest.raises(InputError, match="k3..k6"):
        write_camera(tmp_path / "x.yml", rig5, "kalibr")
    with pytest.raises(InputError, match=r"T_C0_C\[0\] must be the identity"):
        Rig(_rig(2).cameras, [T_from_params([0.1, 0, 0, 0, 0, 0])] * 2)

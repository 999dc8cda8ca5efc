import numpy as np
import pytest

from graphpose import InputError, T_from_params
from graphpose.geometry import rot_z
from graphpose.io.tum import read_tum, write_tum


def _poses(rng, n):
    params = np.column_stack([rng.uniform(-1, 1, (n, 3)), rng.uniform(-3, 3, (n, 3))])
    params[:, 4] = np.clip(params[:, 4], -1.5, 1.5)
    return np.array([T_from_params(p) for p in params])


def test_write_read_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    poses = _poses(rng, 20)
    t = np.arange(20) / 30.0 + 1000.0
    path = write_tum(tmp_path / "traj.txt", t, poses, header="made by a test\nsecond line")
    back = read_tum(path)
    assert len(back) == 20
    np.testing.assert_allclose(back.timestamps, t, atol=1e-6)
    np.testing.assert_allclose(back.poses, poses, atol=1e-8)


def test_quaternion_order_is_xyzw_with_translation_first(tmp_path):
    T = np.eye(4)
    T[:3, :3] = rot_z(np.pi / 2)
    T[:3, 3] = [0.1, -0.2, -0.9]
    write_tum(tmp_path / "one.txt", [2.5], [T])
    fields = [float(v) for v in (tmp_path / "one.txt").read_text().split()]
    h = np.sqrt(0.5)
    np.testing.assert_allclose(fields, [2.5, 0.1, -0.2, -0.9, 0.0, 0.0, h, h], atol=1e-9)


def test_empty_and_comments(tmp_path):
    path = write_tum(tmp_path / "empty.txt", [], np.zeros((0, 4, 4)))
    assert len(read_tum(path)) == 0
    path = write_tum(tmp_path / "lists.txt", [], [], header="every frame lost")  # plain empty lists
    assert path.read_text() == "# every frame lost\n" and len(read_tum(path)) == 0
    (tmp_path / "c.txt").write_text("# header\n\n0 1 2 3 0 0 0 1\n")
    traj = read_tum(tmp_path / "c.txt")
    np.testing.assert_allclose(traj.poses[0][:3, 3], [1, 2, 3])


@pytest.mark.parametrize(
    "row, message",
    [
        ("0 1 2 3 0 0 0", "expected 8 numbers"),
        ("0 1 2 3 0 0 0 1 9", "expected 8 numbers"),
        ("0 1 two 3 0 0 0 1", "not a number"),
        ("0 1 nan 3 0 0 0 1", "NaN"),
        ("0 1 2 3 0 0 0 2", "unit norm"),
    ],
)
def test_read_rejects_malformed_rows(tmp_path, row, message):
    path = tmp_path / "bad.txt"
    path.write_text("0 0 0 0 0 0 0 1\n" + row + "\n")
    with pytest.raises(InputError, match=message) as info:
        read_tum(path)
    assert "bad.txt:2" in str(info.value)


def test_read_missing_file(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_tum(tmp_path / "nope.txt")


def test_write_rejects_bad_input(tmp_path):
    with pytest.raises(InputError, match=r"\(N, 4, 4\)"):
        write_tum(tmp_path / "x.txt", [0.0], np.eye(4))
    with pytest.raises(InputError, match="entries"):
        write_tum(tmp_path / "x.txt", [0.0, 1.0], [np.eye(4)])
    with pytest.raises(InputError, match=r"\(N, 4, 4\)"):
        write_tum(tmp_path / "x.txt", [0.0], [])
    with pytest.raises(InputError, match="poses must be a rectangular array"):
        write_tum(tmp_path / "x.txt", [0.0, 1.0], [np.eye(4), np.eye(3)])
    with pytest.raises(InputError, match="timestamps must be a rectangular array"):
        write_tum(tmp_path / "x.txt", ["0.0"], [np.eye(4)])
    with pytest.raises(InputError, match="NaN"):
        write_tum(tmp_path / "x.txt", [np.nan], [np.eye(4)])
    bad = np.eye(4)
    bad[0, 0] = 2.0
    with pytest.raises(InputError, match=r"poses\[0\]"):
        write_tum(tmp_path / "x.txt", [0.0], [bad])


def test_write_failure_is_an_input_error_and_leaves_no_file(tmp_path):
    with pytest.raises(InputError, match="cannot write .*missing"):
        write_tum(tmp_path / "missing" / "x.txt", [0.0], [np.eye(4)])
    assert not (tmp_path / "missing").exists()
    (tmp_path / "folder.txt").mkdir()  # the path is a folder: os.replace refuses
    with pytest.raises(InputError, match="cannot write .*folder.txt"):
        write_tum(tmp_path / "folder.txt", [0.0], [np.eye(4)])
    assert [p.name for p in tmp_path.iterdir()] == ["folder.txt"]  # no temporary file left behind


def test_tum_line_is_write_tums_line():
    from scipy.spatial.transform import Rotation

    from graphpose.io.tum import tum_line

    T = T_from_params([0.1, -2.0, 3.25, 0.3, -0.2, 1.0])
    q = Rotation.from_matrix(T[:3, :3]).as_quat()
    line = tum_line(12.5, T, q)
    assert line == "12.500000 0.100000000 -2.000000000 3.250000000 " + " ".join(f"{v:.9f}" for v in q)
    assert "\n" not in line

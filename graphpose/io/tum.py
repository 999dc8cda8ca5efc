"""Trajectories in the TUM RGB-D format, readable by evo.

Format
------
One pose per line, seven numbers after the timestamp, separated by spaces::

    timestamp tx ty tz qx qy qz qw

``timestamp`` in seconds; ``(tx, ty, tz)`` the camera's position in the target frame, metres;
``(qx, qy, qz, qw)`` the unit quaternion of the camera's orientation in the target frame
(scalar LAST). Together they are ``T_WC`` of :mod:`graphpose.geometry`: the camera pose in the
target frame. Lines that are empty or start with ``#`` are comments. A frame whose pose is
unknown (lost) simply has no line.

The scalar-last order ``xyzw`` exists only at this edge: inside graphpose rotations are
matrices, and nothing else handles quaternions.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from .._checks import as_float_array, check_transform
from ..errors import InputError
from .files import AtomicFile, atomic_write

#: Tolerance on the norm of a quaternion read from a file (files are written to ~9 digits).
QUAT_NORM_TOL = 1e-4


@dataclass(frozen=True)
class TumTrajectory:
    """A timed sequence of camera poses.

    Attributes
    ----------
    timestamps : (N,) ndarray of float64
        Seconds, in file order.
    poses : (N, 4, 4) ndarray of float64
        ``T_WC`` of every line: camera pose in the target frame, metres.
    """

    timestamps: np.ndarray
    poses: np.ndarray

    def __len__(self) -> int:
        return len(self.timestamps)


def write_tum(path, timestamps, poses, header: str | None = None) -> Path:
    """Write poses to a TUM trajectory file (format in the module docstring).

    Parameters
    ----------
    path : str or Path
        File to write, whole or not at all (:func:`graphpose.io.files.atomic_write`); its parent
        folder must exist.
    timestamps : (N,) array_like
        Seconds, finite.
    poses : (N, 4, 4) array_like
        Camera poses ``T_WC`` in the target frame; each must be a valid rigid transform.
        N may be 0 (``[]`` too): the file then holds only the header.
    header : str, optional
        Text written first as ``#`` comment lines.

    Returns
    -------
    Path
        The path written.

    Raises
    ------
    InputError
        If an input is not an array of numbers, the shapes disagree, a timestamp is not finite, a pose is not a rigid transform,
        or the file cannot be written (missing folder, no permission; the message names the
        path).
    """
    t = as_float_array(timestamps, "timestamps").reshape(-1)
    T = as_float_array(poses, "poses")
    if T.size == 0 and t.size == 0:
        T = T.reshape(0, 4, 4)  # an empty list of poses (every frame lost) is an empty trajectory
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise InputError(f"poses must have shape (N, 4, 4), got {T.shape}")
    if T.shape[0] != t.size:
        raise InputError(f"timestamps has {t.size} entries but poses has {T.shape[0]}")
    if not np.all(np.isfinite(t)):
        raise InputError("timestamps contains NaN or infinite values")
    for k, Tk in enumerate(T):
        check_transform(Tk, f"poses[{k}]")
    lines = [] if header is None else [f"# {line}" for line in header.splitlines()]
    if t.size:
        q = Rotation.from_matrix(T[:, :3, :3]).as_quat()  # scipy's order is x, y, z, w
        lines += [tum_line(tk, Tk, qk) for tk, Tk, qk in zip(t, T, q)]
    path = Path(path)
    atomic_write(path, "\n".join(lines) + "\n" if lines else "")
    return path


def tum_line(timestamp: float, T_WC, q_xyzw) -> str:
    """One pose's line (no newline): ``timestamp tx ty tz qx qy qz qw``, the time to the
    microsecond, the rest to 9 decimals (format in the module docstring).

    Parameters
    ----------
    timestamp : float
        Seconds, finite.
    T_WC : (4, 4) ndarray
        The camera pose in the target frame (checked by the caller); its translation is written.
    q_xyzw : (4,) ndarray
        Its rotation as a unit quaternion, scalar last (scipy's ``as_quat``).
    """
    return f"{timestamp:.6f} " + " ".join(f"{v:.9f}" for v in (*T_WC[:3, 3], *q_xyzw))


class TumStream:
    """A TUM trajectory file written one pose at a time, with the bytes :func:`write_tum`
    writes for the whole sequence at once, and whole or not at all.

    The header (a track's counts its lost frames) is only known at the end: the lines go to a
    temporary body (:class:`graphpose.io.files.AtomicFile`), copied under the header into the
    file at :meth:`close`; :meth:`abort` leaves no file.

    Parameters
    ----------
    path : str or Path
        The file; its folder must exist.

    Raises
    ------
    InputError
        If the file cannot be written (the message names it).
    """

    def __init__(self, path):
        self._body = AtomicFile(path, suffix="body")
        self.path = self._body.path

    def add(self, timestamp: float, T_WC) -> None:
        """One line (:func:`tum_line`); InputError for a pose that is no rigid transform or a
        time that is not finite."""
        T = check_transform(T_WC, "T_WC")
        q = Rotation.from_matrix(T[None, :3, :3]).as_quat()[0]  # scipy's order is x, y, z, w
        if not np.isfinite(timestamp):
            raise InputError("timestamps contains NaN or infinite values")
        self._body.file.write(tum_line(float(timestamp), T, q) + "\n")

    def close(self, header: str) -> None:
        """Write the file: ``header`` as ``#`` comment lines, then the lines."""
        out = AtomicFile(self.path)
        try:
            out.file.write("".join(f"# {line}\n" for line in header.splitlines()))
            self._body.file.flush()
            with open(self._body.tmp, encoding="utf-8", newline="") as body:
                shutil.copyfileobj(body, out.file)
        except BaseException:
            out.abort()
            raise
        finally:
            self._body.abort()
        out.commit()

    def abort(self) -> None:
        """Leave no file (the run failed)."""
        self._body.abort()


def read_tum(path) -> TumTrajectory:
    """Read a TUM trajectory file (format in the module docstring).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    TumTrajectory
        Timestamps (N,) and poses (N, 4, 4) in file order; N may be 0.

    Raises
    ------
    InputError
        If the file is missing, or a line (named by its number) does not hold eight finite
        numbers, or its quaternion is not of unit norm (within :data:`QUAT_NORM_TOL`).
    """
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise InputError(f"TUM file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read TUM file {path}: {exc}") from None
    rows = []
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        rows.append(_parse_row(line, f"{path}:{number}"))
    if not rows:
        return TumTrajectory(np.zeros(0), np.zeros((0, 4, 4)))
    data = np.array(rows)
    poses = np.tile(np.eye(4), (len(rows), 1, 1))
    poses[:, :3, :3] = Rotation.from_quat(data[:, 4:8]).as_matrix()
    poses[:, :3, 3] = data[:, 1:4]
    return TumTrajectory(data[:, 0].copy(), poses)


def _parse_row(line: str, where: str) -> list:
    fields = line.replace(",", " ").split()
    if len(fields) != 8:
        raise InputError(f"{where}: expected 8 numbers 'timestamp tx ty tz qx qy qz qw', got {len(fields)}")
    try:
        values = [float(f) for f in fields]
    except ValueError:
        raise InputError(f"{where}: not a number in {line!r}") from None
    if not np.all(np.isfinite(values)):
        raise InputError(f"{where}: NaN or infinite value in {line!r}")
    norm = np.linalg.norm(values[4:8])
    if abs(norm - 1.0) > QUAT_NORM_TOL:
        raise InputError(f"{where}: quaternion (qx qy qz qw) must have unit norm, got {norm:.6g}")
    return values

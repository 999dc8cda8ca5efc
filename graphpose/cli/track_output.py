"""``graphpose track``'s outputs written as the frames come: the TUM file (:class:`TumStream`),
the JSON document (:class:`JsonStream`) and the summary's figures (:class:`TrackSummary`).

Each frame's line and record is written once its result is final
(:func:`graphpose.track.tracker.track_frames`), so that nothing grows with the sequence but
a few numbers a frame for the summary. The bytes are those :func:`graphpose.io.tum.write_tum`
and :func:`graphpose.io.files.write_json` write for the whole sequence at once, and a file
still appears whole or not at all: the lines go to a temporary file beside it, which
replaces it at :meth:`close` (an error or an interruption leaves no file, never half of one).

The JSON to standard output (``--json -``) is written as it comes too: a run stopped by an
error there leaves the document unfinished (the error line on stderr and exit code say so).
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import sys
from array import array
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from .._checks import check_transform
from ..errors import InputError
from ..io.files import dumps_json


class _TempFile:
    """A temporary file beside ``path`` that replaces it at :meth:`commit`, or goes at :meth:`abort`."""

    def __init__(self, path, suffix: str = "tmp"):
        self.path = Path(path)
        self.tmp = self.path.with_name(f".{self.path.name}.{secrets.token_hex(4)}.{suffix}")
        try:
            # os.open with mode 0o666 lets the umask set the final permissions, as open() would.
            self.file = os.fdopen(os.open(self.tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666), "w",
                                  encoding="utf-8", newline="")
        except OSError as exc:
            raise InputError(f"cannot write {self.path}: {exc.strerror or exc}") from None

    def commit(self) -> None:
        try:
            self.file.flush()
            os.fsync(self.file.fileno())
            self.file.close()
            os.replace(self.tmp, self.path)
        except OSError as exc:
            self.abort()
            raise InputError(f"cannot write {self.path}: {exc.strerror or exc}") from None

    def abort(self) -> None:
        if not self.file.closed:
            self.file.close()
        self.tmp.unlink(missing_ok=True)


class TumStream:
    """A TUM trajectory file (:mod:`graphpose.io.tum`) written one pose at a time.

    The header, which counts the lost frames, is only known at the end: the lines go to a
    temporary body, copied under the header at :meth:`close`.
    """

    def __init__(self, path):
        self._body = _TempFile(path, "body")
        self.path = self._body.path

    def add(self, timestamp: float, T_WC) -> None:
        """One line ``timestamp tx ty tz qx qy qz qw`` (as :func:`graphpose.io.tum.write_tum`)."""
        T = check_transform(T_WC, "T_WC")
        q = Rotation.from_matrix(T[None, :3, :3]).as_quat()[0]  # scipy's order is x, y, z, w
        if not np.isfinite(timestamp):
            raise InputError("timestamps contains NaN or infinite values")
        self._body.file.write(f"{float(timestamp):.6f} " + " ".join(f"{v:.9f}" for v in (*T[:3, 3], *q)) + "\n")

    def close(self, header: str) -> None:
        """Write the file: ``header`` as ``#`` comment lines, then the lines."""
        out = _TempFile(self.path)
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


class JsonStream:
    """``{"frames": [record, ...], key: value, ...}`` written one record at a time, as
    :func:`graphpose.io.files.dumps_json` writes the whole document; ``path`` ``"-"`` is
    standard output."""

    def __init__(self, path):
        self._temp = None if path == "-" else _TempFile(path)
        self._out = sys.stdout if self._temp is None else self._temp.file
        self._count = 0
        self._out.write('{\n "frames": ')

    def add(self, record: dict) -> None:
        """One frame's record (a JSON-ready dict)."""
        self._out.write("[\n  " if self._count == 0 else ",\n  ")
        self._out.write(_indented(record, 2))
        self._count += 1

    def close(self, rest: dict) -> None:
        """End the frames' list, write the other keys of ``rest`` and finish the document."""
        self._out.write("[]" if self._count == 0 else "\n ]")
        for key, value in rest.items():
            self._out.write(f",\n {json.dumps(str(key))}: {_indented(value, 1)}")
        self._out.write("\n}\n")
        if self._temp is not None:
            self._temp.commit()
        else:
            self._out.flush()

    def abort(self) -> None:
        """Leave no file (the run failed); standard output keeps what it was given."""
        if self._temp is not None:
            self._temp.abort()


def _indented(value, level: int) -> str:
    """``value`` as :func:`dumps_json` writes it ``level`` levels deep: each line after the
    first indented by ``level`` more spaces (JSON strings hold no raw newline)."""
    return dumps_json(value)[:-1].replace("\n", "\n" + " " * level)


class TrackSummary:
    """The figures of the summary, gathered frame by frame (a few numbers a frame).

    Parameters
    ----------
    truth : (N, 4, 4) ndarray or None
        True poses, NaN where unknown.
    """

    def __init__(self, truth=None):
        self.truth = truth
        self.n = 0
        self.counts = {"tracked": 0, "detected": 0, "lost": 0}
        self.sigma = array("d")  # 6 a frame with a pose
        self.rms = array("d")
        self.ms = array("d")
        self.lost = array("q")
        self.unreadable = array("q")
        self.errors = array("d")  # (m, deg) pairs of frames with a pose and a truth
        self.first_lost = ""  # the first lost frame's message, for the reason of a run without a pose

    def add(self, f) -> None:
        """One frame's result (:class:`graphpose.track.results.FrameResult`)."""
        from ..geometry import pose_difference

        self.n += 1
        self.counts[f.status] = self.counts.get(f.status, 0) + 1
        if f.status == "lost":
            if not len(self.lost):
                self.first_lost = f"frame {f.index}: {f.message}" if f.message else f"frame {f.index}"
            self.lost.append(f.index)
        else:
            self.ms.append(1000 * (f.frontend_s + f.update_s))
        if f.message.startswith("unreadable frame file"):
            self.unreadable.append(f.index)
        if f.T_WC is None:
            return
        self.sigma.extend(f.sigma)
        self.rms.append(f.reprojection_rms_px)
        if self.truth is not None and np.all(np.isfinite(self.truth[f.index])):
            self.errors.extend(pose_difference(f.T_WC, self.truth[f.index]))

    @property
    def found(self) -> int:
        """Frames with a pose."""
        return len(self.rms)

    def text(self, smoothed: bool, truth_note: str = "") -> str:
        """The summary's lines."""
        counts = ", ".join(f"{s} {self.counts.get(s, 0)}" for s in ("tracked", "detected", "lost"))
        lines = [f"{self.n} frames: {counts}" + (" (smoothed)" if smoothed else "")]
        if self.found:
            sig = np.median(np.frombuffer(self.sigma).reshape(-1, 6), axis=0)
            rms, ms = np.median(np.frombuffer(self.rms)), np.median(np.frombuffer(self.ms))
            lines.append(f"median 1-sigma: {1000 * np.max(sig[:3]):.3f} mm (largest axis), "
                         f"{np.rad2deg(np.max(sig[3:])):.4f} deg; median reprojection RMS {rms:.3f} px; "
                         f"median {ms:.1f} ms a frame")
        if len(self.lost):
            lines.append("lost frames: " + _ranges(np.frombuffer(self.lost, dtype=np.int64)))
        if len(self.unreadable):
            lines.append(f"unreadable frame files (lost): {_ranges(np.frombuffer(self.unreadable, dtype=np.int64))}; "
                         f"see the JSON messages")
        if self.truth is not None:
            lines.append(f"truth: {truth_note}; " + self._truth_error())
        return "\n".join(lines)

    def _truth_error(self) -> str:
        """RMS position and rotation error of the frames with a pose and a true pose."""
        if not len(self.errors):
            return "no frame with a pose has a true pose"
        d = np.frombuffer(self.errors).reshape(-1, 2)
        return (f"error RMS {1000 * np.sqrt(np.mean(d[:, 0] ** 2)):.3f} mm, {np.sqrt(np.mean(d[:, 1] ** 2)):.4f} deg "
                f"over {len(d)} frames")


def _ranges(idx) -> str:
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    return ", ".join(f"{r[0]}" if r.size == 1 else f"{r[0]}-{r[-1]}" for r in runs)

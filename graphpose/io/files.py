"""Files out and in: JSON documents, PNG images, and writes that are whole or nothing."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..errors import InputError


def read_json(path, what: str = "JSON file"):
    """Parse a JSON file; ``what`` names it in errors ("case file", "pose file", ...).

    Returns
    -------
    object
        The parsed document (dict, list, str, number, bool or None).

    Raises
    ------
    InputError
        If the file is missing, unreadable or not JSON; the message names ``what`` and the path.
    """
    path = Path(path)
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"{what} not found: {path}") from None
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read {what} {path}: {exc}") from None



def atomic_write(path, data) -> None:
    """Write ``data`` to ``path`` whole or not at all.

    The bytes go to a temporary file in the same folder, which then replaces ``path`` in one
    :func:`os.replace`, so a reader never sees half a file and an interrupted write leaves the
    old file (or none) behind.

    Parameters
    ----------
    path : str or Path
        Destination file; its folder must exist.
    data : bytes or str
        Contents; ``str`` is encoded as UTF-8.

    Raises
    ------
    InputError
        If the folder is missing or the file cannot be written (the message names the path).
    """
    if isinstance(data, str):
        data = data.encode("utf-8")
    AtomicFile(path, binary=True).commit(data)


class AtomicFile:
    """A file written under a temporary name beside ``path``, which replaces ``path`` at
    :meth:`commit` or goes at :meth:`abort`: a reader never sees half a file, and a run
    stopped midway leaves the old file (or none) behind. :func:`atomic_write` writes a whole
    document at once through it; a file written piece by piece (a track's TUM and JSON as the
    frames come) holds one open until the end.

    Parameters
    ----------
    path : str or Path
        Destination file; its folder must exist.
    binary : bool
        ``file`` takes bytes; else text, UTF-8, with newlines written as given.
    suffix : str
        The temporary name's ending (``.{name}.{8 hex digits}.{suffix}``).

    Attributes
    ----------
    path, tmp : Path
        The destination and the temporary file.
    file : file object
        Open for writing, on ``tmp``.

    Raises
    ------
    InputError
        If the folder is missing or the file cannot be written (the message names ``path``);
        :meth:`commit` too, after removing the temporary file.
    """

    def __init__(self, path, *, binary: bool = False, suffix: str = "tmp"):
        self.path = Path(path)
        self.tmp = self.path.with_name(f".{self.path.name}.{os.urandom(4).hex()}.{suffix}")
        try:
            # os.open with mode 0o666 lets the umask set the final permissions, as open() would.
            fd = os.open(self.tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except OSError as exc:
            raise InputError(f"cannot write {self.path}: {exc.strerror or exc}") from None
        self.file = os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding="utf-8", newline="")

    def commit(self, data=None) -> None:
        """Write ``data`` (if given) last, flush the file to disk and put it in place of ``path``."""
        try:
            if data is not None:
                self.file.write(data)
            self.file.flush()
            os.fsync(self.file.fileno())
            self.file.close()
            os.replace(self.tmp, self.path)
        except OSError as exc:
            self.abort()
            raise InputError(f"cannot write {self.path}: {exc.strerror or exc}") from None
        except BaseException:
            self.abort()
            raise

    def abort(self) -> None:
        """Close and remove the temporary file; ``path`` is left as it was."""
        if not self.file.closed:
            self.file.close()
        self.tmp.unlink(missing_ok=True)


def encode_png(rgb) -> bytes:
    """Encode an 8-bit image as PNG bytes (with imageio, which scikit-image reads with).

    Parameters
    ----------
    rgb : (H, W) or (H, W, 3) array_like of uint8
        Grey or RGB pixels.

    Raises
    ------
    InputError
        If the array is not uint8 of one of those shapes, or is empty.
    """
    import imageio.v3 as iio

    A = np.asarray(rgb)
    if A.dtype != np.uint8 or A.ndim not in (2, 3) or (A.ndim == 3 and A.shape[2] != 3) or A.size == 0:
        raise InputError(f"rgb must be a non-empty uint8 (H, W) or (H, W, 3) array, got {A.dtype} {A.shape}")
    return iio.imwrite("<bytes>", A, extension=".png")


def write_png(path, rgb) -> None:
    """Write an 8-bit grey or RGB image as a PNG file, atomically (see :func:`atomic_write`).

    Raises
    ------
    InputError
        As :func:`encode_png` and :func:`atomic_write`.
    """
    atomic_write(path, encode_png(rgb))


def to_jsonable(value):
    """Turn arrays, numpy scalars, tuples and dicts of them into plain JSON values.

    Non-finite floats become ``None`` (JSON has no NaN); arrays become nested lists.
    """
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, Path):
        return str(value)
    return value


def dumps_json(value) -> str:
    """``value`` (see :func:`to_jsonable`) as indented JSON text, one matrix row per line.

    Objects and lists of objects are indented by one space per level; a list of numbers is
    written on one line and a matrix (list of such lists) with one row per line, so a 4 x 4
    pose reads as four lines. Ends with a newline.
    """
    return _dumps(to_jsonable(value), 0) + "\n"


def _dumps(v, level: int) -> str:
    flat = lambda x: json.dumps(x, allow_nan=False)  # noqa: E731
    is_row = lambda x: isinstance(x, list) and not any(isinstance(e, (list, dict)) for e in x)  # noqa: E731
    pad, inner = " " * level, " " * (level + 1)
    if isinstance(v, dict):
        if not v:
            return "{}"
        items = [f"{inner}{flat(k)}: {_dumps(x, level + 1)}" for k, x in v.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if not isinstance(v, list) or is_row(v):
        return flat(v)
    if all(is_row(row) for row in v):
        return "[" + (",\n" + inner).join(flat(row) for row in v) + "]"
    return "[\n" + ",\n".join(inner + _dumps(x, level + 1) for x in v) + "\n" + pad + "]"


def write_json(path, value) -> None:
    """Write ``value`` (see :func:`to_jsonable`) as JSON (:func:`dumps_json`), atomically.

    Raises
    ------
    InputError
        As :func:`atomic_write`.
    """
    atomic_write(path, dumps_json(value))

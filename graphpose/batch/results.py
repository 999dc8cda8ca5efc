"""Batch results on disk: rows written as they arrive, read back, and the images already done.

Two formats, chosen by the name's ending:

- ``.parquet``: a Parquet data set, i.e. a folder of part files ``part-*.parquet`` that
  ``pyarrow.parquet.read_table(FOLDER)`` or ``pandas.read_parquet(FOLDER)`` read as one
  table. Rows are buffered and written as a new part at least every ``flush_seconds`` while
  results arrive, and on :meth:`Results.close`; a part is written under a hidden name and
  renamed, so a part file is always whole.
- ``.jsonl`` (or ``.ndjson``): JSON lines, one record a line, each line written (and
  flushed to the operating system) as its row arrives. A last line cut short by a killed
  writer is dropped when the file is opened again, and its image is done again.

A row is the record of :func:`graphpose.io.records.result_record` with the batch's status
word and ``time_s`` and ``worker`` (:mod:`graphpose.batch.work`). JSON lines keep it as it
is; Parquet has one column per key, with its fixed type (:data:`SCHEMA`), except
``cross_check``, whose three fields become ``cross_check_translation_m``,
``cross_check_rotation_deg`` and ``cross_check_agree``, and ``camera`` and ``board``, held
as JSON text. :func:`read_results` gives back the JSON form from either.

A row's result depends on its image and on :data:`PARAMETER_KEYS` (the camera's model and
values, the board, the polygon, the robust loss): :func:`parameters` is that key, and
:attr:`Results.made` holds it, with the status, for every image of the set, so that a run
with other parameters is not taken for done (``graphpose batch`` refuses it).

One writer per result set at a time: :func:`open_results` takes an exclusive lock (a
``.lock`` file in the Parquet folder, the file itself for JSON lines), so that two runs on
the same ``--out`` cannot both write an image.
"""

from __future__ import annotations

import json
import os
import time
import uuid
from pathlib import Path

from ..errors import InputError

#: Name endings of the two formats.
PARQUET_SUFFIXES = (".parquet",)
JSONL_SUFFIXES = (".jsonl", ".ndjson")

#: Column name -> Arrow type name of a Parquet row (see :func:`arrow_schema`).
SCHEMA = {
    "image": "string",
    "frame": "int64",       # a recording's frame: its index and time (None for an image file)
    "timestamp": "double",
    "status": "string",
    "message": "string",
    "T_WC": "list<list<double>>",
    "xyz_m": "list<double>",
    "rpy_deg": "list<double>",
    "sigma_xyz_m": "list<double>",
    "sigma_rpy_deg": "list<double>",
    "reprojection_rms_px": "double",
    "junctions_used": "int64",
    "converged": "bool",
    "iterations": "int64",
    "junctions": "list<list<double>>",
    "trusted": "list<bool>",
    "cross_check_translation_m": "double",
    "cross_check_rotation_deg": "double",
    "cross_check_agree": "bool",
    "orientation_ambiguous": "bool",
    "sigma_kind": "string",
    "sigma_pixel_xyz_m": "list<double>",
    "sigma_pixel_rpy_deg": "list<double>",
    "junction0_square": "string",
    "time_s": "double",
    "worker": "string",
    "camera": "string",
    "board": "string",
    "bounds": "list<list<double>>",
    "robust": "bool",
}
_CROSS_CHECK = ("translation_m", "rotation_deg", "agree")
#: Columns only a recording's frame has (its index and time); absent from an image file's record.
_FRAME_COLUMNS = ("frame", "timestamp")
#: Keys held in Parquet as JSON text (objects of their own).
_JSON_COLUMNS = ("camera", "board")

#: The keys of a row, besides its image, that change its result.
PARAMETER_KEYS = ("camera", "board", "bounds", "robust")


def parameters(record: dict) -> str | None:
    """What a row's result was made with, as one comparable text: :data:`PARAMETER_KEYS`,
    the camera by its model and values (not the file it came from); None for a row that
    does not say (written before graphpose recorded them)."""
    if any(record.get(key) is None for key in ("camera", "board")):
        return None
    camera = {k: v for k, v in record["camera"].items() if k not in ("file", "name")}
    distortion = list(camera.get("distortion") or [])
    while distortion and distortion[-1] == 0:  # (k1, k2, p1, p2) is (k1, k2, p1, p2, 0)
        distortion.pop()
    camera["distortion"] = distortion
    return json.dumps([camera, record["board"], record.get("bounds"), bool(record.get("robust"))], sort_keys=True)


def results_format(path) -> str:
    """``"parquet"`` or ``"jsonl"`` from the name's ending; InputError for any other."""
    suffix = Path(path).suffix.lower()
    if suffix in PARQUET_SUFFIXES:
        return "parquet"
    if suffix in JSONL_SUFFIXES:
        return "jsonl"
    raise InputError(f"results {path}: the name must end in .parquet (a Parquet data set, a folder) or "
                     f".jsonl (JSON lines), got {suffix or 'no ending'}")


def arrow_schema():
    """The Parquet rows' ``pyarrow.Schema`` (:data:`SCHEMA`); imports pyarrow."""
    pa = _pyarrow()
    types = {"string": pa.string(), "double": pa.float64(), "int64": pa.int64(), "bool": pa.bool_(),
             "list<double>": pa.list_(pa.float64()), "list<bool>": pa.list_(pa.bool_()),
             "list<list<double>>": pa.list_(pa.list_(pa.float64()))}
    return pa.schema([pa.field(name, types[kind], nullable=name != "image") for name, kind in SCHEMA.items()])


def flat_row(record: dict) -> dict:
    """A record as a Parquet row: :data:`SCHEMA`'s keys, ``cross_check`` spread out."""
    check = record.get("cross_check") or {}
    row = {key: record.get(key) for key in SCHEMA}
    row.update({f"cross_check_{k}": check.get(k) for k in _CROSS_CHECK})
    row.update({k: None if row[k] is None else json.dumps(row[k]) for k in _JSON_COLUMNS})
    return row


def nested_record(row: dict) -> dict:
    """A Parquet row back in the JSON form (the inverse of :func:`flat_row`)."""
    record = {k: v for k, v in row.items() if not k.startswith("cross_check_")}
    check = {k: row.get(f"cross_check_{k}") for k in _CROSS_CHECK}
    record["cross_check"] = None if all(v is None for v in check.values()) else check
    record.update({k: json.loads(record[k]) for k in _JSON_COLUMNS if record.get(k) is not None})
    for key in _FRAME_COLUMNS:  # an image file's row has no frame of a recording
        if record.get(key) is None:
            record.pop(key, None)
    return record


class Results:
    """An open result set: the images already in it, and rows to add.

    Use :func:`open_results`. Attributes: ``path``, ``format`` (``"parquet"`` or
    ``"jsonl"``), ``done`` (the set of image paths with a row, updated by :meth:`write`) and
    ``made`` (image path -> ``(parameters(row), status)`` of its last row, see
    :func:`parameters`).
    """

    format = ""

    def __init__(self, path, flush_seconds: float):
        self.path = Path(path)
        self.flush_seconds = float(flush_seconds)
        self.done = set()
        self.made = {}
        self._lock_fd = None

    def _add(self, record: dict) -> None:
        """Note the image of ``record`` (a row) as done, with its parameters and status."""
        self.done.add(record["image"])
        self.made[record["image"]] = (parameters(record), record.get("status"))

    def write(self, record: dict) -> None:
        """Add one image's row (a record of :mod:`graphpose.batch.work`)."""
        raise NotImplementedError

    def flush(self) -> None:
        """Write out every row given so far."""

    def close(self) -> None:
        """Flush and release the set; safe to call twice."""
        self.flush()
        if self._lock_fd is not None:
            os.close(self._lock_fd)
            self._lock_fd = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _lock(self, path: Path) -> None:
        """Hold an exclusive lock on ``path`` (created if absent) until :meth:`close`."""
        try:
            import fcntl
        except ImportError:  # not POSIX: no lock
            return
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise InputError(f"results {self.path} are being written by another run "
                             f"(one run per result set at a time)") from None
        self._lock_fd = fd


class ParquetResults(Results):
    """A Parquet data set (a folder of part files); see the module docstring."""

    format = "parquet"
    #: A part is also written when this many rows wait.
    rows_per_part = 10_000

    def __init__(self, path, flush_seconds: float = 5.0):
        super().__init__(path, flush_seconds)
        if self.path.exists() and not self.path.is_dir():
            raise InputError(f"results {self.path}: a Parquet data set is a folder, and this is a file")
        if not self.path.parent.is_dir():
            raise InputError(f"results {self.path}: folder {self.path.parent} does not exist")
        self.path.mkdir(exist_ok=True)
        self._lock(self.path / ".lock")
        self._rows, self._since, self._parts = [], None, 0
        self._landing = None  # the part being written, until its rows are forgotten
        pq = _pyarrow("parquet")
        for stale in self.path.glob(".part-*.tmp"):  # a part being written when a run was killed
            stale.unlink()
        for part in _parts(self.path):
            try:
                names = set(pq.read_schema(part).names)  # a part written before a column existed lacks it
                columns = ["image", "status", *(k for k in PARAMETER_KEYS if k in names)]
                rows = pq.read_table(part, columns=[c for c in columns if c in names]).to_pylist()
            except Exception as exc:  # noqa: BLE001  (pyarrow raises several types for a bad file)
                self.close()
                raise InputError(f"results {self.path}: cannot read the part {part.name}: {exc}") from None
            for row in rows:
                self._add(nested_record(row))
        self._schema = arrow_schema()
        self._run = uuid.uuid4().hex[:8]

    def write(self, record: dict) -> None:
        self._rows.append(flat_row(record))
        self._add(record)
        now = time.monotonic()
        if self._since is None:
            self._since = now
        if len(self._rows) >= self.rows_per_part or now - self._since >= self.flush_seconds:
            self.flush()

    def flush(self) -> None:
        if self._landing is not None and (self.path / self._landing).exists():
            # Ctrl-C (or SIGTERM) came between the rename and forgetting the rows: they are
            # written, and writing them again at close would give their images two rows.
            self._forget()
        if not self._rows:
            return
        pa, pq = _pyarrow(), _pyarrow("parquet")
        table = pa.Table.from_pylist(self._rows, schema=self._schema)
        stamp = time.time_ns()  # names sort in the order the parts were written, across runs
        when = time.strftime("%Y%m%dT%H%M%S", time.gmtime(stamp // 10**9)) + f".{stamp % 10**9:09d}"
        name = f"part-{when}-{self._run}-{self._parts:06d}.parquet"
        tmp = self.path / f".{name}.tmp"
        self._landing = name
        pq.write_table(table, tmp)
        os.replace(tmp, self.path / name)
        self._forget()

    def _forget(self) -> None:
        """The waiting rows are in the part :attr:`_landing`: start the next part."""
        self._rows, self._since, self._landing = [], None, None
        self._parts += 1


class JsonLinesResults(Results):
    """JSON lines, one record a line; see the module docstring."""

    format = "jsonl"

    def __init__(self, path, flush_seconds: float = 5.0):
        super().__init__(path, flush_seconds)
        if self.path.is_dir():
            raise InputError(f"results {self.path}: JSON lines are a file, and this is a folder")
        if not self.path.parent.is_dir():
            raise InputError(f"results {self.path}: folder {self.path.parent} does not exist")
        try:
            self._file = open(self.path, "a+b")  # noqa: SIM115  (held open until close())
        except OSError as exc:
            raise InputError(f"cannot open results {self.path}: {exc.strerror or exc}") from None
        self._lock_file()
        self._file.seek(0)
        good = 0  # bytes up to the end of the last whole line
        for number, line in enumerate(self._file, 1):
            if not line.endswith(b"\n"):
                break  # cut short by a killed writer: dropped below
            try:
                self._add(json.loads(line))
            except (ValueError, KeyError, TypeError, AttributeError):
                self._file.close()
                raise InputError(f"results {self.path}: line {number} is not a result record") from None
            good += len(line)
        self._file.truncate(good)
        self._file.seek(0, os.SEEK_END)
        self._synced = time.monotonic()

    def _lock_file(self):
        try:
            import fcntl
        except ImportError:
            return
        try:
            fcntl.flock(self._file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self._file.close()
            raise InputError(f"results {self.path} are being written by another run "
                             f"(one run per result set at a time)") from None

    def write(self, record: dict) -> None:
        line = json.dumps(record, allow_nan=False, separators=(",", ":")) + "\n"
        self._file.write(line.encode())
        self._file.flush()
        self._add(record)
        if time.monotonic() - self._synced >= self.flush_seconds:
            self.flush()

    def flush(self) -> None:
        if not self._file.closed:
            self._file.flush()
            os.fsync(self._file.fileno())
            self._synced = time.monotonic()

    def close(self) -> None:
        if not self._file.closed:
            self.flush()
            self._file.close()  # releases the lock


def open_results(path, *, flush_seconds: float = 5.0) -> Results:
    """Open (or start) the result set ``path`` for writing; see the module docstring.

    Parameters
    ----------
    path : str or Path
        Ends in ``.parquet`` (a folder, created if absent) or ``.jsonl``/``.ndjson``.
    flush_seconds : float
        Parquet: the longest rows wait in memory while results arrive; JSON lines: how
        often the file is synced to disk. Positive.

    Returns
    -------
    Results
        With ``done``, the images already in the set. Close it (or use ``with``).

    Raises
    ------
    InputError
        On another ending, a missing folder, a file where a folder belongs (or the reverse),
        a set being written by another run, or a row that cannot be read.
    """
    if not (isinstance(flush_seconds, (int, float)) and flush_seconds > 0):
        raise InputError(f"flush_seconds must be a positive number of seconds, got {flush_seconds!r}")
    kind = results_format(path)
    return (ParquetResults if kind == "parquet" else JsonLinesResults)(path, flush_seconds)


def read_results(path) -> list:
    """Every row of a result set, in the JSON form (see the module docstring), in file order.

    Raises
    ------
    InputError
        If ``path`` has neither ending, does not exist, or a row cannot be read.
    """
    path = Path(path)
    kind = results_format(path)
    if not path.exists():
        raise InputError(f"results not found: {path}")
    if kind == "jsonl":
        records = []
        with open(path, "rb") as f:
            for number, line in enumerate(f, 1):
                if not line.endswith(b"\n"):
                    break  # a line cut short: not a row
                try:
                    records.append(json.loads(line))
                except ValueError:
                    raise InputError(f"results {path}: line {number} is not JSON") from None
        return records
    pq = _pyarrow("parquet")
    records = []
    for part in _parts(path):
        records += [nested_record(row) for row in pq.read_table(part).to_pylist()]
    return records


def _parts(folder: Path) -> list:
    """The part files of a Parquet data set, oldest first (names start with the time, UTC)."""
    return sorted(p for p in folder.glob("*.parquet") if p.is_file() and not p.name.startswith((".", "_")))


def _pyarrow(module: str = ""):
    """pyarrow (or pyarrow.MODULE), or InputError saying how to install it."""
    from .._extras import require

    return require("pyarrow" + (f".{module}" if module else ""), "batch", "Parquet results")

"""Junctions out and in, for calibrating with another tool or from another detector.

Two formats:

- **mrcal's ``corners.vnl``** (a vnlog: whitespace-separated columns under a ``#`` header
  ``# filename x y level``). Per image with a board, one line per junction of the board in
  its order (row-major from the upper-left junction, x along a row: ``Board.world_points``'s,
  mrcal's object order), ``x y`` in pixels and ``level`` the decimation level it was found
  at (0, full resolution: mrcal weighs a point by ``0.5^level``); a junction that was not
  seen (a partial board) is the line ``filename - - -`` (mrcal skips a point whose level is
  ``-``). An image without a board is the single line ``filename - - -``. Pixels are
  graphpose's and mrcal's alike: the centre of the upper-left pixel at (0, 0).
- **graphpose's JSON**: ``{"format": "graphpose corners", "board": {"cols", "rows",
  "square_m"}, "size": [width, height] or null, "images": [{"image": name, "junctions": null
  or {"index": [...], "uv": [[u, ...], [v, ...]]}}]}``, ``index`` the board's junction
  numbers (``Board.world_points`` columns).

:func:`write_corners` writes either (by the file's suffix: ``.vnl`` or ``.json``);
:func:`read_corners` reads either back as :class:`Corners`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..board import Board
from ..errors import InputError
from .files import atomic_write, read_json, write_json

#: The header line of a corners.vnl.
VNL_HEADER = "# filename x y level"


@dataclass(frozen=True)
class Corners:
    """Junctions of a set of images.

    Attributes
    ----------
    images : tuple of str
        The images' names (as written in the file).
    junctions : tuple
        Per image None (no board) or ``(uv (2, m), index (m,))``: pixels and the board's
        junction numbers.
    size : (int, int) or None
        The images' ``(width, height)`` when the file says it (graphpose's JSON), else None.
    """

    images: tuple
    junctions: tuple
    size: tuple | None = None


def _number(value: float) -> str:
    return repr(float(value))


def write_corners(path, images, junctions, board: Board, size=None) -> None:
    """Write junctions as a corners.vnl (suffix ``.vnl``) or graphpose's JSON (``.json``).

    Parameters
    ----------
    path : str or Path
        The file, written whole or not at all.
    images : sequence of str
        The images' names.
    junctions : sequence
        Per image None or ``(uv (2, m), index (m,))``.
    board : Board
        The board (its junction count orders the vnl's lines; the JSON records it).
    size : (int, int), optional
        The images' size, kept by the JSON.

    Raises
    ------
    InputError
        For another suffix, or a junction number outside the board.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".vnl", ".json"):
        raise InputError(f"--corners-out: the file must end in .vnl (mrcal's corners.vnl) or .json "
                         f"(graphpose's), got {path}")
    if len(images) != len(junctions):
        raise InputError(f"{len(images)} images but {len(junctions)} junction sets")
    for name, j in zip(images, junctions):
        if j is not None and (np.any(np.asarray(j[1]) < 0) or np.any(np.asarray(j[1]) >= board.n)):
            raise InputError(f"{name}: junction numbers outside the {board.cols} x {board.rows} board")
    if suffix == ".json":
        write_json(path, {
            "format": "graphpose corners",
            "board": {"cols": board.cols, "rows": board.rows, "square_m": board.square_m},
            "size": None if size is None else [int(size[0]), int(size[1])],
            "images": [{"image": str(name), "junctions": None if j is None else
                        {"index": np.asarray(j[1], int).tolist(), "uv": np.asarray(j[0], float).tolist()}}
                       for name, j in zip(images, junctions)]})
        return
    lines = [VNL_HEADER]
    for name, j in zip(images, junctions):
        name = str(name)
        if any(c.isspace() for c in name) or name.startswith("#"):
            raise InputError(f"corners.vnl cannot hold the image name {name!r}: its columns are "
                             "separated by whitespace; rename the file or write --corners-out as .json")
        if j is None or np.asarray(j[1]).size == 0:
            lines.append(f"{name} - - -")
            continue
        uv = np.full((2, board.n), np.nan)
        uv[:, np.asarray(j[1], int)] = np.asarray(j[0], float)
        for u, v in uv.T:
            lines.append(f"{name} - - -" if not np.isfinite(u) else f"{name} {_number(u)} {_number(v)} 0")
    atomic_write(path, ("\n".join(lines) + "\n").encode())


def read_corners(path, board: Board) -> Corners:
    """Read junctions from a corners.vnl or graphpose's JSON (:func:`write_corners`).

    Parameters
    ----------
    path : str or Path
        ``.json`` is read as graphpose's JSON, anything else as a corners.vnl.
    board : Board
        The board: a vnl image must have ``board.n`` junction lines (or one ``- - -`` line);
        the JSON's board must be this one.

    Returns
    -------
    Corners

    Raises
    ------
    InputError
        If the file is missing, not of the format, or does not fit the board (the message
        names the line or image).
    """
    path = Path(path)
    if path.suffix.lower() == ".json":
        return _read_json(path, board)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise InputError(f"corners file not found: {path}") from None
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read corners file {path}: {exc}") from None
    columns, rows = None, []
    for number, line in enumerate(text.splitlines(), 1):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            if columns is None and not stripped.startswith("#!"):
                columns = stripped.lstrip("#").split()
            continue
        if columns is None:
            raise InputError(f"{path}: line {number}: data before the vnlog header '{VNL_HEADER}'")
        fields = stripped.split()
        if len(fields) != len(columns):
            raise InputError(f"{path}: line {number}: {len(fields)} fields, the header names {len(columns)}")
        rows.append((number, dict(zip(columns, fields))))
    if columns is None or not {"filename", "x", "y"} <= set(columns):
        raise InputError(f"{path}: not a corners.vnl: it needs the header '{VNL_HEADER}' (columns filename, x, y "
                         "and optionally level)")
    images, groups = [], {}
    for number, row in rows:
        name = row["filename"]
        if name not in groups:
            images.append(name)
            groups[name] = []
        groups[name].append((number, row))
    junctions = []
    for name in images:
        group = groups[name]
        if len(group) == 1 and group[0][1]["x"] == "-":
            junctions.append(None)
            continue
        if len(group) != board.n:
            raise InputError(f"{path}: image {name} has {len(group)} junction lines, the {board.cols} x {board.rows} "
                             f"board has {board.n} (one line each, in the board's order; a board not found is one "
                             "line 'filename - - -')")
        uv, index = [], []
        for k, (number, row) in enumerate(group):
            level = row.get("level", "0")
            if row["x"] == "-" or row["y"] == "-" or level == "-":
                continue
            try:
                uv.append((float(row["x"]), float(row["y"])))
            except ValueError:
                raise InputError(f"{path}: line {number}: x, y must be numbers or '-', got {row['x']!r} "
                                 f"{row['y']!r}") from None
            index.append(k)
        junctions.append(None if not index else (np.array(uv, float).T, np.array(index, int)))
    return Corners(tuple(images), tuple(junctions), None)


def _read_json(path, board):
    doc = read_json(path, "corners file")
    if not isinstance(doc, dict) or doc.get("format") != "graphpose corners" or not isinstance(doc.get("images"), list):
        raise InputError(f"{path}: not graphpose's corners JSON (format 'graphpose corners' with images)")
    b = doc.get("board") or {}
    if (b.get("cols"), b.get("rows")) != (board.cols, board.rows):
        raise InputError(f"{path}: the file's board is {b.get('cols')} x {b.get('rows')} junctions, --board says "
                         f"{board.cols} x {board.rows}")
    images, junctions = [], []
    for k, item in enumerate(doc["images"]):
        name = str(item.get("image", f"image {k}"))
        j = item.get("junctions")
        images.append(name)
        if j is None:
            junctions.append(None)
            continue
        try:
            uv = np.asarray(j["uv"], float).reshape(2, -1)
            index = np.asarray(j["index"], int).ravel()
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{path}: image {name}: junctions must hold 'uv' (2 x m) and 'index' (m)") from None
        if uv.shape[1] != index.size or np.any(index < 0) or np.any(index >= board.n) or not np.all(np.isfinite(uv)):
            raise InputError(f"{path}: image {name}: {uv.shape[1]} pixels and {index.size} junction numbers, which "
                             f"must match, be finite, and lie on the {board.n}-junction board")
        junctions.append((uv, index))
    size = doc.get("size")
    return Corners(tuple(images), tuple(junctions), None if size is None else (int(size[0]), int(size[1])))

"""Reading case files and pose files.

A case file is the JSON format of ``../shared/data/rob501/cases.json``:

``K``
    3 x 3 intrinsics, pixels, of a camera without lens distortion; or
``camera``
    the camera with its lens model (:mod:`graphpose.camera_models`): a calibration file's path,
    relative to the case file (any format :func:`graphpose.io.cameras.read_camera`
    reads), or an inline object ``{"model", "K", "distortion", "size"}`` as graphpose's JSON
    camera file holds. A case file gives ``K`` or ``camera``, not both; or neither, when the
    camera comes from elsewhere (``graphpose estimate --cases FILE --camera ...``).
``square_m``
    Side of a square, metres (optional, 0.0635).
``grid``
    The board's inner junctions (optional, 8 x 6): ``{"cols": 8, "rows": 6}`` or
    ``[8, 6]`` (cols, then rows); either count may be left out of the object. Counts are
    JSON integers >= 2: ``8.9``, ``8.0``, ``"8"`` and ``true`` are refused.
``cases``
    A list of objects, each with ``image`` (a path relative to the file) and optionally
    ``bounds`` (the 2 x 4 polygon: a list of the u row and the v row, clockwise from the
    corner nearest junction 0; without it the whole image is searched), ``guess_T_WC`` (4 x 4),
    ``ref_junctions`` (2 x n) and ``ref_T_WC`` (estimates from elsewhere), and
    ``true_T_WC`` and ``true_junctions`` (exact, for images made by
    :mod:`graphpose.synth.render`).

Every error names the file and the field.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._checks import (
    as_float_array,
    as_points,
    as_polygon,
    check_count,
    check_K,
    check_number,
    check_transform,
)
from ..board import Board
from ..camera_models import Camera, PinholeCamera
from ..errors import InputError
from .cameras import camera_from_dict, read_camera
from .files import read_json


@dataclass(frozen=True)
class Case:
    """One image of a case file; arrays as in the module docstring, None where absent."""

    image: Path
    bounds: np.ndarray | None = None
    guess_T_WC: np.ndarray | None = None
    ref_junctions: np.ndarray | None = None
    ref_T_WC: np.ndarray | None = None
    true_T_WC: np.ndarray | None = None
    true_junctions: np.ndarray | None = None


@dataclass(frozen=True)
class CaseFile:
    """A parsed case file: intrinsics K (3, 3), the board, its cases, and the camera.

    ``camera`` is the file's camera (:mod:`graphpose.camera_models`), a
    :class:`~graphpose.camera_models.PinholeCamera` of ``K`` when the file gives ``K``; ``K`` is
    the camera's intrinsics either way. Both are None for a file that names no camera, read
    with ``load_cases(path, require_camera=False)``: the camera then comes from elsewhere
    (``--camera`` or ``--K``).
    """

    K: np.ndarray | None
    board: Board
    cases: list
    camera: Camera | None = None

    def __post_init__(self):
        if self.camera is None and self.K is not None:
            object.__setattr__(self, "camera", PinholeCamera(self.K))


def load_cases(path, *, require_camera: bool = True) -> CaseFile:
    """Read a case file (format in the module docstring); image paths become absolute.

    Image and camera paths are made absolute as named (``os.path.abspath``): symbolic links
    are kept, so a path is printed as the user wrote it, not as the link resolves.

    Parameters
    ----------
    path : str or Path
        The case file.
    require_camera : bool
        True (default): the file must give ``K`` or ``camera``. False: it may give neither,
        and the result's ``K`` and ``camera`` are then None.

    Raises
    ------
    InputError
        If the file is missing, not JSON, not an object, gives both of ``K`` and ``camera``
        (or neither, with ``require_camera``), its camera file cannot be read, it lacks ``cases`` or a case's
        ``image``, or a field has the wrong type or shape.
    """
    path = Path(path)
    doc = read_json(path, "case file")
    if not isinstance(doc, dict):
        raise InputError(f"case file {path} must hold a JSON object, got {type(doc).__name__}")
    try:
        camera = _camera(doc, path) if require_camera or "K" in doc or "camera" in doc else None
        board = _board(doc, path)
        if not isinstance(doc["cases"], list) or not all(isinstance(c, dict) for c in doc["cases"]):
            raise InputError(f"case file {path}: cases must be a list of objects")
        cases = [_case(c, path.parent) for c in doc["cases"]]
    except KeyError as exc:
        raise InputError(f"case file {path} lacks the field {exc}") from None
    except InputError as exc:
        text = str(exc)
        raise InputError(text if text.startswith(f"case file {path}") else f"case file {path}: {text}") from None
    return CaseFile(None if camera is None else camera.K, board, cases, camera)


def _camera(doc: dict, path: Path) -> Camera:
    """The case file's camera: ``K`` (a pinhole), or ``camera`` (a file or an inline object)."""
    if ("K" in doc) == ("camera" in doc):
        raise InputError(f"case file {path} must give the camera's K (no lens distortion) or a camera "
                         f"(a calibration file or an inline {{model, K, distortion, size}} object), "
                         f"{'not both' if 'K' in doc else 'got neither'}")
    if "K" in doc:
        return PinholeCamera(check_K(doc["K"]))
    entry = doc["camera"]
    if isinstance(entry, str):
        return read_camera(_absolute(path.parent / entry))
    if isinstance(entry, dict):
        return camera_from_dict(entry, f"case file {path}: camera")
    raise InputError(f"case file {path}: camera must be a calibration file's path (relative to the case "
                     f"file) or an object {{model, K, distortion, size}}, got {entry!r}")


def _board(doc: dict, path: Path) -> Board:
    """The board of a case file: ``grid`` as an object or a [cols, rows] list, and ``square_m``."""
    default = Board()
    grid = doc.get("grid", {})
    if isinstance(grid, list) and len(grid) == 2:
        grid = {"cols": grid[0], "rows": grid[1]}
    if not isinstance(grid, dict):
        raise InputError(
            f'case file {path}: grid must be an object {{"cols": 8, "rows": 6}} or a list [8, 6], got {grid!r}')
    cols = check_count("grid cols", grid.get("cols", default.cols), 2)
    rows = check_count("grid rows", grid.get("rows", default.rows), 2)
    square_m = check_number("square_m (metres)", doc.get("square_m", default.square_m), 0.0, strict=True)
    return Board(cols, rows, square_m)


def _case(entry: dict, folder: Path) -> Case:
    image = entry["image"]
    if not isinstance(image, str):
        raise InputError(f"a case's image must be a path string, got {image!r}")
    bounds = None if entry.get("bounds") is None else as_polygon(entry["bounds"], f"bounds of {image}", 4)

    def optional(key, check):
        return None if entry.get(key) is None else check(f"{key} of {image}", entry[key])

    return Case(
        image=_absolute(folder / image),
        bounds=bounds,
        guess_T_WC=optional("guess_T_WC", lambda name, T: check_transform(T, name)),
        ref_junctions=optional("ref_junctions", lambda name, P: as_points(P, 2, name)),
        # An estimate from elsewhere, rounded: only its shape is checked, not its rotation.
        ref_T_WC=optional("ref_T_WC", lambda name, T: as_float_array(T, name, shape=(4, 4))),
        true_T_WC=optional("true_T_WC", lambda name, T: check_transform(T, name)),
        true_junctions=optional("true_junctions", lambda name, P: as_points(P, 2, name)),
    )


def _absolute(path: Path) -> Path:
    """``path`` absolute and normalised, symbolic links kept as named."""
    return Path(os.path.abspath(path))


# --- Writing results: whole files or nothing -------------------------------------------


def load_pose(path) -> np.ndarray:
    """Read a pose file: a JSON 4 x 4 matrix, as a nested list or as ``{"T_WC": [...]}``.

    A list holding one such object (the command line's ``--json`` output for one image) is
    read too.

    Returns
    -------
    T_WC : (4, 4) ndarray of float64
        Validated by :func:`graphpose._checks.check_transform`.

    Raises
    ------
    InputError
        If the file is missing, not JSON, or not a rigid 4 x 4 transform.
    """
    path = Path(path)
    doc = read_json(path, "pose file")
    if isinstance(doc, list) and len(doc) == 1 and isinstance(doc[0], dict):
        doc = doc[0]  # the --json output of one image
    if isinstance(doc, dict):
        if "T_WC" not in doc:
            raise InputError(f"pose file {path} is an object without the key T_WC")
        doc = doc["T_WC"]
    try:
        T = as_float_array(doc, "pose")
    except InputError:
        raise InputError(f"pose file {path} must hold a 4 x 4 matrix of numbers") from None
    return check_transform(T, f"pose in {path.name}")


def bundled_cases_path() -> Path:
    """Path of the bundled example's case file, ``graphpose/data/cases.json``.

    The four synthetic images beside it (made by ``scripts/make_data.py`` with
    :mod:`graphpose.synth.render`) ship as package data, so the example runs from an
    installed wheel as well as from a checkout.
    """
    return Path(__file__).resolve().parents[1] / "data" / "cases.json"  # the package is on disk


def bundled_cases() -> CaseFile:
    """The bundled example: four synthetic images with their true poses (:func:`load_cases`)."""
    return load_cases(bundled_cases_path())

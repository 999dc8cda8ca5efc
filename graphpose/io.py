"""Reading images and case files.

A case file is the JSON format of ``../shared/data/rob501/cases.json``: ``K`` (3 x 3),
optional ``square_m`` and ``grid`` (``{"cols": 8, "rows": 6}``), and ``cases``, each with
``image`` (a path relative to the file), ``bounds`` (2 x 4 polygon) and optionally
``guess_T_WC``, ``ref_junctions`` (2 x n) and ``ref_T_WC`` (estimates from elsewhere), and
``true_T_WC`` and ``true_junctions`` (exact, for images made by :mod:`graphpose.render`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .board import Board
from .camera import check_K, check_transform
from .errors import InputError

#: ITU-R BT.601 luma weights for R, G, B.
_LUMA = np.array([0.299, 0.587, 0.114])


def as_grey(image) -> np.ndarray:
    """Convert an image to a float64 grey array scaled to [0, 1].

    Parameters
    ----------
    image : (H, W), (H, W, 3) or (H, W, 4) array_like
        uint8 (scaled by 1/255), uint16 (by 1/65535), bool, or float (kept as is).
        Colour is converted with ITU-R 601 luma weights; alpha is dropped.

    Raises
    ------
    InputError
        If the array is empty, has another shape, or holds NaN or infinite values.
    """
    I = np.asarray(image)
    if I.size == 0:
        raise InputError("image is empty")
    if I.ndim == 3 and I.shape[2] in (3, 4):
        return _finite(_scale(I[..., :3]) @ _LUMA)
    if I.ndim != 2:
        raise InputError(f"image must be 2-D grey or (H, W, 3|4) colour, got shape {I.shape}")
    return _finite(_scale(I))


def _scale(I: np.ndarray) -> np.ndarray:
    if I.dtype == np.uint8:
        return I.astype(float) / 255.0
    if I.dtype == np.uint16:
        return I.astype(float) / 65535.0
    if I.dtype.kind in "biuf":
        return I.astype(float)
    raise InputError(f"image has unsupported dtype {I.dtype}")


def _finite(I: np.ndarray) -> np.ndarray:
    if not np.all(np.isfinite(I)):
        raise InputError("image contains NaN or infinite values")
    return I


def read_image(path) -> np.ndarray:
    """Read an image file as float64 grey in [0, 1], shape (H, W).

    Raises
    ------
    InputError
        If the file is missing or cannot be decoded as an image.
    """
    from skimage import io as skio

    path = Path(path)
    if not path.is_file():
        raise InputError(f"image file not found: {path}")
    try:
        data = skio.imread(str(path))
    except Exception as exc:  # decoders raise many types; all mean "not an image"
        raise InputError(f"cannot read image {path}: {exc}") from None
    return as_grey(data)


@dataclass(frozen=True)
class Case:
    """One image of a case file; arrays as in the module docstring, None where absent."""

    image: Path
    bounds: np.ndarray
    guess_T_WC: np.ndarray | None = None
    ref_junctions: np.ndarray | None = None
    ref_T_WC: np.ndarray | None = None
    true_T_WC: np.ndarray | None = None
    true_junctions: np.ndarray | None = None


@dataclass(frozen=True)
class CaseFile:
    """A parsed case file: intrinsics K (3, 3), the board, and its cases."""

    K: np.ndarray
    board: Board
    cases: list


def load_cases(path) -> CaseFile:
    """Read a case file (format in the module docstring); image paths become absolute.

    Raises
    ------
    InputError
        If the file is missing, not JSON, or a field has the wrong shape.
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"case file not found: {path}") from None
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read case file {path}: {exc}") from None
    try:
        K = check_K(doc["K"])
        grid = doc.get("grid", {})
        board = Board(int(grid.get("cols", 8)), int(grid.get("rows", 6)), float(doc.get("square_m", 0.0635)))
        cases = [_case(c, path.parent) for c in doc["cases"]]
    except KeyError as exc:
        raise InputError(f"case file {path} lacks the field {exc}") from None
    except (TypeError, ValueError) as exc:
        raise InputError(f"case file {path}: {exc}") from None
    return CaseFile(K, board, cases)


def _case(entry: dict, folder: Path) -> Case:
    bounds = np.asarray(entry["bounds"], dtype=float)
    if bounds.shape != (2, 4):
        raise InputError(f"bounds of {entry['image']} must be 2 x 4, got {bounds.shape}")

    def optional(key, check):
        return None if entry.get(key) is None else check(np.asarray(entry[key], dtype=float))

    return Case(
        image=(folder / entry["image"]).resolve(),
        bounds=bounds,
        guess_T_WC=optional("guess_T_WC", lambda T: check_transform(T, "guess_T_WC")),
        ref_junctions=optional("ref_junctions", lambda P: P),
        ref_T_WC=optional("ref_T_WC", lambda T: T),
        true_T_WC=optional("true_T_WC", lambda T: check_transform(T, "true_T_WC")),
        true_junctions=optional("true_junctions", lambda P: P),
    )

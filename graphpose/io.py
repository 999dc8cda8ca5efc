"""Reading images and case files.

A case file is the JSON format of ``../shared/data/rob501/cases.json``: ``K`` (3 x 3),
optional ``square_m`` and ``grid`` (``{"cols": 8, "rows": 6}``), and ``cases``, each with
``image`` (a path relative to the file), ``bounds`` (2 x 4 polygon) and optionally
``guess_T_WC``, ``ref_junctions`` (2 x n) and ``ref_T_WC`` (estimates from elsewhere), and
``true_T_WC`` and ``true_junctions`` (exact, for images made by :mod:`graphpose.render`).
"""

from __future__ import annotations

import json
import os
import secrets
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .board import Board
from .camera import as_float_array, as_points, check_K, check_transform
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

    Returns
    -------
    grey : (H, W) ndarray of float64
        A grey float64 image is returned itself, not copied (the tracker passes each frame
        through here several times): treat the result as read-only.

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
        return I.astype(float, copy=False)
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
        If the file is missing, not JSON, not an object, lacks ``K``, ``cases`` or a case's
        ``image`` or ``bounds``, or a field has the wrong type or shape.
    """
    path = Path(path)
    doc = read_json(path, "case file")
    if not isinstance(doc, dict):
        raise InputError(f"case file {path} must hold a JSON object, got {type(doc).__name__}")
    try:
        K = check_K(doc["K"])
        grid = doc.get("grid", {})
        if not isinstance(grid, dict):
            raise InputError(f'case file {path}: grid must be an object like {{"cols": 8, "rows": 6}}, got {grid!r}')
        board = Board(int(grid.get("cols", 8)), int(grid.get("rows", 6)), float(doc.get("square_m", 0.0635)))
        if not isinstance(doc["cases"], list) or not all(isinstance(c, dict) for c in doc["cases"]):
            raise InputError(f"case file {path}: cases must be a list of objects")
        cases = [_case(c, path.parent) for c in doc["cases"]]
    except KeyError as exc:
        raise InputError(f"case file {path} lacks the field {exc}") from None
    except (TypeError, ValueError) as exc:
        raise InputError(f"case file {path}: {exc}") from None
    return CaseFile(K, board, cases)


def _case(entry: dict, folder: Path) -> Case:
    image = entry["image"]
    if not isinstance(image, str):
        raise InputError(f"a case's image must be a path string, got {image!r}")
    bounds = as_float_array(entry["bounds"], f"bounds of {image}")
    if bounds.shape != (2, 4):
        raise InputError(f"bounds of {image} must be 2 x 4, got {bounds.shape}")

    def optional(key, check):
        return None if entry.get(key) is None else check(f"{key} of {image}", entry[key])

    return Case(
        image=(folder / image).resolve(),
        bounds=bounds,
        guess_T_WC=optional("guess_T_WC", lambda name, T: check_transform(T, name)),
        ref_junctions=optional("ref_junctions", lambda name, P: as_points(P, 2, name)),
        # An estimate from elsewhere, rounded: only its shape is checked, not its rotation.
        ref_T_WC=optional("ref_T_WC", lambda name, T: as_float_array(T, name, shape=(4, 4))),
        true_T_WC=optional("true_T_WC", lambda name, T: check_transform(T, name)),
        true_junctions=optional("true_junctions", lambda name, P: as_points(P, 2, name)),
    )


# --- Writing results: whole files or nothing -------------------------------------------


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
    path = Path(path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
    try:
        # os.open with mode 0o666 lets the umask set the final permissions, as open() would.
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise InputError(f"cannot write {path}: {exc.strerror or exc}") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


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


def result_record(image, estimate=None, error=None) -> dict:
    """One image's result as a JSON-ready dict (the ``--json`` format of the command line).

    Parameters
    ----------
    image : str or Path
        The image, as the user named it.
    estimate : PoseEstimate or None
        The pose (see :func:`graphpose.pipeline.estimate_pose`); None when the image failed.
    error : str or None
        Why the image failed, or None.

    Returns
    -------
    record : dict
        Keys ``image``, ``converged``, ``iterations``, ``T_WC`` (4 x 4), ``xyz_m`` (3),
        ``rpy_deg`` (3, roll pitch yaw), ``sigma_xyz_mm`` (3), ``sigma_rpy_deg`` (3),
        ``reprojection_rms_px``, ``junctions`` (2 x n pixels, null where a junction was not
        measured; null altogether for an estimate from given points, which has no
        ``junctions``), ``trusted`` (n booleans: the junctions' flags, or the estimate's
        ``mask`` without junctions), ``cross_check`` (``translation_m``, ``rotation_deg``,
        ``agree``) and ``error``. Without an estimate every key but ``image``, ``converged``
        (false) and ``error`` is null.
    """
    record = {"image": str(image), "converged": False, "iterations": None, "T_WC": None,
              "xyz_m": None, "rpy_deg": None, "sigma_xyz_mm": None, "sigma_rpy_deg": None,
              "reprojection_rms_px": None, "junctions": None, "trusted": None,
              "cross_check": None, "error": error}
    if estimate is None:
        return record
    params = np.asarray(estimate.params)
    check = estimate.cross_check
    junctions = estimate.junctions
    record.update(
        converged=bool(estimate.converged),
        iterations=int(estimate.iterations),
        T_WC=np.asarray(estimate.T_WC),
        xyz_m=params[:3],
        rpy_deg=np.degrees(params[3:]),
        sigma_xyz_mm=1000.0 * np.asarray(estimate.sigma_xyz_m),
        sigma_rpy_deg=np.degrees(estimate.sigma_rpy_rad),
        reprojection_rms_px=float(estimate.reprojection_rms_px),
        junctions=None if junctions is None else np.asarray(junctions.points),
        trusted=np.asarray(estimate.mask if junctions is None else junctions.trusted, dtype=bool),
        cross_check={"translation_m": float(check.translation_m),
                     "rotation_deg": float(check.rotation_deg), "agree": bool(check.agree)},
    )
    return to_jsonable(record)


def load_pose(path) -> np.ndarray:
    """Read a pose file: a JSON 4 x 4 matrix, as a nested list or as ``{"T_WC": [...]}``.

    A list holding one such object (the command line's ``--json`` output for one image) is
    read too.

    Returns
    -------
    T_WC : (4, 4) ndarray of float64
        Validated by :func:`graphpose.camera.check_transform`.

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

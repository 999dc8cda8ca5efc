"""What a batch runs on: image paths from folders, glob patterns and list files, and polygons.

Every path leaves here absolute (``os.path.abspath``, symbolic links kept as named), since
workers on other machines know nothing of the client's working folder and a re-run started
elsewhere must recognise the images already done. Relative paths in a list file or a bounds
file are taken relative to that file's folder, as in a case file.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._checks import as_float_array
from ..errors import InputError
from ..io.files import read_json

from ..image import IMAGE_SUFFIXES  # noqa: F401  (the endings taken from a folder, re-exported)
from ..io.sources.paths import LIST_SUFFIXES, expand_paths  # noqa: F401  (one home for the expansion)


def collect_images(inputs) -> list:
    """The images named by ``inputs``, absolute, each once, in the order given.

    Parameters
    ----------
    inputs : iterable of str or Path
        Each one of: a folder (its files ending in :data:`IMAGE_SUFFIXES`, by name; not its
        sub-folders); a glob pattern (``*``, ``?``, ``[...]``; ``**`` crosses folders),
        its matching files by name; a text file ending in :data:`LIST_SUFFIXES` listing one
        path a line (blank lines and lines starting with ``#`` skipped); or an image path.
        A listed or named image that does not exist is kept: its row will say ``missing``.

    Returns
    -------
    list of str
        Absolute paths.

    Raises
    ------
    InputError
        If a folder has no image, a pattern matches no file, a list file cannot be read,
        or nothing at all is named.
    """
    # graphpose.io.sources.expand_paths expands them, as every command does; each once, in order.
    return list(dict.fromkeys(os.path.abspath(p) for p in expand_paths(list(inputs))))


def read_bounds_file(path) -> dict:
    """Per-image bounding polygons from a JSON file.

    The file holds either an object mapping image paths to polygons,
    ``{"img_001.png": [[u1, u2, u3, u4], [v1, v2, v3, v4]], ...}``, or a case file's
    ``{"cases": [{"image": ..., "bounds": ...}, ...]}`` (other keys ignored; a case without
    ``bounds`` is searched whole, as in ``graphpose estimate --cases``). A polygon is
    2 x 4 pixels, clockwise from the vertex nearest the board's upper-left junction, as
    ``graphpose estimate --bounds``; ``null`` searches the whole image.

    Parameters
    ----------
    path : str or Path
        The JSON file; relative image paths in it are relative to its folder.

    Returns
    -------
    dict
        Absolute image path -> (2, 4) ndarray of float64, or None.

    Raises
    ------
    InputError
        If the file is missing or not JSON, not of either form, or a polygon is not a
        finite 2 x 4 array of numbers.
    """
    path = Path(path)
    doc = read_json(path, "bounds file")
    if isinstance(doc, dict) and isinstance(doc.get("cases"), list):
        pairs = []
        for k, case in enumerate(doc["cases"]):
            if not isinstance(case, dict) or not isinstance(case.get("image"), str):
                raise InputError(f"bounds file {path}: cases[{k}] must be an object with 'image' (a path) "
                                 f"and optionally 'bounds' (2 x 4)")
            pairs.append((case["image"], case.get("bounds")))  # a case without bounds: the whole image
    elif isinstance(doc, dict):
        pairs = list(doc.items())
    else:
        raise InputError(f"bounds file {path} must hold a JSON object (image path -> 2 x 4 polygon, or a "
                         f"case file's 'cases'), got {type(doc).__name__}")
    folder = path.parent
    return {os.path.abspath(folder / image): None if poly is None else check_polygon(poly, f"bounds of {image} in {path}")
            for image, poly in pairs}


def check_polygon(poly, name: str) -> np.ndarray:
    """A finite (2, 4) polygon (u row, v row) in pixels as float64; InputError otherwise."""
    P = as_float_array(poly, name, shape=(2, 4))
    if not np.all(np.isfinite(P)):
        raise InputError(f"{name} contains NaN or infinite values")
    return P

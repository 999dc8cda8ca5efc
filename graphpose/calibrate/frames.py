"""Which images a rig's cameras took together: frame sources and their matching.

Each camera's source (a list of files, a folder, or a glob) gives its images in order, each
with a *stamp*: the number in its file name (``left07.jpg`` -> 7; the last run of digits in
the name without its suffix). :func:`match_frames` groups stamps across cameras into views: the
stamps of a view lie within ``tolerance`` of its first, and each camera gives at most one. With
file numbers the tolerance is 0 (the same number); a recording's frames carry timestamps in
seconds, which the same function matches within a tolerance (a frame source that yields
``(timestamp, image)`` plugs in here). A camera may miss a view: that view has None there.
"""

from __future__ import annotations

import glob
import re
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..image import IMAGE_SUFFIXES
from ..io.sources.paths import list_images


def source_files(source, what: str = "source") -> list:
    """The image files of one camera's source, in name order.

    Parameters
    ----------
    source : str, Path or sequence of them
        A folder (its image files, :func:`graphpose.io.sources.paths.list_images`), a glob
        pattern (``left*.jpg``), one file, or a list of files.
    what : str
        The source's name in messages.

    Raises
    ------
    InputError
        If a file does not exist, or the folder or glob gives no image.
    """
    if isinstance(source, (str, Path)):
        path = Path(source)
        if path.is_dir():
            files = list_images(path)
        elif path.is_file():
            files = [path]
        elif any(ch in str(source) for ch in "*?["):
            files = sorted(Path(p) for p in glob.glob(str(source)))
        else:
            raise InputError(f"{what}: {source} is no file, folder or glob pattern")
        if not files:
            raise InputError(f"{what}: {source} holds no image file ({', '.join(IMAGE_SUFFIXES)})")
        return files
    files = [Path(p) for p in source]
    for f in files:
        if not f.is_file():
            raise InputError(f"{what}: image not found: {f}")
    if not files:
        raise InputError(f"{what}: no image given")
    return files


def file_number(path) -> int:
    """The number in a file's name: the last run of digits of its stem (``left07`` -> 7).

    Raises
    ------
    InputError
        If the name holds no digit.
    """
    digits = re.findall(r"\d+", Path(path).stem)
    if not digits:
        raise InputError(f"{path}: its name holds no frame number to match it with the other cameras' "
                         "images (name them left07.jpg, right07.jpg, ..., or give frames=[(left, right), ...])")
    return int(digits[-1])


def match_frames(stamps, tolerance: float = 0.0) -> list:
    """Group the cameras' frames into views by their stamps.

    Parameters
    ----------
    stamps : sequence of (n_c,) array_like
        Per camera, its frames' stamps (file numbers, or timestamps in seconds), each camera's
        distinct.
    tolerance : float
        The largest spread of stamps within one view (0: equal stamps).

    Returns
    -------
    views : list of tuple
        Per view, in the order of its first stamp, one entry per camera: the index of that
        camera's frame, or None where it has none.

    Raises
    ------
    InputError
        If a camera's stamps repeat (two of its frames would fall in one view).
    """
    events = []
    for c, s in enumerate(stamps):
        s = np.asarray(s, dtype=float).ravel()
        if np.unique(s).size != s.size:
            raise InputError(f"camera {c}: its frames' numbers (or timestamps) repeat, so its images "
                             f"cannot be matched with the other cameras': {sorted(s.tolist())[:20]}")
        events += [(float(t), c, i) for i, t in enumerate(s)]
    events.sort()
    views, group, start = [], None, None
    for t, c, i in events:
        if group is None or group[c] is not None or t - start > tolerance:
            if group is not None:
                views.append(tuple(group))
            group, start = [None] * len(stamps), t
        group[c] = i
    if group is not None:
        views.append(tuple(group))
    return views

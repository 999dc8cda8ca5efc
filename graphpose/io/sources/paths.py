"""Image files named the ways people name them: folders, files, quoted globs and list files.

:func:`expand_paths` turns what was typed into the image files in order (a folder's by
:func:`list_images`), and
:class:`ImageFiles` reads them as a :class:`~graphpose.io.sources.base.Recording` whose frames
have no timestamps of their own (``--timestamps`` or ``--fps`` give them).
"""

from __future__ import annotations

import glob
import os
from pathlib import Path

from ...errors import InputError
from ...image import IMAGE_SUFFIXES, read_image
from .base import Frame, Recording

#: Endings of a text file that lists image paths, one a line.
LIST_SUFFIXES = (".txt", ".lst", ".list")
_GLOB = "*?["


def is_pattern(text: str) -> bool:
    """True for a glob pattern (``*``, ``?``, ``[``) that is not itself an existing path."""
    return any(c in text for c in _GLOB) and not os.path.exists(text)


def expand_paths(items) -> list:
    """The image files named by ``items``, in order.

    Parameters
    ----------
    items : str, Path or iterable of them
        Each one of: a folder (its files ending in :data:`graphpose.image.IMAGE_SUFFIXES`, by
        name; not its sub-folders); a glob pattern (quoted, so that graphpose expands it;
        ``**`` crosses folders), its matching files by name; a text file ending in
        :data:`LIST_SUFFIXES` that lists one path a line (relative to the list's folder; blank
        lines and ``#`` comments skipped); or an image path (kept as typed: a missing file is
        the reader's to report).

    Returns
    -------
    list of Path

    Raises
    ------
    InputError
        If a folder holds no image, a pattern matches no file, a list file cannot be read or
        lists nothing, or nothing is named at all.
    """
    if isinstance(items, (str, os.PathLike)):
        items = [items]
    paths = []
    for item in items:
        text = os.fspath(item)
        path = Path(text)
        if path.is_dir():
            files = list_images(path)
            if not files:
                raise InputError(f"no image files ({', '.join(IMAGE_SUFFIXES)}) in {path}")
            paths += files
        elif path.is_file() and path.suffix.lower() in LIST_SUFFIXES:
            paths += list_file(path)
        elif is_pattern(text):
            matches = sorted(Path(m) for m in glob.glob(text, recursive=True) if os.path.isfile(m))
            if not matches:
                raise InputError(f"the pattern {text!r} matches no file")
            paths += matches
        else:
            paths.append(path)
    if not paths:
        raise InputError("no images given")
    return paths


def list_images(folder) -> list:
    """A folder's image files in name order: its files (not its sub-folders) whose name ends in
    one of :data:`graphpose.image.IMAGE_SUFFIXES`, in any case; empty when it holds none.
    Every folder of images graphpose reads (commands, tracks, a rig's cameras) is read with it.
    """
    return sorted(p for p in Path(folder).iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)


def list_file(path) -> list:
    """The paths a list file names, one a line, relative to its folder (see :func:`expand_paths`)."""
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the list file {path}: {exc}") from None
    lines = [line.strip() for line in text.splitlines()]
    names = [line for line in lines if line and not line.startswith("#")]
    if not names:
        raise InputError(f"the list file {path} names no images (one path a line)")
    return [Path(name) if os.path.isabs(name) else path.parent / name for name in names]


class ImageFiles(Recording):
    """Image files read one at a time (:func:`graphpose.image.read_image`, 8-bit files as uint8).

    Parameters
    ----------
    items : str, Path or iterable of them
        As :func:`expand_paths`.
    """

    kind = "image files"

    def __init__(self, items):
        self.files = expand_paths(items)
        super().__init__(str(items) if isinstance(items, (str, os.PathLike)) else "images", None)

    def __len__(self) -> int:
        return len(self.files)

    def label(self, k: int) -> str:
        return str(self.files[k])

    def path(self, k: int) -> Path:
        return self.files[k]

    def read(self, k: int) -> Frame:
        """Frame ``k``: its file read (InputError, naming it, when it cannot be)."""
        return Frame(k, None, read_image(self.files[k], as_float=False))

    def seek_reader(self, k: int) -> None:
        """Nothing to do: every file is read on its own."""

"""The frames of a sequence and their times: folders, file lists or images, read one at a time.

A sequence comes as a recording (:mod:`graphpose.io.sources`: a folder, its image files in name
order (:func:`list_frames`), image files, a glob, a list file, a video, a ROS bag), or images in
memory (a list of arrays or one ``(N, H, W)`` array).
:class:`FrameSource` reads frame ``k`` only when the tracker reaches it, converted once for
every junction call of the frame. Times are seconds per frame, from a list, a text file
(:func:`read_timestamps`) or a frame rate (:func:`frame_timestamps`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._checks import as_float_array, check_number, check_timestamps
from ..errors import InputError
from ..image import as_grey, read_image


def list_frames(folder) -> list:
    """Image files of a folder in file-name order; other files are ignored.

    Parameters
    ----------
    folder : str or Path
        The folder.

    Returns
    -------
    list of Path
        Files whose name ends in one of :data:`graphpose.image.IMAGE_SUFFIXES`, sorted by name
        (:func:`graphpose.io.sources.paths.list_images`).

    Raises
    ------
    InputError
        If the folder does not exist or holds no image.
    """
    from ..io.sources.paths import expand_paths

    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"frames folder not found: {folder}")
    return expand_paths(folder)  # the folder's images, or its message for a folder without any


def read_timestamps(path, n_frames: int | None = None) -> np.ndarray:
    """Frame timestamps from a text file: one number (seconds) per line, ``#`` comments.

    Parameters
    ----------
    path : str or Path
        The file. Only the first number of a line is read (so a TUM-like file works too).
    n_frames : int, optional
        Expected count.

    Returns
    -------
    (N,) ndarray
        Seconds.

    Raises
    ------
    InputError
        If the file is missing or unreadable (a folder, not text), a line is not a number,
        the count differs from ``n_frames``, or the times do not increase strictly.
    """
    path = Path(path)
    try:
        lines = path.read_text().splitlines()
    except FileNotFoundError:
        raise InputError(f"timestamps file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read timestamps file {path}: {exc}") from None
    values = []
    for number, line in enumerate(lines, start=1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        try:
            values.append(float(line.replace(",", " ").split()[0]))
        except ValueError:
            raise InputError(f"{path}:{number}: not a timestamp: {line!r}") from None
    t = np.array(values)
    if n_frames is not None and t.size != n_frames:
        raise InputError(f"{path} holds {t.size} timestamps for {n_frames} frames")
    return check_timestamps(t, str(path))


def frame_timestamps(timestamps, fps: float, n: int) -> np.ndarray:
    """Seconds of ``n`` frames: ``timestamps`` checked, or ``index / fps`` without them.

    Parameters
    ----------
    timestamps : (n,) array_like or None
        Seconds per frame, strictly increasing.
    fps : float
        Frame rate used when ``timestamps`` is None, frames a second.
    n : int
        Number of frames.

    Returns
    -------
    (n,) ndarray
        Seconds.

    Raises
    ------
    InputError
        If ``timestamps`` does not hold ``n`` finite, strictly increasing numbers, or (without
        it) ``fps`` is not a positive finite number.
    """
    if timestamps is None:
        check_number("fps", fps, 0.0, strict=True)
        return np.arange(n) / float(fps)
    t = as_float_array(timestamps, "timestamps").reshape(-1)
    if t.size != n:
        raise InputError(f"timestamps has {t.size} entries for {n} frames")
    return check_timestamps(t, "timestamps")


class FrameSource:
    """The frames of a sequence, read one at a time.

    Parameters
    ----------
    frames : str, Path, Recording, or sequence of images or paths
        A recording (:func:`graphpose.io.sources.open_frames`: a folder, image files, a glob
        pattern, a list file, a video, a ROS bag, or an open
        :class:`~graphpose.io.sources.base.Recording`), images ``(H, W)`` / ``(H, W, 3|4)``
        arrays, or an ``(N, H, W)`` array.
    topic : str, optional
        A bag's image topic (:func:`graphpose.io.sources.open_frames`).

    Raises
    ------
    InputError
        If ``frames`` is none of these (one 2-D image, a number), or a folder that does not
        exist or holds no image, or a recording that cannot be opened.
    """

    def __init__(self, frames, topic=None):
        from ..io.sources import Recording, open_frames

        self.recording = None
        if isinstance(frames, Recording):
            self.recording = frames
        elif isinstance(frames, (str, Path)):
            from ..io.sources.paths import is_pattern

            if Path(frames).is_dir():
                list_frames(frames)  # its own message for a folder without images
            elif not Path(frames).exists() and not is_pattern(str(frames)):
                raise InputError(f"frames not found: {frames} (a folder, an image, a glob, a list file, a video "
                                 f"or a ROS bag)")
            self.recording = open_frames(frames, topic=topic)
        elif isinstance(frames, np.ndarray) and frames.ndim in (2, 3, 4) and frames.dtype != object:
            if frames.ndim == 2:
                raise InputError(f"frames must be a sequence of images, got one array of shape {frames.shape}")
            self._items = frames
        else:
            try:
                items = list(frames)
            except TypeError:
                raise InputError(f"frames must be a folder, a recording, a list of files or of images, "
                                 f"got {type(frames).__name__}") from None
            if items and all(isinstance(item, (str, Path)) for item in items):
                self.recording = open_frames(items, topic=topic)
            else:
                self._items = items
        if topic is not None and self.recording is None:
            raise InputError(f"topic {topic} chooses a ROS bag's image topic, and frames is not a bag")

    def __len__(self) -> int:
        return len(self.recording) if self.recording is not None else len(self._items)

    @property
    def timestamps(self):
        """(N,) seconds the recording carries (a video's presentation times, a bag's header
        stamps), or None (image files, images in memory)."""
        return None if self.recording is None else self.recording.timestamps

    def path(self, k: int) -> Path | None:
        """The file of frame ``k`` (a video's or bag's own path), or None for an image given in memory."""
        if self.recording is not None:
            return self.recording.path(k)
        item = self._items[k]
        return Path(item) if isinstance(item, (str, Path)) else None

    def label(self, k: int) -> str:
        """Frame ``k``'s name in messages: its file, ``VIDEO#k``, ``BAG:TOPIC#k`` or ``frame k``."""
        if self.recording is not None:
            return self.recording.label(k)
        path = self.path(k)
        return f"frame {k}" if path is None else str(path)

    def load(self, k: int) -> np.ndarray:
        """Frame ``k`` as a grey image, converted once for every junction call of the frame.

        Returns
        -------
        (H, W) ndarray
            8-bit grey as it is (no NaN possible; the junction code reads it without a copy),
            anything else float64 grey (:func:`graphpose.image.as_grey`: integers scaled to
            [0, 1], floats kept) checked finite; a file is read by
            :func:`graphpose.image.read_image` with ``as_float=False``, as ``graphpose
            estimate`` reads it (an 8-bit file stays uint8); a video or bag frame is decoded
            in order (:meth:`graphpose.io.sources.base.Recording.read`).

        Raises
        ------
        InputError
            If the file is missing or cannot be decoded, or the image is not a finite grey or
            colour image; the message names the frame.
        BrokenRecordingError
            If a video or bag cannot be read at frame ``k`` (the frames before could be).
        """
        if self.recording is not None:
            image = self.recording.read(k).image
            return image if image.dtype == np.uint8 else as_grey(image)
        item = self._items[k]
        if isinstance(item, (str, Path)):  # a file among images in memory
            return read_image(item, as_float=False)
        try:
            image = np.asarray(item)
            if image.ndim == 2 and image.dtype == np.uint8 and image.size:
                return image
            return as_grey(image)
        except (TypeError, ValueError) as exc:  # InputError is a ValueError; ragged lists raise ValueError
            raise InputError(f"frame {k} must be a finite (H, W) grey or (H, W, 3|4) colour image: {exc}") from None

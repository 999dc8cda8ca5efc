"""One frame source for every command and the library: image files, videos and ROS bags.

:func:`open_frames` turns what was typed (a folder, image files, a quoted glob, a list file, a
video, a ROS 1 or ROS 2 bag) into a :class:`~graphpose.io.sources.base.Recording`: its frames
counted and timed up front, then read one at a time as grey images, each with its own
timestamp (a video's presentation time, a bag message's header stamp; image files have none).
See ``docs/recordings.md``.
"""

from __future__ import annotations

import os
from pathlib import Path

from ...errors import InputError
from .base import BrokenRecordingError, Frame, Recording  # noqa: F401  (re-exported)
from .bags import BagRecording, is_bag
from .paths import ImageFiles, expand_paths  # noqa: F401  (re-exported)
from .video import VIDEO_SUFFIXES, VideoRecording


def is_recording(item) -> bool:
    """True when ``item`` names a video (by its ending) or a ROS bag (file or folder)."""
    if isinstance(item, (str, os.PathLike)):
        path = Path(item)
        return path.suffix.lower() in VIDEO_SUFFIXES or is_bag(path)
    return False


def open_frames(items, *, topic: str | None = None) -> Recording:
    """The frames named by ``items``, as one :class:`Recording`.

    Parameters
    ----------
    items : str, Path or sequence of them
        One video (any container and codec FFmpeg reads, by its ending:
        :data:`~graphpose.io.sources.video.VIDEO_SUFFIXES`), one ROS bag (a ROS 1 ``.bag``, a
        ROS 2 bag folder), or image files as :func:`expand_paths` takes them (folders, files,
        glob patterns, list files).
    topic : str, optional
        A bag's image topic (a bag with one image topic needs none); refused for anything else.

    Returns
    -------
    Recording
        :class:`~graphpose.io.sources.video.VideoRecording`,
        :class:`~graphpose.io.sources.bags.BagRecording` or
        :class:`~graphpose.io.sources.paths.ImageFiles`.

    Raises
    ------
    InputError
        If a recording is named with other inputs, ``topic`` is given without a bag, or the
        source cannot be opened (missing, unreadable, no frame, no such topic: the message
        says which).
    """
    seq = [items] if isinstance(items, (str, os.PathLike)) else list(items)
    recordings = [item for item in seq if is_recording(item)]
    if recordings and len(seq) > 1:
        raise InputError(f"a recording ({recordings[0]}) is read on its own: give one video or bag, "
                         f"or image files, not both")
    if recordings and is_bag(recordings[0]):
        return BagRecording(recordings[0], topic)
    if topic is not None:
        raise InputError(f"--topic {topic} chooses a ROS bag's image topic, and no bag was given")
    if recordings:
        return VideoRecording(recordings[0])
    return ImageFiles(seq)


def frame_key(recording: Recording, k: int) -> str:
    """One frame of a video or bag as a string (a batch row's ``image``): ``/abs/video.mp4#k``,
    or ``/abs/bag:/topic#k``; :func:`parse_frame_key` reads it back."""
    name = os.path.abspath(recording.name)
    topic = getattr(recording, "topic", None)
    return f"{name}:{topic}#{k}" if topic else f"{name}#{k}"


def parse_frame_key(key: str):
    """``(recording path, topic or None, k)`` of a :func:`frame_key`, or None for any other string
    (an image path, even one with a '#' in its name: the recording must exist)."""
    base, sep, index = str(key).rpartition("#")
    if not sep or not index.isdigit():
        return None
    path, topic = base, None
    if ":/" in base and not os.path.exists(base):
        path, topic = base.split(":/", 1)
        topic = "/" + topic
    return (path, topic, int(index)) if is_recording(path) and os.path.exists(path) else None

"""What every frame source is: frames counted and timed up front, read one at a time, in order.

A :class:`Recording` (a video, a bag's image topic, a list of image files) knows how many frames
it holds and when each was taken before any is decoded (an index pass that reads no pixels), and
gives frame ``k`` as an 8-bit (or 16-bit) grey image with its own timestamp. Frames are decoded
in order from an open reader, so reading a recording from start to end costs one decode per
frame and holds one frame at a time; asking for an earlier frame, or one far ahead, reopens the
reader there (:meth:`Recording.seek_reader`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import InputError

#: Frames a reader decodes on to reach a frame ahead rather than seeking (a seek decodes from
#: the key frame before, which may be as far back).
FORWARD_DECODE = 250


class BrokenRecordingError(InputError):
    """A recording that cannot be read past a point (a truncated or corrupt video, a bag cut short).

    The frames before ``index`` were read; the message names where it broke.

    Attributes
    ----------
    index : int
        The first frame that could not be read.
    timestamp : float
        That frame's time from the index pass, seconds (NaN when unknown).
    """

    def __init__(self, message: str, index: int = 0, timestamp: float = float("nan")):
        super().__init__(message)
        self.index, self.timestamp = int(index), float(timestamp)


@dataclass(frozen=True)
class Frame:
    """One decoded frame.

    Attributes
    ----------
    index : int
        0-based position in the recording.
    timestamp : float
        Seconds: the container's presentation time, a bag message's header stamp, or None
        for image files (their times come from ``--timestamps`` or ``--fps``).
    image : (H, W) ndarray of uint8 or uint16
        Grey pixels as the recording holds them (no scaling).
    """

    index: int
    timestamp: float | None
    image: np.ndarray


class Recording:
    """Base class of the frame sources: subclasses set ``name``, ``timestamps`` and ``kind`` in
    their constructor and implement :meth:`_open_at` (an iterator of :class:`Frame` from frame
    ``k`` on)."""

    #: What the recording is, in words ("video", "ROS 2 bag", "image files").
    kind = "recording"
    #: The camera the recording carries (a bag's camera_info), or None.
    camera = None
    #: Where :attr:`camera` came from, in words (the bag and topic), or "".
    camera_source = ""
    #: Why the recording's frames end early, in one line naming where ("" when they do not):
    #: the index pass found the file cut short after its last readable frame.
    damage = ""

    def __init__(self, name: str, timestamps):
        self.name = str(name)
        #: (N,) seconds of every frame from the index pass, or None (image files).
        self.timestamps = None if timestamps is None else np.asarray(timestamps, dtype=float)
        self._reader, self._next = None, 0

    def __len__(self) -> int:
        return len(self.timestamps)

    def label(self, k: int) -> str:
        """Frame ``k``'s name in messages and records: ``NAME#k``."""
        return f"{self.name}#{k}"

    def path(self, k: int):
        """The file frame ``k`` is in (the recording's own path)."""
        from pathlib import Path

        return Path(self.name)

    def read(self, k: int) -> Frame:
        """Frame ``k``, decoded from the open reader when it is the next one, else by reopening it
        at ``k`` (:meth:`seek_reader`).

        Raises
        ------
        InputError
            If ``k`` is out of range.
        BrokenRecordingError
            If the recording cannot be read at ``k`` (its frames before ``k`` could be).
        """
        n = len(self)
        if not 0 <= k < n:
            raise InputError(f"frame {k} is not in {self.name} ({n} frames)")
        if self._reader is not None and self._next < k <= self._next + FORWARD_DECODE:
            while self._next < k:  # a few frames ahead: decoding on is cheaper than seeking
                self._advance(self._next)
        if self._reader is None or k != self._next:
            self.seek_reader(k)
        return self._advance(k)

    def _advance(self, k: int) -> Frame:
        try:
            frame = next(self._reader)
        except StopIteration:
            self._reader = None
            t = self.timestamps[k] if self.timestamps is not None else float("nan")
            raise BrokenRecordingError(f"{self.name} ended at frame {k} of the {len(self)} its index counted "
                                       f"(t = {t:.3f} s): the file is cut short or corrupt there", k, t) from None
        self._next = k + 1
        return frame

    def end_error(self):
        """The :class:`BrokenRecordingError` to raise after the last frame when the file was cut
        short after it (:attr:`damage`), else None."""
        if not self.damage:
            return None
        t = float(self.timestamps[-1]) if self.timestamps is not None and len(self.timestamps) else float("nan")
        return BrokenRecordingError(self.damage, len(self), t)

    def seek_reader(self, k: int) -> None:
        """Start reading at frame ``k`` (closing the reader open before)."""
        self.close()
        self._reader, self._next = self._open_at(k), k

    def frames(self, start: int = 0, stop: int | None = None, step: int = 1):
        """Frames ``start, start + step, ...`` below ``stop`` (default: the end), in order."""
        stop = len(self) if stop is None else min(stop, len(self))
        for k in range(start, stop, step):
            yield self.read(k)
        if stop == len(self) and self.end_error() is not None:
            raise self.end_error()

    def close(self) -> None:
        """Release the open reader, if any (a later :meth:`read` reopens it)."""
        reader, self._reader = getattr(self, "_reader", None), None
        if reader is not None and hasattr(reader, "close"):
            reader.close()

    def __del__(self):
        try:
            self.close()
        except Exception:  # noqa: BLE001 - at interpreter exit the readers' modules may be gone
            pass

    def _open_at(self, k: int):  # pragma: no cover - every subclass has its own
        raise NotImplementedError

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

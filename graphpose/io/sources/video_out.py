"""Videos out through PyAV: frames encoded one at a time (``--overlay-video``, rendered clips).

:class:`VideoWriter` takes grey or RGB uint8 frames of one size and encodes them as they come
(H.264 in yuv420p by default, at a constant rate factor), so nothing grows with the video;
the file appears whole or not at all (written beside it, renamed at :meth:`VideoWriter.close`).
"""

from __future__ import annotations

import os
import secrets
from fractions import Fraction
from pathlib import Path

import numpy as np

from ...errors import InputError


class VideoWriter:
    """An H.264 (or another FFmpeg encoder's) video written frame by frame.

    Parameters
    ----------
    path : str or Path
        The video; its ending names the container (``.mp4``, ``.mkv``, ``.avi``, ...).
    fps : float
        Frames a second (the time base is 1 / (fps * 1000): exact to the microsecond-ish for
        any rate).
    codec : str
        FFmpeg encoder name (default ``libx264``).
    crf : int
        Constant rate factor for x264/x265 (default 23, their own default).
    pix_fmt : str
        Pixel format of the stream (default ``yuv420p``, which every player reads).
    options : dict, optional
        More encoder options (FFmpeg's names, string values).
    container_options : dict, optional
        Muxer options, e.g. ``{"movflags": "+faststart"}`` (an MP4's index first).

    Raises
    ------
    InputError
        If the folder is missing or FFmpeg cannot write the container or codec.
    """

    def __init__(self, path, fps: float = 30.0, *, codec: str = "libx264", crf: int = 23, pix_fmt: str = "yuv420p",
                 options: dict | None = None, container_options: dict | None = None):
        import av

        self.path = Path(path)
        self.tmp = self.path.with_name(f".{self.path.stem}.{secrets.token_hex(4)}{self.path.suffix}")
        self.fps, self.codec, self.pix_fmt = float(fps), codec, pix_fmt
        self.options = {"crf": str(int(crf))} if codec in ("libx264", "libx265") else {}
        self.options.update(options or {})
        try:
            self.container = av.open(str(self.tmp), mode="w", options=dict(container_options or {}))
        except (av.FFmpegError, OSError, ValueError) as exc:
            raise InputError(f"cannot write {self.path}: {exc}") from None
        self.stream, self.count = None, 0
        self.time_base = Fraction(1, int(round(self.fps * 1000)))

    def add(self, image, pts_s: float | None = None) -> None:
        """Encode one frame: ``image`` (H, W) grey or (H, W, 3) RGB uint8, at ``pts_s`` seconds
        (default ``count / fps``)."""
        import av

        A = np.ascontiguousarray(image)
        if A.dtype != np.uint8 or A.ndim not in (2, 3) or (A.ndim == 3 and A.shape[2] != 3):
            raise InputError(f"a video frame must be uint8 (H, W) or (H, W, 3), got {A.dtype} {A.shape}")
        if self.stream is None:
            self._start(A.shape[1], A.shape[0])
        frame = av.VideoFrame.from_ndarray(A, format="gray" if A.ndim == 2 else "rgb24")
        t = self.count / self.fps if pts_s is None else float(pts_s)
        frame.pts = int(round(t / self.time_base))
        frame.time_base = self.time_base
        self.container.mux(self.stream.encode(frame))
        self.count += 1

    def close(self) -> None:
        """Flush the encoder and put the file in place."""
        if self.stream is not None:
            self.container.mux(self.stream.encode(None))
        self.container.close()
        os.replace(self.tmp, self.path)

    def abort(self) -> None:
        """Stop without writing the file."""
        try:
            self.container.close()
        finally:
            self.tmp.unlink(missing_ok=True)

    def _start(self, width: int, height: int) -> None:
        self.stream = self.container.add_stream(self.codec, rate=Fraction(int(round(self.fps * 1000)), 1000),
                                                options=self.options)
        self.stream.width, self.stream.height = width + width % 2, height + height % 2
        self.stream.pix_fmt = self.pix_fmt
        self.stream.time_base = self.time_base
        self.stream.codec_context.time_base = self.time_base
        if (width, height) != (self.stream.width, self.stream.height):  # yuv420p needs even sides
            raise InputError(f"{self.path}: {self.pix_fmt} needs an even width and height, got {width} x {height}")

    def __enter__(self):
        return self

    def __exit__(self, kind, *exc):
        if kind is None:
            self.close()
        else:
            self.abort()

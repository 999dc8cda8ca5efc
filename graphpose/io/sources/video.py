"""Videos through PyAV (FFmpeg): any container and codec FFmpeg reads, one grey frame at a time.

The index pass reads the packets only (no decoding): how many frames there are and each one's
presentation time, ``pts * time_base`` seconds, in presentation order. Frames are then decoded in
order; a frame's grey image is the decoder's luma plane as it is for the 8-bit YUV formats
(H.264, HEVC, VP9, MPEG-4 and MJPEG in their usual 4:2:0/4:2:2/4:4:4), and FFmpeg's conversion
to 8-bit grey for any other pixel format. Reading from frame ``k`` seeks to the key frame at or
before it and decodes up to it.

Damage is found where it is: a file cut short ends its index early (the frames before are read,
and :class:`~graphpose.io.sources.base.BrokenRecordingError` names the point when the reader gets
there), a packet the decoder refuses or a frame it marks corrupt stops the reading at that frame.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import InputError
from .base import BrokenRecordingError, Frame, Recording

#: File name endings read as videos (case-insensitive); any other FFmpeg container can be named
#: with :func:`graphpose.io.sources.open_frames`' ``kind="video"``.
VIDEO_SUFFIXES = (".mp4", ".m4v", ".mov", ".avi", ".mkv", ".webm", ".mpg", ".mpeg", ".ts", ".mts", ".m2ts",
                  ".wmv", ".flv", ".ogv", ".3gp", ".h264", ".264", ".hevc", ".y4m", ".mjpeg", ".gif")

#: Pixel formats whose first plane is 8-bit luma: read as they are.
_LUMA_FORMATS = {"yuv420p", "yuvj420p", "yuv422p", "yuvj422p", "yuv444p", "yuvj444p", "yuv411p", "yuv440p",
                 "yuvj440p", "nv12", "nv21", "gray", "gray8"}


class VideoRecording(Recording):
    """The first video stream of a video file (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The video.

    Raises
    ------
    InputError
        If the file is missing, FFmpeg cannot open it (the message says why: no moov atom is a
        cut-short MP4 whose index was to be written last), it has no video stream, or no frame.
    """

    kind = "video"

    def __init__(self, path):
        path = Path(path)
        if not path.is_file():
            raise InputError(f"video file not found: {path}")
        pts, keys, time_base, self.damage, self.by_count = _index(path)
        if not pts:
            raise InputError(f"{path}: no video frame could be read" + (f" ({self.damage})" if self.damage else ""))
        self.pts = np.array(sorted(pts), dtype=np.int64)
        self.key_pts = np.array(sorted(keys), dtype=np.int64)
        self._where = {int(p): k for k, p in enumerate(self.pts)}
        self.time_base = time_base
        super().__init__(str(path), self.pts * float(time_base))
        if self.damage:
            self.damage = f"{path} broke after frame {len(self) - 1} (t = {self.timestamps[-1]:.3f} s): {self.damage}"

    def _open_at(self, k: int):
        return _decode(self, k)


def _open(path):
    import av

    try:
        container = av.open(str(path))
    except av.FFmpegError as exc:
        raise InputError(f"{path}: not a video FFmpeg can read ({_why(exc)}{_no_moov(path)})") from None
    if not container.streams.video:
        container.close()
        raise InputError(f"{path}: the file holds no video stream")
    return container, container.streams.video[0]


def _index(path):
    """``(pts of every frame, pts of the key frames, time_base, damage, by_count)``: the packets'
    presentation times (decoding times for an AVI: ``by_count``), read without decoding; ``damage`` says why the packets stopped early
    ("" when they did not): a demuxer error, or the last packet well before the duration the
    container's header declares (a file cut short). The last packet before damage may be
    incomplete: it is left out."""
    import av

    container, stream = _open(path)
    pts, keys, damage = [], [], ""
    # An AVI stores frames in decoding order with one time each, their count: FFmpeg's guess of
    # a presentation time from it is off with B-frames; the count itself is the frame's time.
    by_count = container.format.name == "avi"
    try:
        try:
            for packet in container.demux(stream):
                if packet.size == 0 or packet.is_discard:
                    continue  # the flush packet at the end; an edit list's pre-roll
                t = packet.dts if by_count or packet.pts is None else packet.pts
                if t is None:  # a container without times (raw streams): frame counts then
                    t = len(pts)
                pts.append(int(t))
                if packet.is_keyframe:
                    keys.append(int(t))
        except av.FFmpegError as exc:
            damage = f"the file's data stops there ({_why(exc)})"
        # A raw elementary stream has no time base: frames count at the stream's rate then.
        time_base = stream.time_base or 1 / (stream.average_rate or stream.guessed_rate or 30)
        if not damage and len(pts) > 1 and container.duration:
            t = np.sort(np.array(pts)) * float(time_base)
            step = float(np.median(np.diff(t)))
            declared = container.duration / 1e6 - (container.start_time or 0) / 1e6
            if t[-1] - t[0] + 2.5 * step < declared - 0.05:
                damage = (f"its frames stop at {t[-1] - t[0]:.3f} s of the {declared:.3f} s its header declares "
                          f"(the file is cut short or corrupt there)")
        if damage and pts:
            last = max(pts)  # possibly incomplete
            pts.remove(last)
            keys = [k for k in keys if k != last]
    finally:
        container.close()
    return pts, keys, time_base, damage, by_count


def _decode(video: VideoRecording, k: int):
    """Frames from ``k`` on, each with its presentation time; BrokenRecordingError at damage."""
    import av

    container, stream = _open(video.name)
    expected, first = k, True
    try:
        if k > 0:
            keys = video.key_pts[video.key_pts <= video.pts[k]]
            key = int(keys[-1]) if keys.size else int(video.pts[0])
            container.seek(key, stream=stream, backward=True, any_frame=False)
            expected = video._where.get(key, 0)
        packets = container.demux(stream)
        while True:
            try:
                packet = next(packets)
                decoded = packet.decode()
            except StopIteration:
                break
            except av.FFmpegError as exc:
                raise _broken(video, expected, f"the decoder refused it ({_why(exc)})") from None
            for frame in decoded:
                if first and not video.by_count:  # where the decoder starts (a key frame at or before)
                    expected = video._where.get(frame.pts, expected)
                first = False
                if expected >= len(video):
                    return
                if frame.is_corrupt:
                    raise _broken(video, expected, "the decoder marked the picture corrupt")
                # Pictures come in presentation order and are counted: the k-th is frame k (an
                # AVI's B-frames carry no presentation times of their own).
                if expected >= k:
                    yield Frame(expected, float(video.timestamps[expected]), _grey(frame))
                expected += 1
        if expected < len(video):
            raise _broken(video, expected, "the decoder gave no more pictures")
    finally:
        container.close()


def _broken(video, k, why) -> BrokenRecordingError:
    t = float(video.timestamps[k]) if k < len(video) else float("nan")
    return BrokenRecordingError(f"{video.name} broke at frame {k} (t = {t:.3f} s): {why}", k, t)


def _grey(frame) -> np.ndarray:
    """The frame's 8-bit grey pixels, (H, W): the luma plane as it is for 8-bit YUV and grey."""
    if frame.format.name in _LUMA_FORMATS:
        plane = frame.planes[0]
        rows = np.frombuffer(plane, np.uint8).reshape(frame.height, plane.line_size)
        return np.ascontiguousarray(rows[:, :frame.width])
    return frame.to_ndarray(format="gray")


def _no_moov(path) -> str:
    """For an MP4/MOV without its index (the 'moov' atom, written last unless faststart), why."""
    if Path(path).suffix.lower() not in (".mp4", ".m4v", ".mov", ".3gp"):
        return ""
    with open(path, "rb") as f:
        while chunk := f.read(1 << 22):
            if b"moov" in chunk:
                return ""
    return ("; the MP4's index (its 'moov' atom) is missing: the recording was cut short before it was "
            "finished, and no frame can be located without it")


def _why(exc) -> str:
    """FFmpeg's words for an error, without PyAV's errno prefix."""
    text = getattr(exc, "strerror", None) or str(exc)
    return " ".join(str(text).split())

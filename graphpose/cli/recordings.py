"""Recordings on the command line: ``--topic``, ``--overlay-video``, the frame source and its camera.

Every subcommand that reads frames (``estimate``, ``track``, ``calibrate``, ``batch``) opens them
with :func:`open_source` (:func:`graphpose.io.sources.open_frames`: folders, files, quoted globs,
list files, videos, ROS bags); :func:`add_topic_option` declares ``--topic``, and
:func:`recording_camera` takes a bag's ``camera_info`` when neither ``--camera`` nor ``--K`` is
given. :class:`RateProgress` is the progress bar with frames a second.
"""

from __future__ import annotations

import time
from pathlib import Path

from .options import Progress


def add_topic_option(parser) -> None:
    """``--topic TOPIC``: a ROS bag's image topic."""
    parser.add_argument("--topic", metavar="TOPIC",
                        help="a ROS bag's image topic (sensor_msgs/Image or CompressedImage); a bag with one image "
                        "topic needs none; a wrong or missing one is answered with the bag's image topics")


def add_overlay_video_option(parser) -> None:
    """``--overlay-video OUT.mp4``: the overlay on every frame, encoded with PyAV."""
    parser.add_argument("--overlay-video", metavar="OUT.mp4", type=Path,
                        help="write a video of every frame with its junctions and the board reprojected from "
                        "its pose (H.264, CRF 23; the frames' own times)")


def open_source(items, args):
    """The :class:`~graphpose.io.sources.base.Recording` of ``items`` (paths as typed) with
    ``--topic``; InputError (exit 2) when it cannot be opened."""
    from ..io.sources import open_frames

    items = list(items)
    return open_frames(items[0] if len(items) == 1 else items, topic=getattr(args, "topic", None))


def recording_camera(args, recording, camera=None, board=None):
    """``(camera, board, source)`` from ``--camera``/``--K``, else a bag's camera_info, else
    ``camera``/``board``; ``source`` names the camera_info (or is None)."""
    from .options import camera_from_args

    if args.camera is None and args.K is None and camera is None and recording.camera is not None:
        return (*camera_from_args(args, recording.camera, board), recording.camera_source)
    return (*camera_from_args(args, camera, board), None)


def camera_note(source) -> str:
    """The report's line about a camera taken from a bag's camera_info ("" for none)."""
    return "" if not source else f"camera: from the bag's camera_info {source} (no --camera or --K given)"


class RateProgress(Progress):
    """:class:`graphpose.cli.options.Progress` with the frames a second so far after the name."""

    def __init__(self, total: int, stream, width: int = 24):
        super().__init__(total, stream, width)
        self._start = time.perf_counter()

    def show(self, done: int, name: str) -> None:
        seconds = time.perf_counter() - self._start
        rate = f"{done / seconds:.1f} frames/s " if seconds > 0 and done > 1 else ""
        super().show(done, f"{rate}{name}")


class OverlayVideo:
    """``--overlay-video``: each result drawn on its frame (read again, in order, from a second
    reader of the same recording) and encoded at once (:class:`graphpose.io.sources.video_out.VideoWriter`)."""

    def __init__(self, path, items, args, camera, board):
        from ..io.sources.video_out import VideoWriter

        self.frames = open_source(items, args)
        t = self.frames.timestamps
        fps = 30.0 if t is None or len(t) < 2 else (len(t) - 1) / max(float(t[-1] - t[0]), 1e-9)
        self.t0 = None if t is None else float(t[0])
        self.writer = VideoWriter(path, fps)
        self.camera, self.board = camera, board

    def add(self, f) -> None:
        """Draw and encode the result ``f`` on its frame."""
        from ..viz.track_overlay import draw_track_frame

        image = self.frames.read(f.index).image
        picture = draw_track_frame(image, f, self.camera, self.board, label=f"#{f.index}")
        H, W = picture.shape[:2]
        picture = picture[: H - H % 2, : W - W % 2]  # yuv420p: even sides
        self.writer.add(picture, None if self.t0 is None else f.timestamp - self.t0)

    def close(self) -> None:
        self.frames.close()
        self.writer.close()

    def abort(self) -> None:
        self.frames.close()
        self.writer.abort()


def add_every_option(parser) -> None:
    """``--every N``: every N-th frame of a recording."""
    from .options import parse_count

    parser.add_argument("--every", type=parse_count(1), default=1, metavar="N",
                        help="with a video or ROS bag: every N-th frame (frames 0, N, 2N, ...; default 1, every frame)")


def open_recording_input(args):
    """The video or bag when ``args.inputs`` is one (``graphpose batch``), else None (and
    ``--topic`` refused)."""
    from ..io.sources import is_recording
    from . import UsageError

    if len(args.inputs) == 1 and is_recording(args.inputs[0]):
        return open_source(args.inputs, args)
    if getattr(args, "topic", None) is not None:
        raise UsageError("--topic goes with one ROS bag")
    return None


def frame_keys(recording) -> list:
    """Every frame of ``recording`` as a batch row's ``image`` (:func:`graphpose.io.sources.frame_key`)."""
    from ..io.sources import frame_key

    return [frame_key(recording, k) for k in range(len(recording))]


def add_view_options(parser) -> None:
    """``graphpose calibrate``'s options for a recording: ``--max-views`` and ``--topic``."""
    from .options import parse_count

    parser.add_argument("--max-views", type=parse_count(3), default=40, metavar="N",
                        help="with a video or ROS bag: the most views chosen from it (sharp, spread over the "
                        "image, varied tilts and distances, no near-duplicates; default 40)")
    add_topic_option(parser)


def recording_views(args, progress):
    """``(images, names, choice)`` for ``graphpose calibrate`` when IMAGES is one video or bag:
    the views :func:`graphpose.calibrate.views.choose_views` picks, read again; else None."""
    from ..calibrate.views import choose_views
    from ..io.sources import is_recording
    from . import UsageError

    if not (len(args.images) == 1 and is_recording(args.images[0])):
        if getattr(args, "topic", None) is not None:
            raise UsageError("--topic goes with one ROS bag")
        return None
    recording = open_source(args.images, args)
    choice = choose_views(recording, args.board, max_views=args.max_views, keep_images=True,
                          progress=lambda done, total: progress("choosing views", done, total))
    images = list(choice.images) if choice.images is not None else [recording.read(int(k)).image
                                                                    for k in choice.frames]
    recording.close()
    return images, [recording.label(int(k)) for k in choice.frames], choice


def views_record(choice) -> dict:
    """The report's ``views``: how the recording was scanned and, per frame, ``frame``,
    ``timestamp``, ``status`` (``used`` or why not), ``detail``, ``blur_px``, ``speed_px``
    (junction motion, pixels a frame), ``junctions``."""
    import numpy as np

    t = choice.timestamps
    def number(x):
        return None if not np.isfinite(x) else round(float(x), 3)

    frames = [{"frame": k, "timestamp": None if t is None else float(t[k]), "status": s, "detail": d,
               "blur_px": number(b), "speed_px": number(v), "junctions": int(j)}
              for k, (s, d, b, v, j) in enumerate(zip(choice.status, choice.detail, choice.blur_px, choice.speed_px,
                                                      choice.junctions))]
    return {"scan_every": choice.scan_every, "sharp_blur_px": choice.sharp_blur_px, "counts": choice.counts(),
            "frames": frames}


def views_text(choice) -> str:
    """The summary's lines on the views: the frames used, and how many were not, by reason."""
    used = ", ".join(f"#{k}" for k in choice.frames)
    others = "; ".join(f"{n} {s}" for s, n in choice.counts().items() if s != "used")
    scanned = "every frame" if choice.scan_every == 1 else f"every {choice.scan_every}th frame"
    return (f"views: {len(choice.frames)} of {len(choice.status)} frames chosen ({scanned} searched; sharp frames' "
            f"blur {choice.sharp_blur_px:.2f} px): {used}\n  not used: {others or 'none'} "
            f"(each frame's reason: --json REPORT.json, 'views')")

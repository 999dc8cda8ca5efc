"""Tracking the camera over a sequence of frames: :func:`track_frames` (a stream of frame
results, memory flat however long the sequence) and :func:`track_sequence` (all of them in
one :class:`~graphpose.track.results.Track`).

Ties the pieces together, one frame at a time: the frame is read
(:class:`graphpose.track.frames.FrameSource`), the front end finds its junctions and its own
pose (:class:`graphpose.track.frontend.FrontEnd`), the back end adds them to its factor graph
and updates it (a :class:`graphpose.track.backend.Backend`:
:class:`graphpose.track.fixed_lag.FixedLagGraph`, a fixed-lag smoother over the last
``config.lag_s`` seconds, by default; :class:`graphpose.track.sequence_graph.SequenceGraph`,
iSAM2 over the whole sequence, with ``lag_s=None``), and the back end's pose goes back to the
front end to predict the next frame. A frame without a usable board, or a frame file that
cannot be read, is lost: it gets no pose, and no motion factor spans it. At the end the whole
sequence can be smoothed in batch. Each frame's result is given as soon as it is final and
kept by nobody but the caller (:func:`track_frames`); smoothing keeps only the measurements.

Inputs are checked once, here, as :func:`graphpose.estimate.estimate_pose` checks them
(:func:`graphpose._checks.check_bounds` for the bounds and every per-frame polygon, and
:func:`graphpose.camera_models.check_image_size` for every frame against the camera's calibration).
One camera (:mod:`graphpose.camera_models`) serves the whole chain: the front end's predictions,
refinement and detection work on the raw frames through it, and the back end's factors
project through the same model.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import replace

import numpy as np

from .._checks import check_bounds
from ..board import check_board
from ..board import Board
from ..camera_models import as_camera, check_image_size
from ..errors import InputError
from ..io.sources.base import BrokenRecordingError
from .backend import make_backend
from .config import MOTION_SPAN_FRAMES, TrackerConfig, default_lag_s, shortest_lag_s
from .frames import FrameSource, frame_timestamps
from .frontend import FrontEnd
from .results import DETECTED, LOST, FrameResult, Track
from .uncertainty import frame_covariance


def track_frames(frames, camera, *, board: Board = Board(), bounds=None, timestamps=None, fps: float = 30.0,
                 polygons=None, config: TrackerConfig = TrackerConfig(), smooth: bool = False,
                 progress=None, topic: str | None = None) -> Iterator[FrameResult]:
    """Track the camera pose over a sequence of frames, one :class:`FrameResult` at a time.

    The stream of :func:`track_sequence`: the same frames, the same results, in input order,
    but each given as soon as it is final, so that memory stays flat however long the
    sequence. Without ``smooth``, a frame's result (the online, filtered estimate) is final
    once the back end has added the frame, and the tracker keeps no frame's result after
    giving it. With ``smooth``, the online pass keeps only what the batch step needs (each
    frame's measurements and its result without the online pose, about 3 kB a frame), and
    the smoothed results come after the last frame.

    Parameters
    ----------
    frames, camera, bounds, board, timestamps, fps, polygons, config, progress, topic
        As :func:`track_sequence`. ``progress(k, n_frames)`` is called after frame ``k`` is
        tracked (before its result is given, without ``smooth``).
    smooth : bool
        Give the batch-smoothed results of the whole sequence (``Track.smoothed``) instead of
        the online ones, all after the last frame is tracked.

    Returns
    -------
    iterator of FrameResult
        One per input frame, in order; lost frames carry no pose.

    Raises
    ------
    InputError
        When called, for malformed inputs (as :func:`track_sequence`); while iterating, for
        a frame given in memory that is not an image, a frame's size that differs from the
        camera's, or a polygon that fails its check against the first frame read.
    BrokenRecordingError
        While iterating, after the results of every frame before the damage of a truncated or
        corrupt video or bag (the message names the frame and time where it broke).

    Examples
    --------
    >>> for f in track_frames("seq/", K, bounds):            # doctest: +SKIP
    ...     print(f.index, f.status, f.T_WC)
    """
    run = _Run(frames, camera, bounds, board, timestamps, fps, polygons, config, smooth, progress, topic)
    return _then_damage(run, _smoothed_stream(run) if smooth else run.online())


def track_sequence(frames, camera, *, board: Board = Board(), bounds=None, timestamps=None, fps: float = 30.0,
                   polygons=None, config: TrackerConfig = TrackerConfig(), smooth: bool = False,
                   progress=None, topic: str | None = None) -> Track:
    """Track the camera pose over a sequence of frames of the target (every result kept:
    :func:`track_frames` streams them).

    Parameters
    ----------
    frames : str, Path, Recording, or sequence of images or paths
        A folder (its image files in name order, see
        :func:`graphpose.track.frames.list_frames`), a list of image files, a glob pattern, a
        list file, a video or a ROS bag (:func:`graphpose.io.sources.open_frames`), or images
        (H, W) / (H, W, 3|4) arrays, or an (N, H, W) array. Frames are read one at a time.
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`; the frames are raw, with its lens
        distortion), or pinhole intrinsics ``K``, pixels, for frames without distortion. A
        camera that carries its intrinsics' covariance (a calibration's) gives covariances
        that include it (:mod:`graphpose.track.uncertainty`).
    bounds : (2, 4) array_like, optional
        Bounding polygon of the board in the first frame (clockwise from the corner nearest
        junction 0, as in :func:`graphpose.detect.junctions.extract_junctions`). Without it
        (and without ``polygons[0]``) the first frame is searched in the whole image; frames
        stay lost until the board is found. A board whose pattern is unchanged by a half
        turn is then labelled by the image's upper-left rule in the first frame, and kept
        continuous from frame to frame after that.
    board : Board
        The target.
    timestamps : (N,) array_like, optional
        Seconds per frame, strictly increasing; default: a video's presentation times or a
        bag's header stamps, else ``index / fps``.
    fps : float
        Frame rate used when ``timestamps`` is None.
    polygons : sequence of ((2, 4) array_like or None), optional
        Per-frame bounding polygons used whenever a frame needs full extraction (first frame,
        fallback, re-detection after a loss), tried before the reprojected outline of the
        last pose.
    config : TrackerConfig
        Tracker settings.
    smooth : bool
        Also smooth the whole sequence in batch at the end (``Track.smoothed``): one graph
        over every frame, rebuilt from their measurements with the fixed lag, then
        Levenberg-Marquardt and the marginal covariances.
    progress : callable, optional
        Called as ``progress(k, n_frames)`` after every frame.
    topic : str, optional
        A ROS bag's image topic (a bag with one image topic needs none).

    Returns
    -------
    Track
        One :class:`FrameResult` per frame; lost frames carry no pose. A frame FILE that
        cannot be read (missing, corrupt) is lost, with a message naming it.

    Raises
    ------
    InputError
        If the camera, board, timestamps, polygons or config are malformed, there are no
        frames, a frame given in memory is not a finite grey or colour image (checked when
        the frame is reached), a frame's size differs from the camera's calibration, or
        ``bounds`` or a polygon is not a clockwise convex quadrilateral on the image
        (:func:`graphpose._checks.check_bounds`, checked against the first frame read,
        before any is tracked). A frame without a usable board is NOT an error: it is lost.
    BrokenRecordingError
        If a video or bag breaks (truncated, corrupt): its ``track`` attribute holds the
        :class:`Track` of the frames before the damage.
    """
    run = _Run(frames, camera, bounds, board, timestamps, fps, polygons, config, smooth, progress, topic)
    online = tuple(run.online())
    track = Track(online, tuple(run.smoothed(online)) if smooth else None, config)
    if run.broken is not None:
        run.broken.track = track
        raise run.broken
    return track


class _Run:
    """One tracking run: the inputs checked (at once), the front end and the back end, and
    the generators of its results (:meth:`online`, then :meth:`smoothed`)."""

    def __init__(self, frames, camera, bounds, board, timestamps, fps, polygons, config, smooth, progress, topic):
        self.camera = as_camera(camera)
        self.board = check_board(board)
        if not isinstance(config, TrackerConfig):
            raise InputError(f"config must be a TrackerConfig, got {type(config).__name__}")
        self.source = FrameSource(frames, topic)
        n = len(self.source)
        if n == 0:
            raise InputError("frames is empty")
        self.broken = None  # the BrokenRecordingError that ended the frames early, if any
        self.t = frame_timestamps(self.source.timestamps if timestamps is None else timestamps, fps, n)
        shortest = shortest_lag_s(config.motion.model, self.t)
        if config.lag_s is not None and config.lag_s < shortest * (1 + 1e-9):
            raise InputError(
                f"lag_s = {config.lag_s:g} s is shorter than the {MOTION_SPAN_FRAMES[config.motion.model]} frames "
                f"({shortest:g} s at this sequence's median frame interval) that one {config.motion.model} motion "
                f"factor ties together: the motion prior would never act. Give lag_s of at least "
                f"{default_lag_s(config.motion.model, self.t):g} s, or None for the whole-sequence back end")
        self.polys, self.names = _polygon_list(polygons, bounds, n)
        self.config, self.progress = config, progress
        self.front = FrontEnd(self.camera, self.board, config)
        self.graph = make_backend(self.camera, self.board, config.motion, target=config.target, lag_s=config.lag_s,
                                  keep_measurements=smooth)
        self.W = self.board.world_points()

    def online(self) -> Iterator[FrameResult]:
        """Every frame's online result, each given as soon as it is made (none is kept)."""
        source, t, n, checked = self.source, self.t, len(self.t), False
        for k in range(n):
            wall, cpu = time.perf_counter(), time.process_time()
            try:
                image, unreadable = _read(source, k)
            except BrokenRecordingError as exc:
                self.broken = exc  # the frames before it are given; the error comes after them
                return
            if image is None:
                self.front.lose()
                self.graph.break_segment()
                read = (time.perf_counter() - wall, time.process_time() - cpu)
                result = FrameResult(k, t[k], LOST, message=unreadable, read_s=read[0], cpu_s=(read[1], 0.0, 0.0))
            else:
                label = source.label(k)
                check_image_size(self.camera, image.shape, label if label.startswith("frame") else f"frame {k} ({label})")
                if not checked:
                    self.polys, checked = _check_polygons(self.polys, self.names, image.shape[:2]), True
                read = (time.perf_counter() - wall, time.process_time() - cpu)
                result = _step(self.front, self.graph, self.W, self.config, k, t[k], image, self.polys[k], read)
            del image  # not held while the consumer works on the result
            if self.progress is not None:
                self.progress(k, n)
            yield result
        if source.recording is not None:
            self.broken = source.recording.end_error()  # a file cut short after its last frame

    def smoothed(self, frames) -> Iterator[FrameResult]:
        """The frames again with the batch-smoothed poses and covariances of the whole graph
        (after :meth:`online` has run to the end)."""
        batch = self.graph.smooth()
        for f in frames:
            if f.index not in batch:
                yield f
                continue
            b = batch.pop(f.index)
            Wk = self.W[:, f.ids]
            cov, kind = frame_covariance(self.camera, b.T_WC, Wk, b.cov)
            rms = _rms(self.front.project(b.T_WC, Wk) - f.points)
            yield FrameResult(f.index, f.timestamp, f.status, b.T_WC, cov, f.junctions, rms, f.single_T_WC,
                              f.points, f.ids, f.frontend_s, f.update_s, f.message, b.cov, kind, f.read_s, f.cpu_s)


def _then_damage(run, stream) -> Iterator[FrameResult]:
    """``stream``, then the recording's BrokenRecordingError if it broke."""
    yield from stream
    if run.broken is not None:
        raise run.broken


def _smoothed_stream(run) -> Iterator[FrameResult]:
    """The online pass keeping each frame's result without its online pose and covariances
    (the measurements are the back end's), then the smoothed results."""
    kept = [replace(f, T_WC=None, cov=None, cov_pixel=None) if f.T_WC is not None else f for f in run.online()]
    yield from run.smoothed(kept)


def _read(source, k):
    """(image, "") of frame ``k``, or (None, why) for a frame file that cannot be read; a frame
    given in memory that is not an image stays an InputError (the caller's mistake)."""
    try:
        return source.load(k), ""
    except BrokenRecordingError:
        raise
    except InputError as exc:
        if source.path(k) is None:
            raise
        return None, f"unreadable frame file: {exc}"


def _step(front, graph, W, config, k, t, image, polygon, read) -> FrameResult:
    """One frame through the front end and the back end (``read``: the reading's wall and
    CPU seconds)."""
    wall, cpu = time.perf_counter(), time.process_time()
    found = front.measure(k, t, image, polygon)
    frontend_s, frontend_cpu = time.perf_counter() - wall, time.process_time() - cpu
    if found.status == LOST:
        front.lose()
        graph.break_segment()
        return FrameResult(k, t, LOST, frontend_s=frontend_s, message=found.message, read_s=read[0],
                           cpu_s=(read[1], frontend_cpu, 0.0))
    if found.status == DETECTED:
        # The motion model failed to predict this frame (or there was none): no motion
        # factor may tie it to the frames before.
        graph.break_segment()
    fit = found.fit
    sigma = max(fit.sigma_px, config.min_pixel_sigma_px)
    cpu = time.process_time()
    back = graph.add_frame(k, t, found.points, found.ids, fit.T_WC, sigma)
    back_cpu = time.process_time() - cpu
    seen = front.accept(k, t, back.T_WC, image.shape[:2])
    rms = _rms(seen[:, found.ids] - found.points)
    cov, kind = frame_covariance(front.camera, back.T_WC, W[:, found.ids], back.cov)
    return FrameResult(k, t, found.status, back.T_WC, cov, len(found.ids), rms, fit.T_WC, found.points,
                       found.ids, frontend_s, back.update_s, found.message, back.cov, kind, read[0],
                       (read[1], frontend_cpu, back_cpu))


def _polygon_list(polygons, bounds, n):
    """One polygon or None per frame (unchecked; ``bounds`` is frame 0's), and their names."""
    polys, names = [None] * n, [f"polygons[{k}]" for k in range(n)]
    if polygons is not None:
        try:
            polys = list(polygons)
        except TypeError:
            raise InputError(f"polygons must be a sequence of (2, 4) polygons or None, "
                             f"got {type(polygons).__name__}") from None
        if len(polys) != n:
            raise InputError(f"polygons has {len(polys)} entries for {n} frames")
    if bounds is not None:
        polys[0], names[0] = bounds, "bounds"
    return polys, names


def _check_polygons(polys, names, shape) -> list:
    """Every polygon through :func:`graphpose._checks.check_bounds`, against the image
    ``shape`` of the first frame read."""
    return [None if P is None else check_bounds(P, shape, name) for P, name in zip(polys, names)]


def _rms(d) -> float:
    return float(np.sqrt(np.mean(d * d))) if d.size else float("nan")

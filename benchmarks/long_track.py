"""The speed section's long run: graphpose's tracker over 10,000 frames, memory and time a frame.

The goals: tracking over 10,000 rendered frames keep its process memory flat (growth
below 2 MB per 1,000 frames), its back end's time per frame flat (the last 100 frames at most
1.2x frames 100-199) and the whole tracker under 3 ms a frame. Rendering 10,000 frames would
take the benchmark longer than the tracking, so a few hundred distinct frames of one hand-held
trajectory (:func:`graphpose.render_sequence`, no whip pans, noise 2, blur 1) are written as PNG
files and played forward, backward, forward... (a ping-pong: the motion is continuous, it only
turns at the ends), as file paths, so that every frame is read from its file as ``graphpose
track`` reads a folder. The tracker runs through its stream, :func:`graphpose.track_frames`,
with its defaults (the fixed-lag back end, no batch smoothing): each frame's result is taken
as it comes and only what the lockstep replay needs is kept, in buffers filled before the run
(:class:`Kept`), so that keeping it does not grow the memory measured.

Figures, as the tracking section measures its 3,000-frame run (:mod:`benchmarks.tracking`):
memory growth is the slope of the process's resident memory (sampled after every frame, fitted
from frame 300 on: whatever the tracker keeps of every frame shows in it); the back end's growth
is the lockstep replay of the frames' junctions (:func:`benchmarks.tracking.lockstep_growth`,
process CPU time, free of the machine's drift); the whole tracker's time a frame is the interval
between two results of the stream (reading, front end, back end), median process CPU time,
with the wall time beside it. Beside it, from the same run, the median process CPU time of each
part as the stream reports it (``FrameResult.cpu_s``): reading the frame (its PNG decoded by
:func:`graphpose.image.read_image`, 8-bit grey, and its size checked), the front end
(:meth:`graphpose.track.frontend.FrontEnd.measure`: prediction, refinement, the frame's own fit
and checks) and the back end (the fixed-lag smoother's ``add_frame``: the frame's factors, the
update, the marginal covariance); what is left of the interval (the back end's pose taken for
the next prediction, the reprojection RMS, the result, this benchmark's own bookkeeping) is
given too. After the run, the same files are read again by ``read_image`` and by OpenCV's
``imread`` (grey) in turn, the reading's peer.

This module is a block of the speed section rather than a section of its own: the tracking
goals' figures then come from one section, ``python -m benchmarks speed``, in one run.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from benchmarks._common import K_REAL, median, rss_mb
from benchmarks.tracking import lockstep_growth

#: Distinct rendered frames and frames tracked: (quick, full).
DISTINCT = (60, 300)
FRAMES = (1000, 10000)
#: Resident memory is fitted from this frame on (the first frames fill caches and pools).
FIT_FROM = 300


def ping_pong(distinct: int, total: int) -> np.ndarray:
    """Frame order 0, 1, ..., distinct - 1, distinct - 2, ..., 1, 0, 1, ... of length ``total``."""
    period = 2 * distinct - 2
    k = np.arange(total) % period
    return np.where(k < distinct, k, period - k)


def cycled_frames(folder, distinct: int, total: int, seed: int = 19):
    """``distinct`` rendered frames written to ``folder``: (paths in ping-pong order (total,),
    first-frame bounds, timestamps (total,), render seconds)."""
    from graphpose import render_sequence
    from graphpose.io.files import encode_png

    start = time.perf_counter()
    seq = render_sequence(K_REAL, distinct, rng=seed, excursions=0, noise_sigma=2.0, blur_sigma=1.0,
                          distance=(0.6, 1.3), supersample=1)
    files = []
    for k, image in enumerate(seq.images):
        path = Path(folder) / f"frame_{k:04d}.png"
        path.write_bytes(encode_png(image))
        files.append(str(path))
    order = ping_pong(distinct, total)
    return [files[k] for k in order], seq.bounds, np.arange(total) / seq.fps, time.perf_counter() - start


class Kept:
    """What the lockstep replay needs of each of ``n`` frames, in buffers written in full when
    made (so that their pages are resident before the run and filling them grows nothing)."""

    def __init__(self, n: int, n_junctions: int):
        self.points = np.full((n, 2, n_junctions), np.nan)
        self.seen = np.full((n, n_junctions), False)
        self.single_T_WC = np.full((n, 4, 4), np.nan)
        self.timestamp = np.full(n, np.nan)
        self.status = np.full(n, "lost", dtype="<U8")
        self.update_s = np.full(n, np.nan)
        self.cpu_s = np.full((n, 3), np.nan)

    def keep(self, f) -> None:
        """Frame result ``f``'s junctions, single-frame pose, timestamp, status, update time and
        the CPU time of its parts (reading, front end, back end)."""
        k = f.index
        self.timestamp[k], self.status[k], self.update_s[k] = f.timestamp, f.status, f.update_s
        self.cpu_s[k] = f.cpu_s
        if f.points is not None:
            self.points[k][:, f.ids] = f.points
            self.seen[k, f.ids] = True
        if f.single_T_WC is not None:
            self.single_T_WC[k] = f.single_T_WC

    def frames(self) -> list:
        """The kept frames as the replay reads them (index, timestamp, status, points, ids, single_T_WC)."""
        out = []
        for k in range(len(self.timestamp)):
            ids = np.flatnonzero(self.seen[k])
            out.append(SimpleNamespace(index=k, timestamp=float(self.timestamp[k]), status=str(self.status[k]),
                                       points=self.points[k][:, ids], ids=ids, single_T_WC=self.single_T_WC[k]))
        return out


def streamed(frames, K, bounds, timestamps, board):
    """:func:`graphpose.track_frames` over ``frames`` with the wall time, process CPU time and
    resident memory after every frame's result: (Kept, wall seconds (n,), CPU seconds (n,), RSS MB (n,))."""
    from graphpose import track_frames

    n = len(frames)
    kept = Kept(n, board.n)
    stamps, cpu, rss = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    start, cpu_start = time.perf_counter(), time.process_time()
    for f in track_frames(frames, K, bounds=bounds, board=board, timestamps=timestamps):
        kept.keep(f)
        stamps[f.index], cpu[f.index] = time.perf_counter(), time.process_time()
        rss[f.index] = rss_mb()
    return kept, np.diff(np.r_[start, stamps]), np.diff(np.r_[cpu_start, cpu]), rss


def read_times(cv2, files, repeats: int = 5):
    """Median process CPU time (ms) of reading each of ``files`` with graphpose's
    ``read_image(path, as_float=False)`` and with OpenCV's ``imread`` (grey), in turn:
    (graphpose ms, OpenCV ms); OpenCV's is NaN without ``cv2``."""
    from graphpose.image import read_image

    tools = {"graphpose": lambda path: read_image(path, as_float=False)}
    if cv2 is not None:
        tools["opencv"] = lambda path: cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    times = {name: [] for name in tools}
    for path in files:
        for _ in range(repeats):
            for name, read in tools.items():
                start = time.process_time()
                read(path)
                times[name].append(time.process_time() - start)
    return tuple(1000 * median(times[name]) if name in times else float("nan") for name in ("graphpose", "opencv"))


def measure(quick: bool = False, cv2=None):
    """Track the long run; returns (headline figures, one block) for the speed section (``cv2``:
    OpenCV, the reading's peer, or None)."""
    from graphpose import Board
    from graphpose.track.config import DEFAULT_LAG_S
    from graphpose.track.results import LOST

    distinct, total = DISTINCT[0 if quick else 1], FRAMES[0 if quick else 1]
    board = Board()
    with tempfile.TemporaryDirectory() as folder:
        frames, bounds, timestamps, render_s = cycled_frames(folder, distinct, total)
        kept, frame_s, frame_cpu_s, rss = streamed(frames, K_REAL, bounds, timestamps, board)
        read_ms, imread_ms = read_times(cv2, frames[:distinct])
    idx = np.arange(total)
    found = kept.status != LOST
    fit = idx >= min(FIT_FROM, total // 2)
    slope = float(np.polyfit(idx[fit], rss[fit], 1)[0]) * 1000 if np.all(np.isfinite(rss[fit])) else float("nan")
    back_ms = kept.update_s * 1000
    early = median(back_ms[found & (idx >= 100) & (idx < 200)])
    late = median(back_ms[found & (idx >= total - 100)])
    growth, long_ms, young_ms = lockstep_growth(K_REAL, board, kept.frames(), DEFAULT_LAG_S,
                                                keep_measurements=False)
    frame_ms, frame_cpu_ms = 1000 * median(frame_s), 1000 * median(frame_cpu_s)
    part_ms = 1000 * np.median(kept.cpu_s, axis=0)
    rest_ms = 1000 * median(frame_cpu_s - kept.cpu_s.sum(axis=1))
    n_found = int(found.sum())
    block = {"title": f"graphpose track over {total:,} frames: memory and time a frame",
             "text": "{distinct} distinct rendered 640 x 480 frames of one hand-held trajectory (no whip pans; "
                     "rendered and written as PNG in {render_s:.0f} s) played forward and backward in turn to "
                     "{total} frames, each read from its file; the tracker's stream (track_frames) with its "
                     "defaults (fixed lag {lag_s:.1f} s, no batch smoothing). Frames with a pose: {found}. Resident "
                     "memory from frame {fit_from} on: {slope:.2f} MB per 1,000 frames (whatever the tracker keeps "
                     "of every frame shows in it). Back end, lockstep replay of the junctions (process CPU time), last 100 frames "
                     "{long_ms:.3f} ms against a back end 100-199 frames old {young_ms:.3f} ms (ratio "
                     "{growth:.2f}); as tracked (wall time) frames 100-199 {early:.3f} ms, last 100 {late:.3f} ms. "
                     "Whole tracker a frame (reading, front end, back end), median: {frame_cpu_ms:.2f} ms process "
                     "CPU time, {frame_ms:.2f} ms wall. Its parts, median process CPU time a frame in the same run "
                     "(FrameResult.cpu_s): reading the PNG (read_image, 8-bit grey, and the size check) "
                     "{read_cpu_ms:.2f} ms; front end (prediction, refinement at the predicted junctions, the "
                     "frame's own fit, its checks) {front_cpu_ms:.2f} ms; back end (the frame's factors, the "
                     "fixed-lag update, the marginal covariance) {back_cpu_ms:.2f} ms; the rest of the interval "
                     "(the pose taken for the next prediction, the reprojection RMS, the result, the benchmark's "
                     "bookkeeping) {rest_ms:.2f} ms. The same {distinct} files read again after the run, in turn: "
                     "read_image {read_ms:.2f} ms, OpenCV imread (grey) {imread_ms:.2f} ms.",
             "values": {"distinct": distinct, "render_s": render_s, "total": total, "lag_s": DEFAULT_LAG_S,
                        "found": n_found, "fit_from": min(FIT_FROM, total // 2), "slope": slope, "long_ms": long_ms,
                        "young_ms": young_ms, "growth": growth, "early": early, "late": late,
                        "frame_cpu_ms": frame_cpu_ms, "frame_ms": frame_ms, "read_cpu_ms": part_ms[0],
                        "front_cpu_ms": part_ms[1], "back_cpu_ms": part_ms[2], "rest_ms": rest_ms,
                        "read_ms": read_ms, "imread_ms": imread_ms},
             "columns": None, "formats": None, "rows": None}
    figures = [
        {"figure": f"graphpose track, memory growth per 1,000 frames ({total:,} frames)", "unit": "MB",
         "fmt": ".2f", "graphpose": slope, "peer_name": None, "peer": None, "ratio": None, "goal": "< 2 MB",
         "met": bool(slope < 2.0)},
        {"figure": f"graphpose track, back end per frame, last 100 of {total:,} / frames 100-199 (lockstep replay, "
                   "CPU time)", "unit": "", "fmt": ".2f", "graphpose": growth, "peer_name": None, "peer": None,
         "ratio": None, "goal": "<= 1.2x", "met": bool(growth <= 1.2)},
        {"figure": f"graphpose track, whole tracker per frame (read + front + back end), median process CPU time, "
                   f"{total:,} frames", "unit": "ms", "fmt": ".2f", "graphpose": frame_cpu_ms, "peer_name": None,
         "peer": None, "ratio": None, "goal": "< 3 ms", "met": bool(frame_cpu_ms < 3.0)},
        {"figure": f"graphpose track, of which reading the frame (PNG, read_image), median process CPU time, "
                   f"{total:,} frames", "unit": "ms", "fmt": ".2f", "graphpose": part_ms[0], "peer_name": None,
         "peer": None, "ratio": None, "goal": "", "met": None},
        {"figure": f"graphpose track, of which the front end, median process CPU time, {total:,} frames",
         "unit": "ms", "fmt": ".2f", "graphpose": part_ms[1], "peer_name": None, "peer": None, "ratio": None,
         "goal": "", "met": None},
        {"figure": f"graphpose track, of which the back end, median process CPU time, {total:,} frames",
         "unit": "ms", "fmt": ".2f", "graphpose": part_ms[2], "peer_name": None, "peer": None, "ratio": None,
         "goal": "", "met": None},
    ]
    if cv2 is not None:
        figures.append({"figure": f"reading the long run's {distinct} PNG frames again, read_image against OpenCV "
                                  "imread (grey) in turn, median process CPU time", "unit": "ms", "fmt": ".2f",
                        "graphpose": read_ms, "peer_name": "OpenCV imread", "peer": imread_ms,
                        "ratio": read_ms / imread_ms, "goal": "", "met": None})
    return figures, block

"""Recordings benchmark: videos and ROS bags as frame sources, tracked and calibrated from.

Run through ``python -m benchmarks recordings [--quick]``; :func:`main` returns the section's
figures (the dict described in :mod:`benchmarks`). Everything is rendered and written here (the
videos with PyAV, the bags with rosbags' own writers), never downloaded.

1. **Video**: the tracking section's hand-held sequence (noise 2, blur 1, whip pans) encoded as
   H.264 (yuv420p, CRF 23) in an ``.mp4`` and tracked from it by ``graphpose track`` (its TUM file
   read back); the same decoded frames written as PNG files and tracked from the folder with the
   video's presentation times (``--timestamps``); OpenCV's per-frame detection
   (findChessboardCorners + cornerSubPix) + PnP (IPPE + LM) on the same decoded frames; and, for
   the codec's own share, the lossless renders tracked from memory. ATE: RMS position error
   against the truth, without alignment, over the frames every method has a pose in. The TUM
   timestamps against the presentation times PyAV's own decoder gives.
2. **Bags**: the first frames of the same renders in a ROS 1 bag, a ROS 2 sqlite3 bag and a ROS 2
   mcap bag, each as mono8 ``Image`` and as PNG ``CompressedImage``, with a ``camera_info``;
   tracked by ``graphpose track BAG`` without ``--K`` against the folder of the same frames with
   ``--K`` and the bag's stamps: the largest difference of any pose entry.
3. **Flat cost**: a 640 x 480 H.264 recording of 10,000 frames (300 distinct renders played
   forward and backward, as the speed section's long run) tracked from the file by
   :func:`graphpose.track_frames`: resident memory after every frame (slope from frame 300 on)
   and the whole tracker's process CPU time a frame (decoding included), median, with the
   decoding's share (``FrameResult.cpu_s``).
4. **Calibration from a video**: a rendered 60 s clip (30 fps) of the board waved before the
   radtan camera of :func:`graphpose.synth.calibration.radtan_camera`, fast moves between key
   poses (motion blur), some key poses with the board partly out of view
   (:func:`graphpose.synth.clip.calibration_clip`), as H.264 CRF 23. ``graphpose calibrate
   clip.mp4`` (views chosen by itself, at most 40) against graphpose calibrating 40 sharp,
   whole-board frames picked from the truth (evenly over the clip's sharp whole-board frames,
   decoded from the same video) and against OpenCV's findChessboardCornersSB + calibrateCamera
   on every 15th frame (its time, process CPU). Projection error against the true camera: RMS
   ``|camera.project(truth.unproject(u)) - u|`` over a grid of the whole image.
5. **Pans**: the tracking section's noisy 150-frame sequence (noise 9, blur 2.5): frames lost
   while at least half the board's junctions are in view.
"""

from __future__ import annotations

import contextlib
import io
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks._common import K_REAL, median, rms, rss_mb
from benchmarks.long_track import FIT_FROM, ping_pong

K_OPTION = "564.9,564.3,337.3,226.5"
#: Sequence lengths: (quick, full).
VIDEO_FRAMES = (120, 300)
BAG_FRAMES = (30, 100)
LONG_FRAMES = (1000, 10000)
LONG_DISTINCT = (60, 300)
CLIP_SECONDS = (20.0, 60.0)
#: The calibration clip's seed: one the view choice was not tuned on (it was built on seed 3
#: and checked on seeds 5 and 23; none of them is measured here).
CLIP_SEED = 7


def _cli(*args) -> int:
    """``graphpose ARGS`` in process, its stdout swallowed."""
    from graphpose.cli import main

    with contextlib.redirect_stdout(io.StringIO()):
        return main([str(a) for a in args])


def _bounds_option(bounds) -> str:
    return ",".join(f"{u},{v}" for u, v in zip(*bounds))


def _write_video(path, frames, fps=30.0, preset="medium"):
    from graphpose.io.sources.video_out import VideoWriter

    with VideoWriter(path, fps, crf=23, pix_fmt="yuv420p", options={"preset": preset}) as video:
        for image in frames:
            video.add(image)


def _pts_seconds(path) -> np.ndarray:
    """Every frame's presentation time as PyAV's own decoder gives it, in decoding output order."""
    import av

    with av.open(str(path)) as container:
        return np.array([float(frame.pts * frame.time_base) for frame in container.decode(video=0)])


def _tum_poses(path, timestamps):
    """The TUM file's poses at ``timestamps`` (NaN where it has no line) and its timestamps."""
    from graphpose.io.tum import read_tum

    tum = read_tum(path)
    poses = np.full((len(timestamps), 4, 4), np.nan)
    for t, T in zip(tum.timestamps, tum.poses):
        k = int(np.argmin(np.abs(timestamps - t)))
        poses[k] = T
    return poses, tum.timestamps


def _positions_mm(P, truth):
    from graphpose.track.trajectory import trajectory_errors

    return trajectory_errors(P, truth)[:, 0] * 1000


def video(cv2, tmp, quick):
    """Part 1: (figures, block)."""
    from graphpose import Board, project, render_sequence, track_sequence
    from graphpose.io.files import write_png
    from graphpose.io.sources import open_frames
    from benchmarks.tracking import _opencv_pose

    n = VIDEO_FRAMES[quick is False]
    board = Board()
    W = board.world_points()
    seq = render_sequence(K_REAL, n, rng=0, excursions=1 if quick else 2, noise_sigma=2.0, blur_sigma=1.0,
                          distance=(0.6, 1.3))
    mp4 = tmp / "handheld.mp4"
    _write_video(mp4, seq.images, seq.fps)
    bounds = _bounds_option(seq.bounds)
    start = time.perf_counter()
    assert _cli("track", mp4, "--K", K_OPTION, "--bounds", bounds, "--tum", tmp / "video.tum", "-q") == 0
    video_s = time.perf_counter() - start
    clip = open_frames(mp4)
    folder = tmp / "decoded"
    folder.mkdir()
    decoded = []
    for f in clip.frames():
        write_png(folder / f"frame_{f.index:04d}.png", f.image)
        decoded.append(f.image)
    (tmp / "pts.txt").write_text("".join(f"{float(t)!r}\n" for t in clip.timestamps))
    assert _cli("track", folder, "--K", K_OPTION, "--bounds", bounds, "--timestamps", tmp / "pts.txt",
                "--tum", tmp / "folder.tum", "-q") == 0
    video_P, tum_t = _tum_poses(tmp / "video.tum", clip.timestamps)
    folder_P, _ = _tum_poses(tmp / "folder.tum", clip.timestamps)
    lossless = track_sequence(seq.images, K_REAL, bounds=seq.bounds, timestamps=seq.timestamps).poses("online")
    cv_P = np.full((n, 4, 4), np.nan)
    for k, image in enumerate(decoded):
        T, _ = _opencv_pose(cv2, image, K_REAL, project(K_REAL, seq.T_WC[k], W), W)
        if T is not None:
            cv_P[k] = T
    d = {name: _positions_mm(P, seq.T_WC) for name, P in
         (("video", video_P), ("folder", folder_P), ("opencv", cv_P), ("lossless", lossless))}
    both = np.all([np.isfinite(v) for v in d.values()], axis=0)
    ate = {name: rms(v[both]) for name, v in d.items()}
    pts = np.sort(_pts_seconds(mp4))
    found = np.isfinite(d["video"])
    tum_gap_ms = 1000 * float(np.max(np.abs(np.sort(tum_t) - pts[found]))) if len(tum_t) == found.sum() else np.nan
    labels = (("video", "graphpose track clip.mp4 (online)"), ("folder", "graphpose track decoded/ (PNG, same times)"),
              ("opencv", "OpenCV per frame + PnP, same decoded frames"),
              ("lossless", "graphpose, lossless renders (the codec's share)"))
    rows = [[label, int(np.isfinite(d[key]).sum()), rms(d[key][np.isfinite(d[key])]), ate[key]]
            for key, label in labels]
    block = {"title": "Video: a hand-held sequence as H.264 (yuv420p, CRF 23)",
             "text": "{n} frames 640 x 480 at 30 fps (the tracking section's sequence: noise 2, blur 1, whip pans), "
                     "{mb:.2f} MB of .mp4; tracked from the file in {video_s:.1f} s. The decoded frames as PNG files, "
                     "tracked with the video's presentation times. TUM timestamps against PyAV's presentation times: "
                     "largest difference {gap:.4f} ms over {found} lines. ATE over the {both} frames all four have.",
             "values": {"n": n, "mb": mp4.stat().st_size / 1e6, "video_s": video_s, "gap": tum_gap_ms,
                        "found": int(found.sum()), "both": int(both.sum())},
             "columns": ["source", "frames with a pose", "ATE mm (own frames)", "ATE mm (common frames)"],
             "formats": ["", "d", ".3f", ".3f"], "rows": rows}
    figures = [
        {"figure": f"video: ATE from the .mp4 / from a PNG folder of the same decoded frames ({int(both.sum())} frames)",
         "unit": "mm", "fmt": ".3f", "graphpose": ate["video"], "peer_name": "PNG folder", "peer": ate["folder"],
         "ratio": ate["video"] / ate["folder"], "goal": "<= 1.05x", "met": bool(ate["video"] <= 1.05 * ate["folder"])},
        {"figure": "video: ATE from the .mp4 against OpenCV per-frame detection + PnP on the same decoded frames",
         "unit": "mm", "fmt": ".3f", "graphpose": ate["video"], "peer_name": "OpenCV", "peer": ate["opencv"],
         "ratio": ate["video"] / ate["opencv"], "goal": "<= 0.7x", "met": bool(ate["video"] <= 0.7 * ate["opencv"])},
        {"figure": "video: the codec's share, ATE from the .mp4 / from the lossless renders", "unit": "mm",
         "fmt": ".3f", "graphpose": ate["video"], "peer_name": "lossless", "peer": ate["lossless"],
         "ratio": ate["video"] / ate["lossless"], "goal": "", "met": None},
        {"figure": "video: TUM timestamps against the container's presentation times, largest difference",
         "unit": "ms", "fmt": ".4f", "graphpose": tum_gap_ms, "peer_name": None, "peer": None, "ratio": None,
         "goal": "< 1 ms", "met": bool(tum_gap_ms < 1.0)},
    ]
    return figures, block, seq


def bags(tmp, seq, quick):
    """Part 2: (figures, block)."""
    from graphpose import PinholeCamera
    from graphpose.io.files import write_png
    from graphpose.io.sources.bag_writer import BAG_FORMATS, write_bag

    n = BAG_FRAMES[quick is False]
    images = seq.images[:n]
    stamps = 1_700_000_000.0 + seq.timestamps[:n]
    folder = tmp / "bag_frames"
    folder.mkdir()
    for k, image in enumerate(images):
        write_png(folder / f"frame_{k:04d}.png", image)
    (tmp / "stamps.txt").write_text("".join(f"{float(t)!r}\n" for t in stamps))
    bounds = _bounds_option(seq.bounds)
    assert _cli("track", folder, "--K", K_OPTION, "--bounds", bounds, "--timestamps", tmp / "stamps.txt",
                "--tum", tmp / "bag_folder.tum", "-q") == 0
    reference, _ = _tum_poses(tmp / "bag_folder.tum", stamps)
    rows, worst = [], 0.0
    camera = PinholeCamera(K_REAL, size=(640, 480))
    for fmt in BAG_FORMATS:
        for compressed in (False, True):
            path = tmp / (f"{fmt}-{'png' if compressed else 'mono8'}" + (".bag" if fmt == "ros1" else ""))
            write_bag(path, images, stamps, fmt=fmt, compressed=compressed, camera=camera)
            out = tmp / f"{path.name}.tum"
            code = _cli("track", path, "--bounds", bounds, "--tum", out, "-q")
            P, t = _tum_poses(out, stamps) if code == 0 else (np.full_like(reference, np.nan), [])
            same = np.isfinite(P[:, 0, 0]) == np.isfinite(reference[:, 0, 0])
            gap = float(np.nanmax(np.abs(P - reference))) if same.all() else float("inf")
            worst = max(worst, gap)
            size = sum(p.stat().st_size for p in ([path] if path.is_file() else path.iterdir())) / 1e6
            rows.append([fmt, "CompressedImage PNG" if compressed else "Image mono8", f"{size:.1f} MB",
                         int(np.isfinite(P[:, 0, 0]).sum()), gap])
    block = {"title": "ROS bags: the same frames, poses without --K (the bag's camera_info)",
             "text": "The first {n} lossless renders written by rosbags' writers with a camera_info on "
                     "/camera/camera_info, tracked by 'graphpose track BAG' (no --K); the reference is the folder "
                     "of the same frames with --K and the bags' header stamps (--timestamps).",
             "values": {"n": n},
             "columns": ["bag", "images", "size", "frames with a pose", "largest pose difference to the folder's"],
             "formats": ["", "", "", "d", ".1e"], "rows": rows}
    figures = [{"figure": "bags (ROS 1, ROS 2 sqlite3, ROS 2 mcap; Image mono8 and CompressedImage PNG): largest "
                          "pose difference to the folder's, tracked without --K", "unit": "", "fmt": ".1e",
                "graphpose": worst, "peer_name": None, "peer": None, "ratio": None, "goal": "<= 1e-9",
                "met": bool(worst <= 1e-9)}]
    return figures, block


def flat_cost(tmp, quick):
    """Part 3: (figures, block)."""
    from graphpose import Board, render_sequence, track_frames
    from graphpose.track.results import LOST

    distinct, total = LONG_DISTINCT[quick is False], LONG_FRAMES[quick is False]
    seq = render_sequence(K_REAL, distinct, rng=19, excursions=0, noise_sigma=2.0, blur_sigma=1.0,
                          distance=(0.6, 1.3), supersample=1)
    path = tmp / "long.mp4"
    start = time.perf_counter()
    # x264's veryfast preset (CRF 23 as the others): encoding 10,000 frames at its default
    # preset would take the benchmark longer than the tracking.
    _write_video(path, (seq.images[k] for k in ping_pong(distinct, total)), seq.fps, preset="veryfast")
    encode_s = time.perf_counter() - start
    n = total
    cpu, rss, reading, lost = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan), 0
    cpu_start = time.process_time()
    for f in track_frames(path, K_REAL, bounds=seq.bounds, board=Board()):
        now = time.process_time()
        cpu[f.index], cpu_start = now - cpu_start, now
        reading[f.index] = f.cpu_s[0]
        lost += f.status == LOST
        rss[f.index] = rss_mb()
    idx = np.arange(n)
    fit = idx >= min(FIT_FROM, n // 2)
    slope = float(np.polyfit(idx[fit], rss[fit], 1)[0]) * 1000
    frame_ms, read_ms = 1000 * median(cpu), 1000 * median(reading)
    block = {"title": f"Flat cost: a {total:,}-frame H.264 recording at 640 x 480",
             "text": "{distinct} distinct renders played forward and backward to {total} frames, encoded (CRF 23, x264 preset "
                     "veryfast) in "
                     "{encode_s:.0f} s to {mb:.1f} MB; tracked from the file by track_frames (defaults: fixed lag, no "
                     "smoothing), {lost} frames lost. Resident memory from frame {fit_from} on: {slope:.3f} MB per "
                     "1,000 frames. Whole tracker a frame (decoding, front end, back end), median process CPU time "
                     "{frame_ms:.2f} ms, of which decoding the frame {read_ms:.2f} ms.",
             "values": {"distinct": distinct, "total": total, "encode_s": encode_s, "mb": path.stat().st_size / 1e6,
                        "lost": int(lost), "fit_from": int(min(FIT_FROM, n // 2)), "slope": slope,
                        "frame_ms": frame_ms, "read_ms": read_ms},
             "columns": None, "formats": None, "rows": None}
    figures = [
        {"figure": f"video of {total:,} frames: memory growth per 1,000 frames", "unit": "MB", "fmt": ".3f",
         "graphpose": slope, "peer_name": None, "peer": None, "ratio": None, "goal": "< 2 MB", "met": bool(slope < 2)},
        {"figure": f"video of {total:,} frames: whole tracker per frame incl. decoding, median process CPU time",
         "unit": "ms", "fmt": ".2f", "graphpose": frame_ms, "peer_name": None, "peer": None, "ratio": None,
         "goal": "< 3 ms", "met": bool(frame_ms < 3.0)},
        {"figure": f"video of {total:,} frames: of which decoding a frame (H.264, PyAV), median process CPU time",
         "unit": "ms", "fmt": ".2f", "graphpose": read_ms, "peer_name": None, "peer": None, "ratio": None,
         "goal": "", "met": None},
    ]
    return figures, block


def _projection_error(camera, truth) -> float:
    w, h = truth.size
    u, v = np.meshgrid(np.arange(0.0, w, 8), np.arange(0.0, h, 8))
    uv = np.stack([u.ravel(), v.ravel()])
    rays = truth.unproject(uv)
    d = camera.project(rays) - uv
    ok = np.all(np.isfinite(d), axis=0)
    return float(np.sqrt(np.mean(np.sum(d[:, ok] ** 2, axis=0))))


def calibration(cv2, tmp, quick):
    """Part 4: (figures, block)."""
    import json

    from graphpose import Board
    from graphpose.calibrate import calibrate
    from graphpose.io.cameras import read_camera
    from graphpose.io.sources import open_frames
    from graphpose.synth.calibration import radtan_camera
    from graphpose.synth.clip import calibration_clip

    seconds = CLIP_SECONDS[quick is False]
    truth, board = radtan_camera(), Board()
    start = time.perf_counter()
    clip = calibration_clip(truth, seconds, 30.0, rng=CLIP_SEED)
    path = tmp / "waved.mp4"
    _write_video(path, clip.frames(), 30.0)
    render_s = time.perf_counter() - start
    # graphpose calibrate on the video, choosing its own views: the whole run timed.
    wall, cpu = time.perf_counter(), time.process_time()
    code = _cli("calibrate", path, "--board", f"{board.cols}x{board.rows}x{board.square_m}", "--out",
                tmp / "cam.json", "--json", tmp / "report.json", "--max-views", 40)
    ours_wall, ours_cpu = time.perf_counter() - wall, time.process_time() - cpu
    assert code == 0, "graphpose calibrate failed on the clip"
    ours = _projection_error(read_camera(tmp / "cam.json"), truth)
    report = json.loads((tmp / "report.json").read_text())
    counts = report["views"]["counts"]
    used = [f["frame"] for f in report["views"]["frames"] if f["status"] == "used"]
    # 40 sharp, whole-board frames picked from the truth, evenly over the clip, decoded from the video.
    eligible = np.flatnonzero((clip.subframes == 1) & (clip.visible == 1.0))
    picks = eligible[np.round(np.linspace(0, len(eligible) - 1, 40)).astype(int)]
    video = open_frames(path)
    hand = calibrate([video.read(int(k)).image for k in picks], "radtan", board=board)
    by_hand = _projection_error(hand.camera, truth)
    # OpenCV: findChessboardCornersSB + calibrateCamera on every 15th frame.
    wall, cpu = time.perf_counter(), time.process_time()
    obj, img = [], []
    W = board.world_points().T.astype(np.float32)
    for f in video.frames(step=15):
        found, corners = cv2.findChessboardCornersSB(f.image, (board.cols, board.rows))
        if found:
            obj.append(W)
            img.append(corners)
    _, K, dist, _, _ = cv2.calibrateCamera(obj, img, truth.size, None, None)
    cv_wall, cv_cpu = time.perf_counter() - wall, time.process_time() - cpu
    from graphpose import RadTanCamera

    cv_err = _projection_error(RadTanCamera(K, dist.ravel()[:5], size=truth.size), truth)
    sharp = [k for k in used if clip.subframes[k] == 1]
    block = {"title": "Calibration from a video: a board waved before a radtan camera",
             "text": "A {seconds:.0f} s clip at 30 fps (seed {seed}, {n} frames, 640 x 480, H.264 CRF 23; rendered and encoded in "
                     "{render_s:.0f} s): {blurred} frames motion-blurred, {partial} with the board partly out of view. "
                     "graphpose calibrate chose {used} views ({sharp} of them not blurred in the truth); the other "
                     "frames: {others}. 40 sharp whole-board frames picked from the truth, evenly over the clip. "
                     "OpenCV: findChessboardCornersSB on every 15th frame ({cv_frames} frames, {cv_found} with a "
                     "board) + calibrateCamera (five coefficients). Whole runs: graphpose {ours_wall:.1f} s wall "
                     "({ours_cpu:.1f} s process CPU), OpenCV {cv_wall:.1f} s wall ({cv_cpu:.1f} s CPU).",
             "values": {"seconds": seconds, "seed": CLIP_SEED, "n": len(clip), "render_s": render_s,
                        "blurred": int((clip.subframes > 1).sum()),
                        "partial": int(((clip.visible > 0) & (clip.visible < 1)).sum()), "used": len(used),
                        "sharp": len(sharp), "others": ", ".join(f"{v} {k}" for k, v in counts.items() if k != "used"),
                        "cv_frames": len(range(0, len(clip), 15)), "cv_found": len(obj), "ours_wall": ours_wall,
                        "ours_cpu": ours_cpu, "cv_wall": cv_wall, "cv_cpu": cv_cpu},
             "columns": ["calibration", "views", "projection error vs the true camera, px RMS"],
             "formats": ["", "d", ".4f"],
             "rows": [["graphpose calibrate clip.mp4 (its own views)", len(used), ours],
                      ["graphpose on 40 sharp whole-board frames picked from the truth", 40, by_hand],
                      ["OpenCV SB + calibrateCamera, every 15th frame", len(obj), cv_err]]}
    figures = [
        {"figure": "calibration from a video: projection error vs the true camera, own views / 40 hand-picked sharp "
                   "whole-board frames", "unit": "px", "fmt": ".4f", "graphpose": ours, "peer_name": "hand-picked",
         "peer": by_hand, "ratio": ours / by_hand, "goal": "<= 1x", "met": bool(ours <= by_hand)},
        {"figure": "calibration from a video: whole run (decoding, choosing, calibrating), process CPU time, against "
                   "OpenCV SB + calibrateCamera on every 15th frame", "unit": "s", "fmt": ".1f", "graphpose": ours_cpu,
         "peer_name": "OpenCV", "peer": cv_cpu, "ratio": ours_cpu / cv_cpu, "goal": "< 1x",
         "met": bool(ours_cpu < cv_cpu)},
        {"figure": "calibration from a video: whole run, wall time (the machine's load in it), against OpenCV SB + "
                   "calibrateCamera on every 15th frame", "unit": "s", "fmt": ".1f", "graphpose": ours_wall,
         "peer_name": "OpenCV", "peer": cv_wall, "ratio": ours_wall / cv_wall, "goal": "< 1x",
         "met": bool(ours_wall < cv_wall)},
    ]
    return figures, block


def pans(quick):
    """Part 5: (figures, block)."""
    from graphpose import Board, render_sequence, track_sequence
    from benchmarks.tracking import NOISY

    n = 60 if quick else 150
    board = Board()
    seq = render_sequence(K_REAL, n, rng=3, excursions=1, noise_sigma=NOISY[0], blur_sigma=NOISY[1],
                          distance=(0.6, 1.3))
    track = track_sequence(seq.images, K_REAL, bounds=seq.bounds, timestamps=seq.timestamps)
    half = seq.visible >= board.n / 2
    lost = half & ~track.found
    block = {"title": "Pans: frames lost with at least half the board in view",
             "text": "The tracking section's noisy sequence ({n} frames, noise {noise:g}, blur {blur:g}): {half} frames "
                     "with at least half of the {junctions} junctions in view, {lost} of them lost (frames {which}).",
             "values": {"n": n, "noise": NOISY[0], "blur": NOISY[1], "half": int(half.sum()), "junctions": board.n,
                        "lost": int(lost.sum()), "which": ", ".join(map(str, np.flatnonzero(lost))) or "none"},
             "columns": None, "formats": None, "rows": None}
    figures = [{"figure": f"pans: frames lost with at least half the board in view, noisy {n}-frame sequence",
                "unit": "", "fmt": "d", "graphpose": int(lost.sum()), "peer_name": None, "peer": None, "ratio": None,
                "goal": "0", "met": bool(lost.sum() == 0)}]
    return figures, block


def main(quick: bool = False) -> dict:
    """Measure the section; returns its goal, headline figures and detail blocks."""
    import cv2

    figures, blocks = [], []
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        f, b, seq = video(cv2, tmp, quick)
        figures += f
        blocks.append(b)
        for part in (lambda: bags(tmp, seq, quick), lambda: flat_cost(tmp, quick), lambda: calibration(cv2, tmp, quick),
                     lambda: pans(quick)):
            f, b = part()
            figures += f
            blocks.append(b)
    return {"goal": "Recordings as people make them: a video tracked as well as the same decoded frames "
                    "from a folder, and better than OpenCV per frame; its TUM timestamps the container's; ROS bags "
                    "giving the folder's poses with their own camera_info; a 10,000-frame video at flat memory and "
                    "under 3 ms a frame; a calibration from a waved clip at least as good as 40 hand-picked frames "
                    "and faster than OpenCV on every 15th frame; no frame lost in pans with half the board in view.",
            "figures": figures, "blocks": blocks}


if __name__ == "__main__":
    import sys

    from benchmarks.cli import main as cli_main

    sys.exit(cli_main(["recordings", *sys.argv[1:]]))

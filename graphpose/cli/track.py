"""``graphpose track``: the camera trajectory over a sequence of frames of the board.

Turns the arguments into typed values (frame files, bounds (2, 4), a camera (``--camera FILE``
with its lens model, or a pinhole ``--K``), :class:`Board`, timestamps, a true trajectory), calls :func:`graphpose.track.tracker.track_frames` once, and
writes, frame by frame as the results come (:mod:`graphpose.cli.track_output`), the trajectory
in TUM format (``--tum``) and per-frame results as JSON (``--json``); then a picture
(``--plot``, from a few numbers kept a frame) and a summary on stdout. A frame file that cannot be read is a lost
frame, not an error. The true trajectory (``--truth``, or the ``truth.tum`` that
``graphpose render-sequence`` leaves beside its frames) is drawn in the picture and measured
against in the summary. Exit code 0 when at least one frame has a pose, 1 when every frame
was lost (see :mod:`graphpose.cli`).
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from dataclasses import replace
from pathlib import Path

import numpy as np

from .._checks import as_float_array
from ..errors import InputError
from ..io.files import read_json
from ..track.config import DEFAULT_LAG_S, MOTION_MODELS, TARGET_FORMS
from ..io.sources.bags import is_bag
from ..io.sources.base import BrokenRecordingError
from ..io.sources.paths import is_pattern
from . import HelpFormatter, EXIT_FAILED, EXIT_OK, exit_code, exit_codes_help, prefix, print_error
from .recordings import (
    OverlayVideo,
    RateProgress,
    add_overlay_video_option,
    add_topic_option,
    camera_note,
    open_source,
    recording_camera,
)
from .options import (
    add_camera_option,
    add_target_options,
    camera_file,
    camera_from_args,
    check_camera_options,
    check_output_folder,
    parse_bounds,
    parse_positive,
)
from ..io.files import to_jsonable
from ..io.records import frame_record, pose_block, target_keys, target_words

#: ``--lag``'s default: :func:`graphpose.track.config.default_lag_s` of the frames' timestamps.
AUTO_LAG = "auto"

_EXAMPLES = """\
examples:
  graphpose render-sequence seq/ --frames 120
  graphpose track seq/ --bounds "$(python -c 'import json; b=json.load(open("seq/bounds.json"))["bounds"]; print(",".join(f"{u},{v}" for u, v in zip(*b)))')" \\
      --tum est.tum --json est.json --smooth --plot track.png    # seq/truth.tum is drawn and measured
  graphpose track frames/*.png --K 564.9,564.3,337.3,226.5 --bounds 166,254,455,136,541,347,259,477 \
      --timestamps times.txt --tum est.tum
  graphpose track frames/ --K 564.9,564.3,337.3,226.5 --truth mocap.tum --plot track.png
  graphpose track raw/ --camera camchain.yaml --board 9x6x0.03 --tum est.tum   # raw frames, their lens
  evo_ape tum seq/truth.tum est.tum          # absolute trajectory error (no alignment needed)

FRAMES is one folder (its image files in name order; other files are ignored), image files
in the order given, a quoted glob, a list file (one path a line), a video (its presentation
times are the frames' times) or a ROS bag (--topic; header stamps; its camera_info is the
camera when neither --camera nor --K is given): docs/recordings.md. Frames need their camera: --camera FILE or --K (no calibration yet:
'graphpose calibrate'); a folder written by 'graphpose render-sequence' brings its own. --bounds (optional) is the board's polygon in the FIRST frame, (u, v)
pixels, clockwise from the corner nearest junction 0; without it the first frame is searched
whole, and a board unchanged by a half turn is labelled from the image's upper left, then
kept continuous from frame to frame. --camera reads a calibration with the lens model (the
frames are raw); --K is a camera without distortion. The TUM file has one line
'timestamp tx ty tz qx qy qz qw' per frame with a pose (camera in the target frame); a lost
frame has no line. A frame file that cannot be read is reported lost. --truth poses are matched
to the frames by timestamp (within 10 ms and half a frame interval); a folder written by
'graphpose render-sequence' brings its own truth.tum, one pose per frame.
""" + exit_codes_help("every frame lost (the reason on stderr)")


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``track`` subcommand's parser to ``subparsers``."""
    p = subparsers.add_parser(
        "track",
        help="camera trajectory over a sequence of frames (iSAM2), TUM and JSON output",
        description=textwrap.fill(
            "Track the camera pose T_WC relative to a checkerboard over a sequence of frames: "
            "junctions predicted and refined frame to frame, one GTSAM graph solved incrementally "
            "with iSAM2, frames without a usable board reported lost.", 88),
        epilog=_EXAMPLES,
        formatter_class=HelpFormatter,
    )
    p.add_argument("frames", nargs="*", type=Path, metavar="FRAMES",
                   help="a folder of frames, frame files in order, a quoted glob, a list file (one path a line), "
                   "a video or a ROS bag (see docs/recordings.md); none with --rig")
    p.add_argument("--bounds", type=parse_bounds, metavar="U1,V1,U2,V2,U3,V3,U4,V4",
                   help="the board's bounding polygon in the first frame, pixels (default: search the "
                   "whole image, which finds a board that does not fill the frame)")
    p.add_argument("--polygons", type=Path, metavar="POLYGONS.json",
                   help="per-frame bounding polygons for re-detection: a JSON list with one 2 x 4 "
                   "polygon or null per frame")
    add_target_options(p)
    add_camera_option(p)
    times = p.add_mutually_exclusive_group()
    times.add_argument("--fps", type=parse_positive, default=30.0, help="frame rate for timestamps index / fps (default 30)")
    times.add_argument("--timestamps", type=Path, metavar="FILE", help="one timestamp (seconds) per frame, one per line")
    p.add_argument("--motion", choices=MOTION_MODELS, default="constant_velocity",
                   help="motion prior between frames (default constant_velocity; wnoa is GTSAM's C++ "
                   "constant-velocity factor, without a robust kernel)")
    p.add_argument("--target", choices=TARGET_FORMS, default="resection",
                   help="how the fixed target points enter the graph (default resection: one factor "
                   "a frame; frame_landmarks: pinned landmark copies with GTSAM's projection factors, "
                   "all C++ with --motion wnoa)")
    p.add_argument("--robust", action="store_true",
                   help="Huber loss in each frame's own pose fit, as 'graphpose estimate --robust' "
                   "(down-weights outlying junctions)")
    p.add_argument("--lag", type=_parse_lag, default=AUTO_LAG, metavar="SECONDS",
                   help=f"online back end: a fixed-lag smoother over the last SECONDS (default {DEFAULT_LAG_S:g}, "
                   "longer for slow sequences: twice the frames one motion factor spans), flat cost however long the "
                   "sequence; 'none': one iSAM2 over the whole sequence, whose cost grows with it")
    p.add_argument("--smooth", action="store_true", help="smooth the whole trajectory in batch at the end")
    p.add_argument("--tum", metavar="OUT.txt", help="write the trajectory in TUM format")
    p.add_argument("--json", metavar="OUT.json", help="write per-frame results as JSON ('-': stdout, no summary)")
    p.add_argument("--plot", metavar="OUT.png",
                   help="draw the trajectory, with the truth where known, and the per-frame reprojection "
                   "RMS (needs the plot extra, matplotlib: checked before the tracking starts)")
    p.add_argument("--truth", type=Path, metavar="TRUTH.tum",
                   help="the true trajectory (TUM), drawn by --plot and measured against in the summary "
                   "(default: FRAMES/truth.tum of a folder written by graphpose render-sequence)")
    p.add_argument("-q", "--quiet", action="store_true", help="no summary on stdout")
    from .rig import add_track_options

    add_track_options(p)
    add_topic_option(p)
    add_overlay_video_option(p)
    return p


def run(args) -> int:
    """Run ``graphpose track`` with parsed ``args``; returns the exit code."""
    if getattr(args, "rig", None):
        from .rig import run_track

        return run_track(args)
    if not args.frames:
        from . import UsageError

        raise UsageError("give the frames (FRAMES: a folder or frame files), or --rig SOURCE0 SOURCE1 ... for a rig")
    from ..track.config import MotionPrior, TrackerConfig, default_lag_s
    from ..track.frames import frame_timestamps, read_timestamps
    from ..track.tracker import track_frames
    from ..io.tum import TumStream
    from .track_output import JsonStream, TrackSummary, abort_on_error

    if args.plot is not None:  # a missing extra is found now, not after the whole sequence
        from .._extras import require

        require("matplotlib", "plot", "graphpose track --plot")
    check_camera_options(args)
    files = _frame_files(args.frames, args)
    n = len(files)
    timestamps = files.timestamps if args.timestamps is None else read_timestamps(args.timestamps, n)
    polygons = None if args.polygons is None else _read_polygons(args.polygons)
    for path, name in ((args.tum, "--tum"), (args.json, "--json"), (args.plot, "--plot"),
                       (args.overlay_video, "--overlay-video")):
        check_output_folder(path, name)
    seconds = frame_timestamps(timestamps, args.fps, n)
    truth, truth_note = _truth(args, n, seconds)
    camera, board, source = _camera(args, files)  # after the other inputs: each says first what is wrong with it
    progress = RateProgress(n, sys.stderr)
    lag = default_lag_s(args.motion, seconds) if args.lag == AUTO_LAG else args.lag
    config = TrackerConfig(motion=MotionPrior(args.motion), target=args.target, robust=args.robust, lag_s=lag)
    stream = track_frames(files, camera, bounds=args.bounds, board=board, timestamps=timestamps, fps=args.fps,
                          polygons=polygons, config=config, smooth=args.smooth,
                          progress=lambda k, n: progress.show(k + 1, Path(files.label(k)).name))
    target = target_keys(camera, board, *camera_file(args, source))
    summary, kept = TrackSummary(truth), []  # kept: the picture's few numbers a frame
    tum = None if args.tum is None else TumStream(args.tum)
    doc = video = broken = None
    with abort_on_error(progress, lambda: (tum, doc)):
        doc = None if args.json is None else JsonStream(args.json)
        video = None if args.overlay_video is None else OverlayVideo(args.overlay_video, args.frames, args, camera, board)
        try:
            for f in stream:
                summary.add(f)
                if tum is not None and f.T_WC is not None:
                    tum.add(f.timestamp, f.T_WC)
                if doc is not None:
                    doc.add(_frame_record(f, files.label(f.index)))
                if video is not None:
                    video.add(f)
                if args.plot is not None:
                    kept.append(replace(f, cov=None, cov_pixel=None, single_T_WC=None, points=None, ids=None))
        except BrokenRecordingError as exc:  # what came before the damage is written, then the one line
            broken = exc
        progress.clear()
        if video is not None:
            video.close()
        if tum is not None:
            tum.close(f"graphpose track: camera pose T_WC in the target frame; {summary.n - summary.found} "
                      f"lost frames have no line")
        if doc is not None:
            doc.close({"smoothed": bool(args.smooth), "motion": args.motion, "target": args.target,
                       "lag_s": config.lag_s, "K": camera.K, "camera": target["camera"],
                       "board": f"{board.cols}x{board.rows}x{board.square_m}"})
    if args.plot is not None:
        from ..track.results import Track
        from ..viz.plot import plot_track

        kept = tuple(kept)
        plot_track(Track(kept, kept if args.smooth else None, config), args.plot, board=board, truth=truth,
                   title=f"graphpose track: {len(kept)} frames" + (", truth in grey" if truth is not None else ""))
    if not args.quiet and args.json != "-":
        print(summary.text(args.smooth, truth_note), flush=True)
        print("camera: {}; board: {}".format(*target_words(target)), flush=True)
        if files.camera_source and source == files.camera_source:
            print(camera_note(source), flush=True)
    if broken is not None:
        print_error(broken, prog=prefix("track"))
        return exit_code(broken)
    if not summary.found:  # the failure's reason on stderr, as every command's
        print(f"{prefix('track')}: error: no pose in any of the {summary.n} frames; the first lost, "
              f"{summary.first_lost} (no frame of the {n} in {files.name} shows the board {board.cols}x{board.rows}"
              f"{'' if args.bounds is None else ' inside --bounds'})", file=sys.stderr, flush=True)
    return EXIT_OK if summary.found else EXIT_FAILED


def _frame_record(f, path) -> dict:
    """The frame's JSON record (:func:`graphpose.io.records.frame_record`) with what its sigmas
    describe, as ``graphpose estimate`` records it: ``sigma_kind``, and the pixel noise's
    share alone in ``sigma_pixel_xyz_m`` and ``sigma_pixel_rpy_deg``."""
    record = frame_record(f, path)
    pixel = pose_block(f.status, None, f.T_WC, f.cov_pixel)
    record.update(to_jsonable({"sigma_kind": None if f.T_WC is None else f.sigma_kind,
                               "sigma_pixel_xyz_m": pixel["sigma_xyz_m"],
                               "sigma_pixel_rpy_deg": pixel["sigma_rpy_deg"]}))
    return record


def _camera(args, recording):
    """``(Camera, Board, source)``: as :func:`graphpose.cli.options.camera_from_args`; a folder
    written by ``graphpose render-sequence`` brings its own K and board (its ``bounds.json``,
    then the ``source``), as the bundled example's case file does, and a bag its camera_info
    (:func:`graphpose.cli.recordings.recording_camera`); None otherwise."""
    check_camera_options(args)
    folder = args.frames[0] if len(args.frames) == 1 and args.frames[0].is_dir() else None
    meta = folder / "bounds.json" if folder is not None else None
    if args.camera is not None or args.K is not None or meta is None or not meta.is_file():
        return recording_camera(args, recording)
    from ..board import Board
    from ..camera_models import PinholeCamera

    doc = read_json(meta, "the rendered sequence's bounds.json")
    try:
        camera, board = PinholeCamera(np.asarray(doc["K"], dtype=float)), Board.parse(doc["board"])
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{meta} (graphpose render-sequence's) holds no usable K and board ({exc}); "
                         f"give --camera FILE or --K FX,FY,CX,CY") from None
    return (*camera_from_args(args, camera, board), str(meta))


def _parse_lag(text: str):
    """``--lag``: a positive number of seconds, 'none' (the whole-sequence iSAM2) or 'auto'
    (the default, :data:`AUTO_LAG`)."""
    word = text.strip().lower()
    if word == "none":
        return None
    if word == AUTO_LAG:
        return AUTO_LAG
    return parse_positive(text)


def _truth(args, n, timestamps):
    """The true pose of every frame, (n, 4, 4) with NaN where unknown, and where it came from;
    (None, "") without a truth. ``--truth`` is matched by timestamp; a folder written by
    ``graphpose render-sequence`` (its ``truth.tum`` and ``bounds.json``,
    :func:`graphpose.synth.sequence.write_sequence`) holds one true pose per frame, in order."""
    from ..io.tum import read_tum
    from ..track.trajectory import associate

    path, own = args.truth, False
    folder = args.frames[0] if len(args.frames) == 1 and args.frames[0].is_dir() else None
    if path is None and folder is not None and (folder / "bounds.json").is_file() and (folder / "truth.tum").is_file():
        path, own = folder / "truth.tum", True
    if path is None:
        return None, ""
    truth = read_tum(path)
    if own and len(truth) == n:
        return truth.poses, f"{path} (the rendered sequence's own, one pose per frame)"
    poses = associate(truth.timestamps, truth.poses, timestamps)
    matched = int(np.sum(np.isfinite(poses[:, 0, 0])))
    if matched == 0:
        raise InputError(f"{'--truth ' if not own else ''}{path}: none of its {len(truth)} poses has the "
                         f"timestamp of a frame (frames at {timestamps[0]:.6f}-{timestamps[-1]:.6f} s; "
                         f"give the frames' own times with --timestamps or --fps)")
    return poses, f"{path} ({matched} of {n} frames matched by timestamp)"


def _frame_files(paths, args):
    """The frames (:func:`graphpose.cli.recordings.open_source`); image files named one by one
    must exist (a folder's, a glob's or a list's are found by looking)."""
    from ..io.sources import ImageFiles
    from ..track.frames import list_frames

    if len(paths) == 1 and paths[0].is_dir() and not is_bag(paths[0]):
        list_frames(paths[0])  # its own message for a folder without images
    missing = [str(p) for p in paths if not p.exists() and not is_pattern(str(p))]
    if missing:
        raise _not_found(missing)
    recording = open_source(paths, args)
    if isinstance(recording, ImageFiles):
        missing = [str(p) for p in recording.files if not p.is_file()]
        if missing:
            raise _not_found(missing)
    return recording


def _not_found(missing) -> InputError:
    """The one error for frame files that are not there, naming the first few."""
    more = ""
    if len(missing) > 1:
        more = f" (and {len(missing) - 1} more: {', '.join(missing[1:3])}" + (" ...)" if len(missing) > 3 else ")")
    return InputError(f"image file not found: {missing[0]}{more}")


def _read_polygons(path: Path) -> list:
    doc = read_json(path, "--polygons file")
    if not isinstance(doc, list):
        raise InputError(f"--polygons {path} must hold a JSON list (one 2 x 4 polygon or null per frame)")
    return [None if p is None else as_float_array(p, f"--polygons {path} entry {k}") for k, p in enumerate(doc)]

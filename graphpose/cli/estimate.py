"""``graphpose estimate``: the camera pose from images, folders of them, a case file, or the bundled example.

Turns the arguments into typed values (bounds (2, 4) or none, a camera (``--camera FILE``
with its lens model, or a pinhole ``--K``), :class:`Board`, a guess (4, 4)), calls :func:`graphpose.estimate.estimate_pose` once per image, and writes a report
on stdout, optionally ``--json`` results and ``--overlay`` pictures. An image that fails in
a batch is reported on stderr and in its JSON entry, and the others go on; the exit code is
then the worst of the images' codes (see :mod:`graphpose.cli`).
"""

from __future__ import annotations

import argparse
import os
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..camera_models import check_image_size
from ..errors import BoardNotFoundError, GraphposeError, InputError
from ..image import read_image
from ..io.files import write_png
from ..estimate import estimate_pose, pose_difference
from ..pose.covariance import SIGMA_PIXEL
from ..io.sources import BrokenRecordingError, expand_paths, is_recording
from . import HelpFormatter, EXIT_OK, UsageError, error_line, exit_code, exit_codes_help, prefix, print_error
from .recordings import RateProgress, add_every_option, add_topic_option, camera_note, open_source, recording_camera
from .options import (
    add_camera_option,
    add_target_options,
    board_hint,
    camera_file,
    camera_from_args,
    check_camera_options,
    check_output_folder,
    parse_bounds,
    write_json_option,
)
from ..io.records import result_record, target_keys, target_words


def __getattr__(name):
    """``DEFAULT_CASES``: the bundled example, package data made by scripts/make_data.py with
    graphpose.synth.render; looked up on first use, so that the case files' reader (and the
    camera files' behind it) is not imported by a command that reads neither."""
    if name == "DEFAULT_CASES":
        from ..io.cases import bundled_cases_path
        return bundled_cases_path()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

_EXAMPLES = """\
examples:
  graphpose estimate                                  # the bundled example (data/cases.json)
  graphpose estimate board.png --K 564.9,564.3,337.3,226.5   # the board searched in the whole image
  graphpose estimate raw.jpg --camera left.opencv.yml --board 9x6x0.03   # a raw image, its lens
  graphpose estimate left/ right01.jpg right02.jpg --camera cam.yml --board 9x6x30mm --json poses.json
  graphpose estimate board.png --bounds 166,254,455,136,541,347,259,477 \\
      --K 564.9,564.3,337.3,226.5 --board 8x6x0.0635 --guess pose.json
  graphpose estimate --cases cases.json --json out.json --overlay overlays/

An image needs its camera: --camera FILE or --K (no calibration yet: 'graphpose calibrate').
A FOLDER stands for its image files in name order. --bounds (optional) lists the polygon's corners (u, v) in pixels, (u, v) = (column, row)
from 0, clockwise from the corner nearest junction 0: it narrows the search and names
junction 0's corner. Without it a board unchanged by a half turn is reported orientation
ambiguous (junction 0 is then the corner nearest the image's upper left). --camera reads
OpenCV YAML/XML, ROS camera_info, Kalibr (cam0) and graphpose's JSON calibrations; --K is
a camera without distortion. POSE.json holds a 4 x 4 T_WC (camera pose in the target frame)
as a nested list or as {"T_WC": [...]}.
""" + exit_codes_help("an estimate failed (no board found, no convergence; with many images: the worst)")


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``estimate`` subcommand's parser to ``subparsers`` (an argparse subparsers action)."""
    p = subparsers.add_parser(
        "estimate",
        help="camera pose from checkerboard images (default: the bundled example)",
        description=textwrap.fill(
            "Estimate the camera pose T_WC relative to a checkerboard, with 1-sigma uncertainties. "
            "Give images or folders of them (with --camera FILE or --K, optionally --bounds), or --cases "
            "CASES.json; with neither, runs the bundled example data/cases.json. With --camera, images are "
            "raw (lens distortion modelled).", 88),
        epilog=_EXAMPLES,
        formatter_class=HelpFormatter,
    )
    p.add_argument("images", nargs="*", type=Path, metavar="IMAGE_OR_FOLDER",
                   help="images of the board (any format scikit-image reads; colour is made grey), folders "
                   "of them (their image files in name order), quoted globs, list files (one path a line), "
                   "or one video or ROS bag (every frame, or every N-th with --every)")
    p.add_argument("--bounds", type=parse_bounds, metavar="U1,V1,U2,V2,U3,V3,U4,V4",
                   help="the board's bounding polygon in the images, pixels, clockwise from the corner nearest "
                   "junction 0 (default: search the whole image)")
    add_target_options(p, "with --cases, the file's")
    add_camera_option(p, "with --cases, the file's K or camera")
    p.add_argument("--guess", type=Path, metavar="POSE.json",
                   help="initial pose for the images (default: the linear homography initialiser)")
    p.add_argument("--cases", type=Path, metavar="CASES.json",
                   help="many images: a case file (K or camera, and per case image path relative to the "
                   "file, optional bounds and guess_T_WC)")
    p.add_argument("--no-guess", action="store_true",
                   help="ignore the case file's guesses and use the linear initialiser")
    p.add_argument("--robust", action="store_true", help="down-weight outlying junctions (robust loss)")
    p.add_argument("--json", metavar="OUT.json",
                   help="write the results as JSON, a list with one object per image ('-': stdout, no report)")
    p.add_argument("--overlay", metavar="OUT.png|FOLDER",
                   help="draw junctions, reprojection, axes and pose on the image; a folder "
                   "(created if absent) holds one IMAGE_NAME.overlay.png per image")
    p.add_argument("-q", "--quiet", action="store_true", help="no report on stdout (errors still on stderr)")
    from .rig import add_estimate_options

    add_estimate_options(p)
    add_topic_option(p)
    add_every_option(p)
    return p


# --- the run -----------------------------------------------------------------------------


@dataclass(frozen=True)
class Job:
    """One image to estimate: its name for people and for JSON, bounds (2, 4) or None, guess (4, 4) or None."""

    name: str
    path: Path
    bounds: np.ndarray | None = None
    guess: np.ndarray | None = None
    true_T_WC: np.ndarray | None = None
    ref_T_WC: np.ndarray | None = None
    recording: object = None  # a video or bag (graphpose.io.sources) whose frame ``frame`` this is
    frame: int | None = None


def run(args) -> int:
    """Run ``graphpose estimate`` with parsed ``args``; returns the exit code."""
    if getattr(args, "rig", None):
        from .rig import run_estimate

        return run_estimate(args)
    jobs, cases, source = _jobs(args)
    overlays = _overlay_paths(args.overlay, jobs) or [None] * len(jobs)
    check_output_folder(args.json, "--json")
    camera, board, target = _target(args, cases, source, jobs)
    report = not (args.quiet or args.json == "-")
    progress = RateProgress(len(jobs), sys.stderr)
    records, codes, broken = [], [], None
    try:
        for i, (job, overlay) in enumerate(zip(jobs, overlays)):
            progress.show(i, Path(job.name).name)
            record, code = _run_one(job, camera, board, target, args.robust, overlay, report, progress,
                                        board_given=args.board is not None)
            records.append(record)
            codes.append(code)
        if jobs and jobs[0].recording is not None:
            broken = jobs[0].recording.end_error()
    except BrokenRecordingError as exc:  # the frames before the damage are reported and written
        broken = exc
    progress.clear()
    if report and len(jobs) > 1:
        failed = sum(c != EXIT_OK for c in codes)
        what = "images" if jobs[0].recording is None else f"frames of {jobs[0].recording.name}"
        print(f"{len(jobs)} {what}: {len(jobs) - failed} estimated, {failed} failed")
    write_json_option(args.json, records)
    if broken is not None:
        print_error(broken, prog=prefix("estimate"))
        return exit_code(broken)
    return max(codes)


def _run_one(job, camera, board, target, robust, overlay, report, progress, board_given=False):
    """Estimate one image, report it and draw it; returns its JSON record and exit code.

    Every failure of this image, writing its overlay included, is reported and recorded here,
    so the batch goes on and its JSON is still written. ``target`` holds the record's
    ``camera`` and ``board`` keys (:func:`graphpose.io.records.target_keys`).
    """
    estimate, error, code, image = None, None, EXIT_OK, None
    try:
        image = _read(job)
        check_image_size(camera, image.shape, job.name)
        try:
            estimate = estimate_pose(image, camera, bounds=job.bounds, board=board, guess=job.guess, robust=robust)
        except BoardNotFoundError as exc:
            raise BoardNotFoundError(board_hint(str(exc), board_given)) from None
        # An unreliable pose is drawn too: the picture shows why.
        if overlay is not None:
            _write_overlay(overlay, image, estimate, camera, board, job)
        if not estimate.ok:
            raise _NotConverged(f"no reliable pose: {estimate.message}")
    except BrokenRecordingError:
        raise
    except GraphposeError as exc:
        error, code = " ".join(str(exc).split()), exit_code(exc)
        picture = ""
        if overlay is not None and image is not None and estimate is None:
            picture = _write_failure_overlay(overlay, image, error, job, board, progress,
                                             getattr(exc, "junctions_seen", 0))
        progress.clear()
        line = error_line(exc, "" if str(job.path) in str(exc) else job.name)
        print(f"{prefix('estimate')}: error: {line}{picture}", file=sys.stderr, flush=True)
    record = result_record(str(job.path), estimate, error)
    if job.recording is not None:  # the frame by index and time
        record = {"image": record.pop("image"), "frame": job.frame,
                  "timestamp": float(job.recording.timestamps[job.frame]), **record}
    record["vs_truth"] = _difference(estimate, job.true_T_WC)
    record["vs_reference"] = _difference(estimate, job.ref_T_WC)
    record.update(target)
    # An unreliable pose goes to JSON and the overlay, not into the report.
    if report and code == EXIT_OK:
        progress.clear()
        print(format_report(job.name, estimate, record), flush=True)
    return record, code


def _read(job):
    """The job's grey image: its file (8-bit stays uint8: the detector reads it as it is), or
    its frame of a recording."""
    if job.recording is not None:
        return job.recording.read(job.frame).image
    return read_image(job.path, as_float=False)


def _write_overlay(path: Path, image, estimate, camera, board, job) -> None:
    """Draw ``estimate`` on ``image`` into the PNG ``path``, creating its folder if needed."""
    from ..viz.overlay import draw_overlay  # only with --overlay: not in every command's start

    _make_folder(path)
    write_png(path, draw_overlay(image, estimate, camera, board, bounds=job.bounds, label=Path(job.name).name))


def _write_failure_overlay(path: Path, image, reason: str, job, board, progress, seen: int = 0) -> str:
    """Draw the picture of an image without a pose: its bounds, what the search found, the
    reason (:func:`graphpose.viz.failure.draw_failure`); returns the words that add its path
    to the image's error line (a failure to write it is one more line, and no words)."""
    from ..viz.failure import draw_failure

    try:
        _make_folder(path)
        write_png(path, draw_failure(image, reason, bounds=job.bounds, board=board, label=Path(job.name).name,
                                       seen=seen))
    except GraphposeError as exc:
        progress.clear()
        print_error(exc, job.name, prog=prefix("estimate"))
        return ""
    return f" (its picture, with what was found: {path})"


def _make_folder(path: Path) -> None:
    try:
        path.parent.mkdir(exist_ok=True)
    except OSError as exc:
        raise InputError(f"--overlay: cannot create folder {path.parent}: {exc.strerror or exc}") from None


class _NotConverged(GraphposeError):
    """The pose did not converge or failed the GN-GTSAM cross-check (exit code 1)."""


def _jobs(args):
    """The images to estimate, from images and folders, --cases or the bundled example; the
    case file (None for images) and its name as shown."""
    if args.images and args.cases is not None:
        raise UsageError("give either IMAGE or --cases, not both (IMAGE: images or folders of them)")
    check_camera_options(args)  # before any file is read
    if args.images:
        if args.no_guess and args.guess is not None:
            raise UsageError("--guess and --no-guess contradict each other")
        guess = None
        if args.guess is not None:
            from ..io.cases import load_pose

            guess = load_pose(args.guess)
        recording = open_source(args.images, args) if len(args.images) == 1 and is_recording(args.images[0]) else None
        if recording is not None:
            return [Job(recording.label(k), Path(recording.name), args.bounds, guess, recording=recording, frame=k)
                    for k in range(0, len(recording), args.every)], None, None
        if args.every != 1 or getattr(args, "topic", None) is not None:
            raise UsageError("--every and --topic go with one video or ROS bag")
        return [Job(str(path), path, args.bounds, guess) for path in expand_paths(args.images)], None, None
    if args.bounds is not None:
        raise UsageError("--bounds goes with IMAGE (images or folders); a case file gives each image its bounds")
    if args.guess is not None:
        raise UsageError("--guess goes with IMAGE (images or folders); a case file gives each image its guess_T_WC")
    from ..io.cases import bundled_cases_path, load_cases

    path = args.cases if args.cases is not None else bundled_cases_path()
    if args.cases is None and not path.is_file():
        raise InputError(f"the bundled example {path} is missing; give IMAGE --bounds ... or --cases CASES.json")
    cases = load_cases(path, require_camera=False)
    if not cases.cases:
        raise InputError(f"case file {path} has no cases")
    jobs = [Job(_display(c.image), c.image, c.bounds, None if args.no_guess else c.guess_T_WC,
                c.true_T_WC, c.ref_T_WC) for c in cases.cases]
    return jobs, cases, _display(path)


def _target(args, cases, source, jobs=()):
    """The camera, the board and the records' ``camera`` and ``board`` keys: from the
    options, else the case file's, else a bag's camera_info; no camera at all is
    :data:`graphpose.cli.options.NO_CAMERA`."""
    if cases is None and jobs and jobs[0].recording is not None:
        camera, board, source = recording_camera(args, jobs[0].recording)
        if source and not (args.quiet or args.json == "-"):
            print(camera_note(source))
    elif cases is None:
        camera, board = camera_from_args(args)
    else:
        camera, board = camera_from_args(args, cases.camera, cases.board,
                                         source=f"case file {source} gives no K nor camera")
    return camera, board, target_keys(camera, board, *camera_file(args, source))


def _display(path: Path) -> str:
    """``path`` relative to the working folder when it lies below it, else absolute."""
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def _overlay_paths(overlay, jobs) -> list | None:
    """Where each job's overlay goes: OUT.png for one image, FOLDER/NAME.overlay.png for many."""
    if overlay is None:
        return None
    path = Path(overlay)
    folder = path.is_dir() or overlay.endswith(("/", os.sep)) or (len(jobs) > 1 and not path.suffix)
    if not folder:
        if len(jobs) > 1:
            raise UsageError(f"--overlay: {len(jobs)} images need a folder, got the file name {overlay}")
        if path.suffix.lower() != ".png":
            raise UsageError(f"--overlay: the picture is PNG, so the name must end in .png, got {overlay}")
        check_output_folder(path, "--overlay")
        return [path]
    check_output_folder(path.resolve(), "--overlay")
    names, seen = [], {}
    for job in jobs:
        stem = Path(job.path).stem
        seen[stem] = seen.get(stem, 0) + 1
        names.append(path / (f"{stem}.overlay.png" if seen[stem] == 1 else f"{stem}-{seen[stem]}.overlay.png"))
    return names


def _difference(estimate, T_ref) -> dict | None:
    """Translation (mm) and rotation angle (deg) between the estimate and a known pose, or None."""
    if estimate is None or T_ref is None:
        return None
    metres, degrees = pose_difference(estimate.T_WC, T_ref)
    return {"translation_mm": 1000.0 * metres, "rotation_deg": degrees}


# --- the report ----------------------------------------------------------------------------

#: The report's line for an estimate whose board orientation the image cannot fix.
ORIENTATION_AMBIGUOUS = ("orientation ambiguous (half-turn symmetric board, no bounds): junction 0 is the "
                         "corner nearest the image's upper left")


def format_report(name: str, estimate, record: dict) -> str:
    """The readable report of one image's estimate (several lines, no trailing newline)."""
    T = np.asarray(estimate.T_WC)
    x, y, z, *rpy = estimate.params
    sx, sy, sz = 1000.0 * np.asarray(estimate.sigma_xyz_m)
    sr, sp, sw = np.degrees(estimate.sigma_rpy_rad)
    roll, pitch, yaw = np.degrees(rpy)
    trusted = np.asarray(estimate.mask, dtype=bool)
    check = estimate.cross_check
    state = "converged" if estimate.converged else "NOT converged"
    n = int(estimate.iterations)
    rows = [f"{name}  ({state}, {n} iteration{'' if n == 1 else 's'})"]
    for i, row in enumerate(T):
        rows.append(("  T_WC  " if i == 0 else "        ") + "[" + " ".join(f"{v:9.5f}" for v in row) + " ]")
    rows += [
        f"  {'':16}{'x':>10}{'y':>10}{'z':>10}",
        f"  {'position (m)':16}{x:10.4f}{y:10.4f}{z:10.4f}",
        f"  {'1-sigma (mm)':16}{sx:10.2f}{sy:10.2f}{sz:10.2f}",
        f"  {'':16}{'roll':>10}{'pitch':>10}{'yaw':>10}",
        f"  {'angles (deg)':16}{roll:10.3f}{pitch:10.3f}{yaw:10.3f}",
        f"  {'1-sigma (deg)':16}{sr:10.3f}{sp:10.3f}{sw:10.3f}",
        *_sigma_kind_rows(estimate),
        f"  {'reprojection':16}{estimate.rms_px:.3f} px RMS over {trusted.size} junctions, "
        f"{int(trusted.sum())} trusted",
        f"  {'GN vs GTSAM':16}{1000.0 * check.translation_m:.2g} mm, {check.rotation_deg:.2g} deg apart: "
        + ("agree" if check.agree else "DISAGREE"),
    ]
    if record.get("camera") is not None:
        camera, board = target_words(record)
        rows += [f"  {'camera':16}{camera}", f"  {'board':16}{board}"]
    if getattr(estimate, "orientation_ambiguous", False):
        rows.append(f"  {'orientation':16}{ORIENTATION_AMBIGUOUS}")
    for key, label in (("vs_truth", "error vs truth"), ("vs_reference", "vs reference")):
        if record.get(key):
            rows.append(f"  {label:16}{record[key]['translation_mm']:.2f} mm, {record[key]['rotation_deg']:.3f} deg")
    return "\n".join(rows) + "\n"


def _sigma_kind_rows(estimate) -> list:
    """With a calibration's covariance in the sigmas: say so, and give the pixel noise's share."""
    if getattr(estimate, "sigma_kind", SIGMA_PIXEL) == SIGMA_PIXEL:
        return []
    sigma = np.sqrt(np.diag(estimate.cov_pixel))
    mm, deg = 1000.0 * sigma[:3], np.degrees(sigma[3:])
    return [f"  {'1-sigma from':16}{estimate.sigma_kind}; pixel noise alone:",
            f"  {'  (mm)':16}{mm[0]:10.2f}{mm[1]:10.2f}{mm[2]:10.2f}",
            f"  {'  (deg)':16}{deg[0]:10.3f}{deg[1]:10.3f}{deg[2]:10.3f}"]

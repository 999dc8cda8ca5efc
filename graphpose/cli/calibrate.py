"""``graphpose calibrate``: the camera's intrinsics and lens from images of the board.

Turns the arguments into typed values (image files in order, a :class:`Board`, a model
name, an output format), checks every output before the work starts (folders, the ``plot``
extra, whether the format can hold the model), calls :func:`graphpose.calibrate.calibrate`
with a progress bar on stderr, and writes the camera file (:func:`graphpose.io.cameras.write_camera`),
optionally the ``--report`` (alias ``--json``) (:func:`graphpose.io.records.calibration_record`) and the ``--plot`` picture
(:func:`graphpose.viz.calibration.plot_calibration`), and a summary on stdout.

Exit codes: 0 calibrated; 1 the calibration failed (a solver did not converge, or the two
solvers disagree: nothing is written but the report); 2 bad usage or input (fewer than three
images with a board, images of different sizes, views that do not constrain the focal
length, a file that is not an image, ...).
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

import numpy as np

from .._extras import require
from ..camera_models import HELD_MODELS
from ..camera_models import MODELS as CALIBRATION_MODELS
from ..errors import GraphposeError, InputError
from ..io.cameras import FORMATS
from . import HelpFormatter, EXIT_OK, PROG, UsageError, calibrate_extras, exit_codes_help
from ..io.sources import expand_paths
from .options import BOARD_UNITS, Progress, check_output_folder, parse_board, write_json_option
from .recordings import add_view_options, recording_views, views_record, views_text

#: The models ``--model`` takes, and the formats of ``--format``.
MODELS = (*CALIBRATION_MODELS, *HELD_MODELS)

_EXAMPLES = """\
examples:
  graphpose calibrate shots/ --board 9x6x0.03 --out camera.json
  graphpose calibrate left*.jpg --board 9x6x0.03 --model radtan --out left.yml --format opencv \\
      --report report.json --plot calibration.png
  graphpose calibrate fisheye/ --board 8x6x0.0635 --model fisheye --out cam.yaml --format kalibr
  graphpose calibrate left*.jpg --board 9x6x25mm --model radtan4 --out left.camchain.yaml --format kalibr

IMAGES are image files or folders (a folder's image files in name order). --board gives the
inner junctions per row and per column and the square side in metres. The camera file holds
the intrinsics, the lens and the image size; the json format also holds the parameters'
covariance, which 'graphpose estimate --camera FILE' then carries into every pose's sigmas.
Kalibr's radtan keeps four coefficients, so --format kalibr takes --model radtan4 (k1, k2,
p1, p2 with k3 held at 0), pinhole or fisheye.
An image file that cannot be read is named on stderr and left out; the others go on.
""" + exit_codes_help("the calibration failed (solvers not converged or disagreeing)",
                      "bad usage or input (fewer than three images with a board, images of different "
                      "sizes, views that do not constrain the focal length, ...)")


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``calibrate`` subcommand's parser to ``subparsers``."""
    p = subparsers.add_parser(
        "calibrate",
        help="the camera's intrinsics and lens, with their covariance, from images of the board",
        description=textwrap.fill(
            "Calibrate a camera from raw images of the checkerboard: the intrinsics K, the lens "
            "distortion and their covariance, each image's pose and residual. Images without a "
            "board, and images whose residuals do not fit the others, are named and left out.", 88),
        epilog=_EXAMPLES,
        formatter_class=HelpFormatter,
    )
    p.add_argument("images", nargs="*", type=Path, metavar="IMAGES",
                   help="image files, folders of them (name order), quoted globs, list files, or one video or "
                   "ROS bag (its views chosen: --max-views); none with --corners or --rig")
    p.add_argument("--board", type=parse_board, required=True, metavar="COLSxROWSxSQUARE_M",
                   help=f"inner junctions per row and per column, {BOARD_UNITS}")
    p.add_argument("--model", choices=MODELS, default="radtan",
                   help="the lens model: pinhole (none), radtan (OpenCV's k1, k2, p1, p2, k3), radtan4 "
                   "(k1, k2, p1, p2, k3 held at 0: Kalibr's pinhole-radtan) or fisheye (OpenCV's k1..k4); "
                   "default radtan")
    p.add_argument("--out", type=Path, required=True, metavar="CAMERA_FILE",
                   help="the calibrated camera's file (read by 'graphpose estimate --camera')")
    p.add_argument("--format", choices=FORMATS, default="json",
                   help="the camera file's format: graphpose's json (with the covariance; default), "
                   "OpenCV FileStorage YAML, ROS camera_info, Kalibr camchain")
    # dest json (the old name's): other code of the command (--rig) reads args.json.
    p.add_argument("--report", "--json", dest="json", metavar="REPORT.json",
                   help="write the report: the camera, the covariance, the RMS and every image's status, "
                   "message, RMS and pose ('-': stdout, no summary); --json is its old name")
    p.add_argument("--plot", type=Path, metavar="PNG",
                   help="draw the residuals and the coverage and uncertainty map over the image "
                   "(needs the plot extra, matplotlib)")
    p.add_argument("-q", "--quiet", action="store_true", help="no summary on stdout (errors still on stderr)")
    from .rig import add_calibrate_options

    add_calibrate_options(p)
    calibrate_extras.add_options(p)
    add_view_options(p)
    return p


def run(args) -> int:
    """Run ``graphpose calibrate`` with parsed ``args``; returns the exit code."""
    if getattr(args, "rig", None):
        from .rig import run_calibrate

        return run_calibrate(args)
    if not args.images and args.corners is None:
        raise UsageError("give the IMAGES of the board, --corners FILE, or --rig SOURCE0 SOURCE1 ... for a rig")
    from ..calibrate import calibrate
    from ..io.cameras import covariance_note, write_camera
    from ..io.records import calibration_record

    _check_outputs(args)
    calibrate_extras.check(args)
    progress = Progress(2, sys.stderr)
    views = None

    def show(stage, done, total):
        progress.total = max(int(total), 1)
        progress.show(int(done), stage)

    try:
        calibration = calibrate_extras.calibrate_from_args(args, show)
        if calibration is None:
            views = recording_views(args, show)
            files, names = (image_files(args.images), None) if views is None else views[:2]
            calibration = calibrate(files, args.model, board=args.board, names=names or [str(f) for f in files],
                                    progress=show, warp=calibrate_extras.warp_option(args))
    finally:
        progress.clear()
    for name, status, message in zip(calibration.images, calibration.status, calibration.message):
        if status == "unreadable":  # named, and the others went on
            print(f"{PROG} calibrate: warning: {message} (left out)", file=sys.stderr, flush=True)
    record = calibration_record(calibration)
    if views is not None:
        record["views"] = views_record(views[2])
    write_json_option(args.json, record)
    if not calibration.ok:
        raise CalibrationFailed(f"{calibration.summary} (no camera file written)")
    write_camera(args.out, calibration.camera, format=args.format)
    note = covariance_note(calibration.camera, args.format)
    if args.plot is not None:
        from ..viz.calibration import plot_calibration

        plot_calibration(calibration, args.plot, title=f"graphpose calibrate: {args.model}, "
                         f"{calibration.status.count('used')} images")
    extra = calibrate_extras.after(args, calibration)
    if not args.quiet and args.json != "-":
        print(format_summary(calibration, args.out, args.format), flush=True)
        if views is not None:
            print(views_text(views[2]), flush=True)
        calibrate_extras.print_lines(extra, args.quiet)
    if note is not None:
        print(f"graphpose calibrate: note: {note}", file=sys.stderr)
    return EXIT_OK


class CalibrationFailed(GraphposeError):
    """The solvers did not converge or disagree (exit code 1)."""


def _check_outputs(args) -> None:
    """Every output can be written and every option fits, before the work starts."""
    for path, name in ((args.out, "--out"), (args.plot, "--plot"), (args.json, "--report")):
        check_output_folder(path, name)
    if args.format == "kalibr" and args.model == "radtan":
        raise UsageError("--format kalibr cannot hold --model radtan: Kalibr's radtan keeps four coefficients "
                         "(k1, k2, p1, p2) and graphpose's radtan calibrates k3 as well (OpenCV's five), which is "
                         "never dropped; calibrate --model radtan4 (k3 held at 0), or write --format json, opencv "
                         "or ros")
    if args.plot is not None:
        if args.plot.suffix.lower() != ".png":
            raise UsageError(f"--plot: the picture is PNG, so the name must end in .png, got {args.plot}")
        require("matplotlib", "plot", "graphpose calibrate --plot")


def image_files(paths) -> list:
    """The images of IMAGES (:func:`graphpose.io.sources.expand_paths`: files as given, a
    folder's image files in name order, a glob's matches, a list file's paths), each of which
    must exist.

    Raises
    ------
    InputError
        If a path does not exist or a folder holds no image.
    """
    files = expand_paths(paths)
    missing = [path for path in files if not Path(path).is_file()]
    if missing:
        raise InputError(f"image file not found: {missing[0]}")
    return files


#: How each parameter is printed: its unit and format.
_UNITS = {"fx": "px", "fy": "px", "cx": "px", "cy": "px"}


def format_summary(calibration, out, fmt: str) -> str:
    """The readable summary of a calibration (several lines, no trailing newline)."""
    camera = calibration.camera
    status = list(calibration.status)
    counts = {s: status.count(s) for s in ("used", "rejected", "no board", "unreadable")}
    used = [p for p, s in zip(calibration.points, status) if s == "used"]
    junctions = sum(p.shape[1] for p in used)
    rows = [
        f"{camera.model} camera, {camera.size[0]} x {camera.size[1]} pixels, from {len(status)} images: "
        f"{counts['used']} used, {counts['rejected']} rejected, {counts['no board']} without a board"
        + (f", {counts['unreadable']} unreadable" if counts["unreadable"] else ""),
        f"  {'reprojection':16}{calibration.rms_px:.3f} px RMS over {junctions} junctions",
        f"  {'parameter':16}{'value':>14}{'1-sigma':>12}",
    ]
    for name, value, sigma in zip(calibration.parameter_names, calibration.parameters, calibration.sigmas):
        unit = _UNITS.get(name, "")
        rows.append(f"  {name:16}{value:14.6g}{sigma:12.3g} {unit}".rstrip())
    kept = "with the covariance" if fmt == "json" else "without the covariance"
    rows.append(f"  {'camera file':16}{out} ({fmt}, {kept})")
    for name, s, message, rms in zip(calibration.images, status, calibration.message, calibration.image_rms_px):
        figure = f"{rms:.3f} px" if np.isfinite(rms) else ""
        line = f"    {Path(str(name)).name:24} {s:9}{figure:>10}"
        if s != "used" and message:
            line += f"  {' '.join(str(message).split())}"
        rows.append(line.rstrip())
    return "\n".join(rows) + "\n"

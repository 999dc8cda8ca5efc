"""The command line's rig options: ``graphpose calibrate --rig`` and ``graphpose estimate --rig``.

Kept apart from :mod:`graphpose.cli.calibrate` and :mod:`graphpose.cli.estimate` (each adds the
options here and hands the run here when ``--rig`` is given):

- ``graphpose calibrate --rig SOURCE0 SOURCE1 [...] --board ... --out rig.yaml --format
  kalibr|opencv|json [--rig-models M0,M1,...] [--json REPORT] [--plot PNG]``: each SOURCE is one
  camera's images (a folder, a glob in quotes, or an image file), matched across cameras by
  the number in their file names; :func:`graphpose.calibrate.rig.calibrate_rig`, the rig file
  (:mod:`graphpose.io.rig_files`), the report (:func:`rig_record`: each camera's intrinsics and
  RMS, each extrinsic as a baseline in mm and a rotation in degrees with their 1-sigma) and the
  plot (:func:`graphpose.viz.rig.plot_rig`).
- ``graphpose estimate --camera rig.yaml --rig IMAGE0 IMAGE1 [...]``: one image per camera,
  taken together; :func:`graphpose.pipeline_rig.estimate_rig_pose`, camera 0's pose.
- ``graphpose track --camera rig.yaml --rig SOURCE0 SOURCE1 [...] [--tum OUT] [--json OUT]``:
  each frame's rig pose on its own (no motion model or smoothing), in ``track``'s TUM and JSON
  outputs, naming camera 0's pose.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ..errors import InputError
from . import EXIT_OK, UsageError


def add_calibrate_options(p) -> None:
    """``--rig`` and ``--rig-models`` of ``graphpose calibrate``."""
    p.add_argument("--rig", nargs="+", metavar="SOURCE",
                   help="calibrate a rig: one SOURCE per camera (a folder, a quoted glob such as 'left*.jpg', or an "
                   "image), camera 0 first; images are matched by the number in their names (left07 with right07). "
                   "Writes the rig (--format kalibr, opencv for two cameras, or json with the covariance)")
    p.add_argument("--rig-models", metavar="M0,M1,...",
                   help="with --rig: one lens model per camera (e.g. radtan,fisheye); default --model for all")


def add_estimate_options(p) -> None:
    """``--rig`` of ``graphpose estimate``."""
    p.add_argument("--rig", nargs="+", type=Path, metavar="IMAGE",
                   help="the rig's pose: one image per camera of the --camera rig file, taken together (camera 0 "
                   "first); reports camera 0's pose T_WC from every camera's junctions")


def rig_from_file(path, option: str = "--camera"):
    """The :class:`graphpose.rig.Rig` of a rig file, or a UsageError saying it holds one camera."""
    from ..io.cameras import read_camera
    from ..rig import Rig

    if path is None:
        raise UsageError("--rig needs --camera RIG_FILE: the rig's cameras and extrinsics (a Kalibr camchain with "
                         "T_cn_cnm1, an OpenCV stereo file, or graphpose's rig JSON)")
    try:
        rig = read_camera(path)
    except InputError as exc:
        raise InputError(f"{option}: {exc}") from None
    if not isinstance(rig, Rig):
        raise UsageError(f"{option} {path} holds one camera, not a rig: --rig needs a rig file (a Kalibr camchain "
                         "with T_cn_cnm1 between its cameras, an OpenCV stereo file with M1 M2 R T, or graphpose's "
                         "rig JSON, as 'graphpose calibrate --rig' writes)")
    return rig


# --- calibrate --rig ------------------------------------------------------------------------


def run_calibrate(args) -> int:
    """``graphpose calibrate --rig ...``; returns the exit code."""
    from ..calibrate.rig import calibrate_rig
    from ..io.cameras import write_camera
    from ..io.rig_files import RIG_FORMATS
    from .calibrate import CalibrationFailed, _check_outputs
    from .options import Progress, write_json_option

    if args.images:
        raise UsageError("give the images either as IMAGES (one camera) or as --rig SOURCE0 SOURCE1 ... (one source "
                         "per camera), not both")
    if len(args.rig) < 2:
        raise UsageError(f"--rig needs one SOURCE per camera, at least two; got {len(args.rig)}")
    if args.format not in RIG_FORMATS:
        raise UsageError(f"--format {args.format} holds one camera; a rig is written as {', '.join(RIG_FORMATS)}")
    models = args.rig_models.split(",") if args.rig_models else [args.model] * len(args.rig)
    if len(models) != len(args.rig):
        raise UsageError(f"--rig-models must name one model per camera: {len(args.rig)} cameras, {len(models)} models")
    if args.format == "opencv" and len(args.rig) != 2:
        raise UsageError(f"--format opencv is OpenCV's stereo file of two cameras; this rig has {len(args.rig)}: "
                         "write kalibr or json")
    saved = args.model
    for m in models:  # each model against the format, as for one camera
        args.model = m
        _check_outputs(args)
    args.model = saved
    progress = Progress(1, sys.stderr)

    def show(stage, done, total):
        progress.total = max(int(total), 1)
        progress.show(int(done), stage)

    try:
        calibration = calibrate_rig([str(s) for s in args.rig], models, board=args.board, progress=show)
    finally:
        progress.clear()
    record = rig_record(calibration)
    write_json_option(args.json, record)
    if not calibration.ok:
        raise CalibrationFailed(f"{calibration.summary} (no rig file written)")
    write_camera(args.out, calibration.rig, format=args.format)
    if args.plot is not None:
        from ..viz.rig import plot_rig

        plot_rig(calibration, args.plot)
    if not args.quiet and args.json != "-":
        print(format_rig_summary(calibration, args.out, args.format), flush=True)
    return EXIT_OK


def rig_record(calibration) -> dict:
    """The ``--json`` report of a rig calibration, JSON-ready.

    Returns
    -------
    dict
        ``cameras``: per camera ``name``, ``model``, ``K``, ``distortion``, ``size``,
        ``parameters`` (``{name: value}``), ``sigmas`` (the same names), ``rms_px``;
        ``extrinsics``: per camera i >= 1 ``camera``, ``T_C0_C`` (4 x 4, camera i in camera 0's
        frame), ``baseline_mm``, ``baseline_sigma_mm``, ``rotation_deg``, ``rotation_sigma_deg``;
        ``parameter_names`` and ``covariance`` (the joint one); ``rms_px``; ``views``: per view
        ``view``, and per camera ``images``, ``status``, ``message``, ``rms_px``, with the rig's
        pose ``T_WC0`` (null where no camera used the view); ``ok``, ``summary``.
    """
    from ..io.files import to_jsonable

    rig = calibration.rig
    cameras = []
    for c, camera in enumerate(rig.cameras):
        names = camera.parameter_names
        p = calibration.parameters[[calibration.parameter_names.index(f"cam{c}.{n}") for n in names]]
        s = calibration.sigmas[[calibration.parameter_names.index(f"cam{c}.{n}") for n in names]]
        cameras.append({"name": rig.names[c], "model": camera.model, "K": camera.K, "distortion": camera.distortion,
                        "size": list(camera.size), "parameters": dict(zip(names, p.tolist())),
                        "sigmas": dict(zip(names, s.tolist())), "rms_px": float(calibration.camera_rms_px[c])})
    extrinsics = [{"camera": e["camera"], "T_C0_C": rig.T_C0_C[e["camera"]], "baseline_mm": 1000 * e["baseline_m"],
                   "baseline_sigma_mm": 1000 * e["baseline_sigma_m"], "rotation_deg": e["rotation_deg"],
                   "rotation_sigma_deg": e["rotation_sigma_deg"]} for e in calibration.extrinsics()]
    views = []
    for v, name in enumerate(calibration.views):
        rms = [float(x) if np.isfinite(x) else None for x in calibration.view_rms_px[v]]
        views.append({"view": name, "images": list(calibration.images[v]), "status": list(calibration.status[v]),
                      "message": [m or None for m in calibration.message[v]], "rms_px": rms,
                      "T_WC0": calibration.poses[v]})
    return to_jsonable({"cameras": cameras, "extrinsics": extrinsics, "parameter_names": list(calibration.parameter_names),
                        "covariance": calibration.cov, "rms_px": calibration.rms_px, "views": views,
                        "ok": calibration.ok, "summary": calibration.summary})


def format_rig_summary(calibration, out, fmt: str) -> str:
    """The readable summary of a rig calibration (several lines)."""
    rig = calibration.rig
    rows = [calibration.summary]
    for c, camera in enumerate(rig.cameras):
        w, h = camera.size
        rows.append(f"  {rig.names[c]}: {camera.model}, {w} x {h}, fx {camera.fx:.2f} fy {camera.fy:.2f} "
                    f"cx {camera.cx:.2f} cy {camera.cy:.2f} px, RMS {calibration.camera_rms_px[c]:.3f} px")
    for e in calibration.extrinsics():
        rows.append(f"  {rig.names[e['camera']]} from {rig.names[0]}: baseline {1000 * e['baseline_m']:.2f} "
                    f"+- {1000 * e['baseline_sigma_m']:.2f} mm, rotation {e['rotation_deg']:.3f} "
                    f"+- {e['rotation_sigma_deg']:.3f} deg")
    rows.append(f"  rig file: {out} ({fmt}{', with the covariance' if fmt == 'json' else ''})")
    for v, name in enumerate(calibration.views):
        for c in range(len(rig)):
            s = calibration.status[v][c]
            if s in ("rejected", "no board"):
                rows.append(f"    view {name} {rig.names[c]}: {s}: {' '.join(calibration.message[v][c].split())}")
    return "\n".join(rows) + "\n"


# --- estimate --rig -------------------------------------------------------------------------


def run_estimate(args) -> int:
    """``graphpose estimate --camera RIG --rig IMAGE0 IMAGE1 ...``; returns the exit code."""
    from ..pipeline_rig import estimate_rig_pose
    from . import error_line, exit_code
    from .options import check_output_folder, write_json_option

    if args.images or args.cases is not None:
        raise UsageError("--rig takes the rig's images itself (one per camera): give no IMAGES and no --cases")
    if getattr(args, "camera_name", None) is not None:
        raise UsageError("--camera-name picks one camera; --rig uses every camera of the rig file")
    check_output_folder(args.json, "--json")
    rig = rig_from_file(args.camera)
    if len(args.rig) != len(rig):
        raise UsageError(f"--rig needs one image per camera of {args.camera}: it holds {len(rig)} cameras "
                         f"({', '.join(rig.names)}), got {len(args.rig)} images")
    for path in args.rig:
        if not Path(path).is_file():
            raise InputError(f"image not found: {path}")
    from ..board import Board

    board = args.board if args.board is not None else Board()
    estimate = estimate_rig_pose(args.rig, rig, board=board, robust=args.robust)
    record = rig_pose_record(estimate, args.rig, rig, str(args.camera))
    write_json_option(args.json, record)
    if not estimate.ok:
        from .estimate import _NotConverged

        exc = _NotConverged(f"no reliable rig pose: {estimate.message}")
        print(f"graphpose: error: {error_line(exc, '')}", file=sys.stderr)
        return exit_code(exc)
    if not args.quiet and args.json != "-":
        print(format_rig_pose(estimate, args.rig, rig), flush=True)
    return EXIT_OK


def rig_pose_record(estimate, images, rig, camera_file) -> dict:
    """The JSON record of a rig pose: ``T_WC`` (camera 0's pose in the target frame), ``params``,
    ``cov``, ``sigma_xyz_m``, ``sigma_rpy_rad``, ``reprojection_rms_px``, per camera ``cameras``
    (``name``, ``image``, ``status``, ``message``, ``junctions``), ``cross_check``, ``ok``."""
    from ..io.files import to_jsonable

    cams = [{"name": rig.names[c], "image": str(images[c]), "status": estimate.status[c],
             "message": estimate.messages[c] or None, "junctions": int(estimate.residuals[c].shape[1])}
            for c in range(len(rig))]
    return to_jsonable({"camera": camera_file, "pose_of": rig.names[0], "T_WC": estimate.T_WC, "params": estimate.params,
                        "cov": estimate.cov, "sigma_xyz_m": estimate.sigma_xyz_m, "sigma_rpy_rad": estimate.sigma_rpy_rad,
                        "reprojection_rms_px": estimate.rms_px, "cameras": cams,
                        "cross_check": {"translation_m": estimate.cross_check.translation_m,
                                        "rotation_deg": estimate.cross_check.rotation_deg,
                                        "agree": estimate.cross_check.agree},
                        "ok": estimate.ok, "message": estimate.message})


def format_rig_pose(estimate, images, rig) -> str:
    """The readable report of a rig pose."""
    x, y, z = estimate.T_WC[:3, 3]
    sx, sy, sz = estimate.sigma_xyz_m
    r, p, yw = np.degrees(estimate.params[3:])
    sr, sp, syw = np.degrees(estimate.sigma_rpy_rad)
    rows = [f"rig pose ({rig.names[0]} in the target frame, T_WC) from {sum(s == 'used' for s in estimate.status)} "
            f"of {len(rig)} cameras:",
            f"  x {x:.5f} +- {sx:.5f}  y {y:.5f} +- {sy:.5f}  z {z:.5f} +- {sz:.5f} m",
            f"  roll {r:.4f} +- {sr:.4f}  pitch {p:.4f} +- {sp:.4f}  yaw {yw:.4f} +- {syw:.4f} deg",
            f"  reprojection RMS {estimate.rms_px:.3f} px; GN vs GTSAM "
            f"{estimate.cross_check.translation_m:.1e} m, {estimate.cross_check.rotation_deg:.1e} deg"]
    for c in range(len(rig)):
        note = "" if estimate.status[c] == "used" else f": {estimate.messages[c]}"
        rows.append(f"  {rig.names[c]} {Path(str(images[c])).name}: {estimate.status[c]}{note}")
    return "\n".join(rows) + "\n"


# --- track --rig ----------------------------------------------------------------------------


def add_track_options(p) -> None:
    """``--rig`` of ``graphpose track``."""
    p.add_argument("--rig", nargs="+", metavar="SOURCE",
                   help="track a rig: one SOURCE of frames per camera of the --camera rig file (a folder, a quoted "
                   "glob, or a frame), camera 0 first, matched by the number in their names; each frame's rig pose "
                   "(camera 0's T_WC) from every camera at once, frame by frame (no motion model or smoothing)")


def run_track(args) -> int:
    """``graphpose track --camera RIG --rig SOURCE0 SOURCE1 ...``: each frame's rig pose,
    estimated on its own (:func:`graphpose.pipeline_rig.estimate_rig_pose`), written as ``track``
    writes its trajectory (``--tum``: camera 0's pose; ``--json``: a record per frame)."""
    from ..calibrate.frames import file_number, match_frames, source_files
    from ..errors import BoardNotFoundError
    from ..pipeline_rig import estimate_rig_pose
    from ..track.frames import frame_timestamps, read_timestamps
    from . import EXIT_FAILED
    from .options import Progress, check_output_folder
    from ..io.tum import TumStream
    from .track_output import JsonStream, abort_on_error

    if args.frames:
        raise UsageError("--rig takes the rig's frames itself (one SOURCE per camera): give no FRAMES")
    unsupported = [name for name, given in (("--bounds", args.bounds is not None), ("--polygons", args.polygons),
                                            ("--smooth", args.smooth), ("--plot", args.plot), ("--truth", args.truth),
                                            ("--camera-name", getattr(args, "camera_name", None)))
                   if given]
    if unsupported:
        raise UsageError(f"{', '.join(unsupported)}: not available with --rig, which estimates each frame's rig pose "
                         "on its own (no motion model, no smoothing)")
    for path, name in ((args.tum, "--tum"), (args.json, "--json")):
        check_output_folder(path, name)
    rig = rig_from_file(args.camera)
    if len(args.rig) != len(rig):
        raise UsageError(f"--rig needs one SOURCE per camera of {args.camera}: it holds {len(rig)} cameras "
                         f"({', '.join(rig.names)}), got {len(args.rig)}")
    files = [source_files(s, f"--rig source {c}") for c, s in enumerate(args.rig)]
    views = match_frames([[file_number(f) for f in fs] for fs in files])
    timestamps = None if args.timestamps is None else read_timestamps(args.timestamps, len(views))
    seconds = frame_timestamps(timestamps, args.fps, len(views))
    from ..board import Board

    board = args.board if args.board is not None else Board()
    tum = None if args.tum is None else TumStream(args.tum)
    doc = None
    progress = Progress(len(views), sys.stderr)
    found = 0
    with abort_on_error(progress, lambda: (tum, doc)):
        doc = None if args.json is None else JsonStream(args.json)
        for k, group in enumerate(views):
            images = [None if i is None else files[c][i] for c, i in enumerate(group)]
            progress.show(k + 1, next(Path(p).name for p in images if p is not None))
            try:
                est = estimate_rig_pose(images, rig, board=board, robust=args.robust)
                ok = est.ok
            except BoardNotFoundError as exc:
                est, ok, why = None, False, str(exc)
            if ok:
                found += 1
                if tum is not None:
                    tum.add(float(seconds[k]), est.T_WC)
            if doc is not None:
                record = {"index": k, "timestamp": float(seconds[k]), "status": "ok" if ok else "lost"}
                if est is not None:
                    record.update(rig_pose_record(est, images, rig, str(args.camera)))
                else:
                    record.update({"images": [None if p is None else str(p) for p in images], "message": why})
                doc.add(record)
        progress.clear()
        if tum is not None:
            tum.close(f"graphpose track --rig: the rig's pose (camera 0's T_WC in the target frame), each frame on its "
                      f"own; {len(views) - found} lost frames have no line")
        if doc is not None:
            doc.close({"rig": str(args.camera), "pose_of": rig.names[0], "smoothed": False,
                       "board": f"{board.cols}x{board.rows}x{board.square_m}"})
    if not args.quiet and args.json != "-":
        print(f"graphpose track --rig: {found} of {len(views)} frames with the rig's pose ({rig.names[0]}'s T_WC), "
              f"{len(views) - found} lost")
    return EXIT_OK if found else EXIT_FAILED


__all__ = ["add_calibrate_options", "add_estimate_options", "add_track_options", "run_calibrate", "run_estimate",
           "run_track", "rig_record",
           "rig_pose_record", "rig_from_file"]

"""``graphpose calibrate``'s options for other detectors and for judging a calibration:
junctions in and out, cross-validation, and the projection uncertainty in the summary.

Kept apart from :mod:`graphpose.cli.calibrate` (which others edit too), which calls
:func:`add_options`, :func:`check`, :func:`calibrate_from_args` and :func:`after`:

- ``--corners FILE``: calibrate from a corners.vnl (mrcal's) or graphpose's corners JSON
  instead of images (IMAGES then not given); ``--image-size WIDTHxHEIGHT`` gives the images'
  size where the file does not (a corners.vnl), else the first image it names is read for it;
- ``--corners-out FILE``: write every image's junctions as a corners.vnl (``.vnl``) or
  graphpose's JSON (``.json``), :mod:`graphpose.io.corners`;
- ``--cross-validate [PNG]``: calibrate the odd and even used views apart and report their
  projection difference after the fitted rotation beside what their covariances predict
  (:func:`graphpose.calibrate.crossval.cross_validate`), and draw it to PNG if given.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from . import UsageError
from .options import check_output_folder


def parse_size(text: str) -> tuple:
    """``"WIDTHxHEIGHT"`` pixels -> (int, int); ArgumentTypeError otherwise."""
    parts = text.lower().split("x")
    try:
        w, h = (int(p) for p in parts)
        if len(parts) != 2 or w < 1 or h < 1:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels (e.g. 640x480), got {text!r}") from None
    return w, h


def add_options(p: argparse.ArgumentParser) -> None:
    """Add the junction, cross-validation and uncertainty options to the calibrate parser."""
    p.add_argument("--corners", type=Path, metavar="FILE",
                   help="calibrate from another detector's junctions instead of images: mrcal's corners.vnl "
                   "(# filename x y level) or graphpose's corners JSON (--corners-out); IMAGES not given")
    p.add_argument("--image-size", type=parse_size, metavar="WIDTHxHEIGHT",
                   help="with --corners: the images' size in pixels (a corners.vnl does not hold it; default: "
                   "read from the first image the file names)")
    p.add_argument("--corners-out", type=Path, metavar="FILE",
                   help="write every image's junctions as mrcal's corners.vnl (FILE.vnl) or graphpose's JSON "
                   "(FILE.json)")
    p.add_argument("--warp", choices=("auto", "on", "off"), default="auto",
                   help="estimate the board's bending with the camera (mrcal's two-parameter board warp; the "
                   "report gives the sag in mm): auto (default) keeps it where the views constrain it and agree "
                   "on it, on always, off takes the board as flat")
    p.add_argument("--cross-validate", nargs="?", const=True, default=None, metavar="PNG",
                   help="calibrate the odd and even used views apart and report their projection difference "
                   "after the best-fitting rotation (mrcal's projection_diff) beside what their covariances "
                   "predict; with PNG, draw it")


def check(args) -> None:
    """Usage errors of these options, before any work."""
    if getattr(args, "format", None) == "kalibr" and args.model == "rational":
        raise UsageError("--format kalibr cannot hold --model rational: Kalibr has no rational model (its radtan "
                         "keeps k1, k2, p1, p2); write --format json, opencv or ros (rational_polynomial)")
    if args.corners is not None and args.images:
        raise UsageError("give either IMAGES or --corners FILE, not both")
    if args.corners is None and not args.images:
        raise UsageError("give the IMAGES of the board (or --corners FILE)")
    if args.image_size is not None and args.corners is None:
        raise UsageError("--image-size goes with --corners (images give their own size)")
    if args.corners_out is not None:
        check_output_folder(args.corners_out, "--corners-out")
        if args.corners_out.suffix.lower() not in (".vnl", ".json"):
            raise UsageError(f"--corners-out: the file must end in .vnl (mrcal's corners.vnl) or .json, got "
                             f"{args.corners_out}")
    if isinstance(args.cross_validate, str):
        png = Path(args.cross_validate)
        check_output_folder(png, "--cross-validate")
        if png.suffix.lower() != ".png":
            raise UsageError(f"--cross-validate: the picture is PNG, so the name must end in .png, got {png}")
        from .._extras import require

        require("matplotlib", "plot", "graphpose calibrate --cross-validate PNG")


def calibrate_from_args(args, show):
    """The calibration from ``--corners`` (None without it: the caller calibrates the images)."""
    if args.corners is None:
        return None
    from ..calibrate import calibrate_corners
    from ..io.corners import read_corners

    corners = read_corners(args.corners, args.board)
    size = args.image_size or corners.size
    if size is None:
        size = _size_from_images(args.corners, corners.images)
    return calibrate_corners(corners, args.model, board=args.board, size=size, progress=show,
                             warp=warp_option(args))


def warp_option(args):
    """``--warp`` as :func:`graphpose.calibrate.calibrate`'s ``warp``: "auto", True or False."""
    return {"auto": "auto", "on": True, "off": False}[getattr(args, "warp", "auto")]


def _size_from_images(path, names) -> tuple:
    from ..errors import InputError
    from ..image import read_image

    for name in names[:1]:
        for candidate in (Path(name), Path(path).parent / name):
            if candidate.is_file():
                image = read_image(candidate, as_float=False)
                return image.shape[1], image.shape[0]
    raise InputError(f"{path} does not hold the images' size and its first image ({names[0] if names else 'none'}) "
                     "is not found: give --image-size WIDTHxHEIGHT")


def after(args, calibration) -> list:
    """Write ``--corners-out`` and run ``--cross-validate``; the summary's extra lines."""
    lines = []
    if args.corners_out is not None:
        from ..io.corners import write_corners

        write_corners(args.corners_out, calibration.images, calibration.detections, args.board,
                      calibration.camera.size)
        lines.append(f"  {'corners':16}{args.corners_out}")
    if calibration.warp_m is not None:
        lines.append(f"  {'board warp':16}sag {calibration.sag_mm:+.3f} +- {calibration.sag_sigma_mm:.3f} mm at the "
                     f"centre (w_x {1000 * calibration.warp_m[0]:+.3f}, w_y {1000 * calibration.warp_m[1]:+.3f} mm)")
    elif calibration.warp_note is not None:
        lines.append(f"  {'board warp':16}flat (warp auto): {calibration.warp_note}")
    lines += uncertainty_lines(calibration)
    if args.cross_validate is not None:
        from ..calibrate.crossval import cross_validate

        cv = cross_validate(calibration, board=args.board, warp=warp_option(args))
        lines.append(f"  {'cross-validate':16}odd and even views ({cv.halves[0].status.count('used')} + "
                     f"{cv.halves[1].status.count('used')}): projection difference {cv.median_px:.3f} px median "
                     f"after the fitted rotation; their covariances predict {cv.predicted_median_px:.3f} px")
        if isinstance(args.cross_validate, str):
            from ..viz.calibration import plot_cross_validation

            plot_cross_validation(cv, args.cross_validate)
    return lines


def uncertainty_lines(calibration) -> list:
    """The projection uncertainty at the centre and the four corners, at the boards' distance."""
    if calibration.joint_cov is None or not np.all(np.isfinite(calibration.joint_cov)):
        return []
    w, h = calibration.camera.size
    q = np.array([[(w - 1) / 2, 0, w - 1, 0, w - 1], [(h - 1) / 2, 0, 0, h - 1, h - 1]], float)
    s = calibration.projection_uncertainty(q, calibration.board_distance_m).sigma_px
    corners = ", ".join("-" if not np.isfinite(x) else f"{x:.3g}" for x in s[1:])
    return [f"  {'uncertainty':16}{s[0]:.3g} px at the centre, {corners} px at the corners (1-sigma at the boards' "
            f"{calibration.board_distance_m:.2f} m, mrcal's projection uncertainty)"]


def print_lines(lines, quiet: bool) -> None:
    if lines and not quiet:
        print("\n".join(lines), file=sys.stdout, flush=True)

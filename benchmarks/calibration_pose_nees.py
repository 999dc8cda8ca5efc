"""The pose with the calibration's uncertainty: NEES over independent calibrate-then-estimate trials.

    python -m benchmarks.calibration_pose_nees [--quick] [--trials N]

The "pose with calibration uncertainty" figure, for the benchmark's ``calibration``
section (:mod:`benchmarks.calibration` calls :func:`pose_nees`): each trial renders a fresh
calibration set of the radtan camera (:func:`graphpose.synth.calibration.calibration_set`),
calibrates on 8 views (``graphpose.calibrate``), writes the camera file (graphpose JSON, with
the covariance) and reads it back, then estimates the pose of held-out views of the same
camera with it (``estimate_pose``, the sheet outline as bounds: the board is half-turn symmetric). The 6-D pose error against the truth is judged
by the reported covariance (pixel noise and calibration) and by the pixel-noise-only one
(``cov_pixel``): NEES ``e^T cov^-1 e``, 6 on average when the covariance is right (goal 4.5-7.5).
Trials are independent (their own images and calibration); the held-out views of one trial
share its calibration error, so the figure is the mean over trials of each trial's first
held-out view, and the mean over all held-out views is printed beside it.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from benchmarks._common import mean, nees, params_error

#: Views calibrated on, views estimated with the result, trials (full run, --quick).
CALIBRATION_VIEWS = 8
HELD_OUT = 4
TRIALS = (30, 20)


def pose_nees(quick: bool = False, trials: int | None = None, seed: int = 2020) -> dict:
    """Run the trials; returns the figures (see the module docstring).

    Returns
    -------
    dict
        ``trials`` (calibrations that succeeded), ``failed`` and ``why_failed`` (their
        messages), ``nees_first`` and
        ``nees_pixel_first`` (means over the trials' first held-out views), ``nees_all`` and
        ``nees_pixel_all`` (over every held-out view), ``views`` (held-out estimates),
        ``sigma_ratio_z`` (median over the views of the along-axis 1-sigma with the calibration
        over the pixel noise's alone).
    """
    import graphpose
    from graphpose import estimate_pose, read_camera, write_camera
    from graphpose.geometry import params_from_T
    from graphpose.synth.calibration import calibration_set, radtan_camera

    n = trials if trials is not None else TRIALS[1 if quick else 0]
    rng = np.random.default_rng(seed)
    first, first_pixel, every, every_pixel, ratio_z = [], [], [], [], []
    failed, why = 0, []
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "camera.json"
        for _ in range(n):
            views = calibration_set(radtan_camera(), CALIBRATION_VIEWS + HELD_OUT, rng=rng)
            try:
                calibration = graphpose.calibrate(views.images[:CALIBRATION_VIEWS], "radtan", board=views.board)
            except graphpose.GraphposeError as exc:
                failed += 1
                why.append(" ".join(str(exc).split()))
                continue
            if not calibration.ok:
                failed += 1
                why.append(calibration.summary)
                continue
            write_camera(path, calibration.camera)
            camera = read_camera(path)
            for k, rendering in enumerate(views.renderings[CALIBRATION_VIEWS:]):
                try:
                    # The outline names junction 0's corner: the 8 x 6 board is half-turn symmetric.
                    est = estimate_pose(rendering.image, camera, bounds=rendering.outline, board=views.board)
                except graphpose.GraphposeError:
                    continue
                if not est.ok or est.orientation_ambiguous:
                    continue
                e = params_error(params_from_T(est.T_WC), rendering.T_WC)
                full, pixel = nees(est.cov, e), nees(est.cov_pixel, e)
                every.append(full)
                every_pixel.append(pixel)
                ratio_z.append(float(np.sqrt(est.cov[2, 2] / est.cov_pixel[2, 2])))
                if k == 0:
                    first.append(full)
                    first_pixel.append(pixel)
    return {"trials": n - failed, "failed": failed, "why_failed": why, "views": len(every),
            "nees_first": mean(first), "nees_pixel_first": mean(first_pixel),
            "nees_all": mean(every), "nees_pixel_all": mean(every_pixel),
            "sigma_ratio_z": float(np.median(ratio_z)) if ratio_z else float("nan")}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--trials", type=int)
    args = parser.parse_args(argv)
    out = pose_nees(args.quick, args.trials)
    print(f"pose NEES over {out['trials']} trials ({out['failed']} calibrations failed), first held-out view each: "
          f"{out['nees_first']:.2f} with the calibration's covariance (goal 4.5-7.5), "
          f"{out['nees_pixel_first']:.1f} with the pixel noise's alone")
    print(f"over all {out['views']} held-out views: {out['nees_all']:.2f} and {out['nees_pixel_all']:.1f}; "
          f"along-axis 1-sigma with the calibration / pixel noise alone, median {out['sigma_ratio_z']:.2f}")
    for line in out["why_failed"]:
        print(f"  a calibration failed: {line}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

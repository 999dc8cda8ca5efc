"""Calibration benchmark: ``graphpose.calibrate`` beside OpenCV's calibration, on rendered sets
with exact truth and on OpenCV's own samples.

    python -m benchmarks calibration [--quick]      (or python -m benchmarks.calibration [--quick])

Every figure is measured in this run (``--quick``: small sets, to check that it works).
OpenCV (the peer) is imported here only; its corners are its own: ``findChessboardCorners``
(default flags) + ``cornerSubPix`` with ``winSize=(5, 5)`` (an 11 x 11 window, as the other
sections), then ``calibrateCamera`` (five coefficients, OpenCV's defaults) or
``cv2.fisheye.calibrate`` (``CALIB_USE_INTRINSIC_GUESS | CALIB_RECOMPUTE_EXTRINSIC |
CALIB_FIX_SKEW`` from f = width / pi at the image's centre: without a start it diverges on
these images).

Sections
--------
1. Rendered calibration sets (:mod:`graphpose.synth.calibration`; noise 2 grey levels, blur
   1 px, 8 bits): radtan (k1 = -0.3, 640 x 480, 40 views) and fisheye (about 185 degrees,
   1280 x 960, 30 views). For each calibration: the projection error against the true
   camera at the observed junctions: the ray the true camera sees at each junction's exact
   pixel ``u``, projected through the calibrated camera, ``sqrt(mean |cal.project(
   true.unproject(u)) - u|^2)`` over every junction of the views that method used (the same
   camera-frame ray through both, no alignment of the frames, so a principal point off by
   half a pixel counts in full; goal: graphpose at most 0.3 x OpenCV's); the same over the
   whole image (every 8th pixel); the prediction error (each view's junctions predicted
   through the method's own pose of it, against the exact pixels: what the calibration
   reproduces, frame alignment included); and each parameter's error in graphpose's
   reported sigmas (goal: all within 3).
2. Calibration NEES: ``e^T cov^-1 e`` of the intrinsic parameters over 20 independent
   rendered radtan calibrations (20 views each; 3 in ``--quick``); goal: the mean within
   0.7-1.3 x the parameter count (9).
3. OpenCV's samples (``../shared/data/opencv_samples``, 13 left and 13 right raw images, 9 x 6
   junctions, 30 mm): the reprojection RMS (``sqrt(mean(du^2 + dv^2))``, each on its own
   junctions; goal: graphpose at most OpenCV's), the parameters beside OpenCV's and the
   published ones (read from ``left.opencv.yml``, ``right.opencv.xml``); and mrcal's
   cross-validation: graphpose calibrated on the odd and on the even images (their boards
   searched through the whole set's camera: alone, a half finds too few without one), the two
   parameter vectors' difference against what their covariances predict
   (``d^T (C1 + C2)^-1 d``, whose mean would be 9 if the model and the noise were all), and
   the two cameras' projection difference over the image beside its predicted 1-sigma. Each
   with the board warp as ``calibrate`` decides by default (``warp="auto"``, which drops it
   where the views disagree on it), beside it with the warp always estimated (``warp=True``)
   and with a flat board (``warp=False``). The RMS "with the warp" is ``warp=True``'s (radtan
   and rational), beside the views' agreement on the warp (its chi-square).
3b. A bent board (:func:`benchmarks.calibration_uncertainty.bent_board`): 20 rendered radtan
   views of a board with 3 mm of sag (mrcal's warp) and the same poses' flat set: the
   projection error over the image against the true camera, bent with the warp / flat (goal
   <= 1.2), and the sag found against the truth in its sigmas (goal within 2).
4. The pose with the calibration's uncertainty (:mod:`benchmarks.calibration_pose_nees`): over 30
   trials (20 in ``--quick``) calibrate on 8 rendered views, write and read the camera file,
   estimate held-out views; the pose NEES with the covariance that includes the
   calibration's (goal 4.5-7.5) beside the pixel-noise-only one.
5. Speed: 40 rendered radtan images of 640 x 480: ``graphpose.calibrate`` against
   ``findChessboardCornersSB`` on each image + ``calibrateCamera``, wall and process CPU
   seconds (goal: graphpose faster).
"""

from __future__ import annotations

import os
import time

import numpy as np

import graphpose
from benchmarks._common import SAMPLES, T_WC_from_opencv, opencv_classic, opencv_sb, points
from benchmarks.calibration_pose_nees import pose_nees
from benchmarks.calibration_uncertainty import (bent_board, corners_roundtrip, outliers, rendered_nees,
                                                samples_uncertainty)
from graphpose import Board, read_camera
from graphpose.camera_models import MODELS
from graphpose.synth.calibration import calibration_set, fisheye_camera, radtan_camera

SAMPLE_BOARD = Board(9, 6, 0.03)


def _opencv_corners(cv2, image, pattern, sb=False):
    """OpenCV's corners (2, n): findChessboardCorners + cornerSubPix 5 x 5, or the SB detector."""
    return points(opencv_sb(cv2, image, pattern) if sb else opencv_classic(cv2, image, pattern))


def _opencv_calibrate(cv2, images, board, model, size, sb=False):
    """OpenCV's camera, RMS and the used views' corners (list of (index, (2, n)))."""
    pattern = (board.cols, board.rows)
    W = board.world_points().T.astype(np.float64)
    found = [(i, c) for i, c in ((i, _opencv_corners(cv2, im, pattern, sb)) for i, im in enumerate(images))
             if c is not None]
    obj = [W.reshape(1, -1, 3).copy() for _ in found]
    img = [c.T.reshape(1, -1, 2).astype(np.float64).copy() for _, c in found]
    if model == "fisheye":
        # OpenCV 5's names (4.x: cv2.fisheye.CALIB_...). Without a starting K OpenCV's fisheye
        # calibration diverges on these images (RMS > 100 px): it starts from f = width / pi
        # at the image's centre, as a user would be told to.
        flags = cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_RECOMPUTE_EXTRINSIC | cv2.CALIB_FIX_SKEW
        criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
        w, h = size
        K0 = np.array([[w / np.pi, 0.0, 0.5 * w], [0.0, w / np.pi, 0.5 * h], [0.0, 0.0, 1.0]])
        rms, K, D, rvecs, tvecs = cv2.fisheye.calibrate(obj, img, size, K0, np.zeros(4), flags=flags,
                                                         criteria=criteria)
        camera = graphpose.FisheyeCamera(K, D.ravel(), size)
    else:
        rms, K, D, rvecs, tvecs = cv2.calibrateCamera([o.reshape(-1, 3).astype(np.float32) for o in obj],
                                                      [m.reshape(-1, 2).astype(np.float32) for m in img], size,
                                                      None, None)
        camera = graphpose.RadTanCamera(K, D.ravel()[:5], size)
    poses = [T_WC_from_opencv(cv2, rvec, tvec) for rvec, tvec in zip(rvecs, tvecs)]
    return camera, float(rms), [(i, c, T) for (i, c), T in zip(found, poses)]


def _prediction_error(camera, views):
    """RMS |prediction - truth| over views [(T_WC, true pixels (2, n))]: the calibrated camera
    and its own pose of each view against the exact junctions."""
    from graphpose.geometry import to_camera

    W = Board().world_points()
    errors = []
    for T, uv in views:
        p = camera.project(to_camera(T, W))
        # Matched by position: a method's labels may be the renderer's turned half round.
        d = np.hypot(p[0][:, None] - uv[0][None], p[1][:, None] - uv[1][None])
        errors.append(np.nanmin(d, axis=1))
    e = np.concatenate(errors)
    return float(np.sqrt(np.mean(e[np.isfinite(e)] ** 2)))


def _projection_error(camera, truth, uv):
    """RMS |camera.project(truth.unproject(uv)) - uv| over pixels (2, n) of the true camera: the
    same camera-frame ray through both (no alignment of the frames)."""
    rays = truth.unproject(uv)
    d = camera.project(rays) - uv
    ok = np.all(np.isfinite(d), axis=0)
    return float(np.sqrt(np.mean(np.sum(d[:, ok] ** 2, axis=0))))


def _whole_image(camera, step=8):
    w, h = camera.size
    u, v = np.meshgrid(np.arange(0.0, w, step), np.arange(0.0, h, step))
    uv = np.stack([u.ravel(), v.ravel()])
    return uv[:, np.all(np.isfinite(camera.unproject(uv)), axis=0)]


def rendered(cv2, quick):
    """Section 1."""
    out = {}
    for name, camera, views in (("radtan", radtan_camera(), 12 if quick else 40),
                                ("fisheye", fisheye_camera(), 12 if quick else 30)):
        views_set = calibration_set(camera, views, rng=2026)
        t = time.perf_counter()
        cal = graphpose.calibrate(views_set.images, model=camera.model)
        seconds = time.perf_counter() - t
        ours = [(T, r.junctions) for r, s, T in zip(views_set.renderings, cal.status, cal.poses) if s == "used"]
        cv_camera, cv_rms, cv_found = _opencv_calibrate(cv2, views_set.images, views_set.board, camera.model,
                                                       camera.size)
        theirs = [(T, views_set.renderings[i].junctions) for i, _, T in cv_found]
        whole = _whole_image(camera)
        z = (cal.parameters - camera.parameters) / cal.sigmas
        out[name] = {
            "views": views, "graphpose_used": cal.status.count("used"), "opencv_used": len(cv_found),
            "ok": cal.ok, "seconds": seconds, "summary": cal.summary,
            "passes": {m.split(" (")[0]: sum(1 for x in cal.message if x.startswith(m.split(" (")[0]))
                       for m in set(cal.message) if m.startswith("board found")},
            "graphpose_projection_px": _projection_error(cal.camera, camera, np.hstack([uv for _, uv in ours])),
            "opencv_projection_px": _projection_error(cv_camera, camera, np.hstack([uv for _, uv in theirs])),
            "graphpose_prediction_px": _prediction_error(cal.camera, ours),
            "opencv_prediction_px": _prediction_error(cv_camera, theirs),
            "graphpose_projection_whole_px": _projection_error(cal.camera, camera, whole),
            "opencv_projection_whole_px": _projection_error(cv_camera, camera, whole),
            "graphpose_rms_px": cal.rms_px, "opencv_rms_px": cv_rms,
            "z": dict(zip(cal.parameter_names, z.tolist())), "max_abs_z": float(np.max(np.abs(z))),
            "truth": camera.parameters.tolist(), "graphpose": cal.parameters.tolist(),
            "sigmas": cal.sigmas.tolist(), "opencv": cv_camera.parameters.tolist(),
            "cross_check": cal.cross_check.max_difference,
        }
        o = out[name]
        o["ratio"] = o["graphpose_projection_px"] / o["opencv_projection_px"]
    return out


def samples(cv2, quick):
    """Section 3."""
    out = {}
    for side, published in (("left", "left.opencv.yml"), ("right", "right.opencv.xml")):
        files = sorted(SAMPLES.glob(f"{side}*.jpg"))
        images = [graphpose.read_image(f, as_float=False) for f in files]
        size = (images[0].shape[1], images[0].shape[0])
        cal = graphpose.calibrate(files, "radtan", board=SAMPLE_BOARD)
        cv_camera, cv_rms, cv_found = _opencv_calibrate(cv2, images, SAMPLE_BOARD, "radtan", size)
        pub = read_camera(SAMPLES / published)
        extra = samples_uncertainty(files, SAMPLE_BOARD)
        out[side] = {
            "images": len(files), "graphpose_used": cal.status.count("used"), "opencv_used": len(cv_found),
            "ok": cal.ok, "graphpose_rms_px": cal.rms_px, "opencv_rms_px": cv_rms,
            "names": list(cal.parameter_names), "graphpose": cal.parameters.tolist(), "sigmas": cal.sigmas.tolist(),
            "opencv": cv_camera.parameters.tolist(), "published": pub.parameters.tolist(),
            **extra,
        }
    return out


def speed(cv2, quick):
    """Section 4."""
    camera = radtan_camera()
    views = calibration_set(camera, 10 if quick else 40, rng=77)
    images = views.images
    t, c = time.perf_counter(), time.process_time()
    cal = graphpose.calibrate(images)
    g_wall, g_cpu = time.perf_counter() - t, time.process_time() - c
    t, c = time.perf_counter(), time.process_time()
    _, _, found = _opencv_calibrate(cv2, images, views.board, "radtan", camera.size, sb=True)
    o_wall, o_cpu = time.perf_counter() - t, time.process_time() - c
    return {"images": len(images), "graphpose_s": g_wall, "graphpose_cpu_s": g_cpu, "opencv_s": o_wall,
            "opencv_cpu_s": o_cpu, "graphpose_used": cal.status.count("used"), "opencv_used": len(found),
            "ratio": g_wall / o_wall, "cpu_ratio": g_cpu / o_cpu}


def main(quick: bool = False) -> dict:
    """Measure every part; returns the figures, which :func:`section` lays out for :mod:`benchmarks`."""
    import cv2

    started = time.time()
    out = {"quick": quick, "load_average_at_start": list(os.getloadavg()), "opencv": cv2.__version__}
    out["rendered"] = rendered(cv2, quick)
    out["nees"] = rendered_nees(quick)
    out["outliers"] = outliers(quick)
    out["corners"] = corners_roundtrip()
    out["bent"] = bent_board(quick)
    out["samples"] = samples(cv2, quick) if SAMPLES.is_dir() else f"absent: {SAMPLES}"
    out["speed"] = speed(cv2, quick)
    out["pose_nees"] = pose_nees(quick)
    goals = []
    for name in ("radtan", "fisheye"):
        r = out["rendered"][name]
        goals.append({"figure": f"{name}: projection error vs the true camera at the observed junctions", "unit": "px",
                      "graphpose": r["graphpose_projection_px"], "peer": r["opencv_projection_px"],
                      "goal": "<= 0.3 x OpenCV's", "met": bool(r["ratio"] <= 0.3)})
        goals.append({"figure": f"{name}: largest |parameter error| / reported sigma", "unit": "",
                      "graphpose": r["max_abs_z"], "peer": None, "goal": "<= 3", "met": bool(r["max_abs_z"] <= 3)})
    for name in ("radtan", "fisheye"):
        n = out["nees"][name]
        sets = n["sets"] - n["failed"]
        P = n["parameters"]
        goals.append({"figure": f"{name}: projection-uncertainty NEES over a grid at the boards' distance, mean of "
                                f"{sets} sets of {n['views']} views (mrcal's alignment)", "unit": "",
                      "graphpose": n["grid_nees_boards_mean"], "peer": None, "goal": "1.4-2.6 (2 dof)",
                      "met": bool(1.4 <= n["grid_nees_boards_mean"] <= 2.6 and n["failed"] == 0)})
        goals.append({"figure": f"{name}: projection-uncertainty NEES over a grid at infinity (same sets)", "unit": "",
                      "graphpose": n["grid_nees_infinity_mean"], "peer": None, "goal": "1.4-2.6 (2 dof)",
                      "met": bool(1.4 <= n["grid_nees_infinity_mean"] <= 2.6)})
        goals.append({"figure": f"{name}: parameter NEES mean over the same sets ({P} parameters)", "unit": "",
                      "graphpose": n["parameter_nees_mean"], "peer": None,
                      "goal": f"{0.7 * P:.1f}-{1.3 * P:.1f} (0.7-1.3 x {P})",
                      "met": bool(0.7 * P <= n["parameter_nees_mean"] <= 1.3 * P)})
    o = out["outliers"]
    goals.append({"figure": f"outliers: moved junctions flagged ({o['moved']} of {o['junctions']} moved by 2-5 px)",
                  "unit": "", "graphpose": o["fraction_flagged"], "peer": None, "goal": ">= 0.9",
                  "met": bool(o["fraction_flagged"] >= 0.9)})
    goals.append({"figure": "outliers: projection error over the image, with them / clean set", "unit": "",
                  "graphpose": o["ratio"], "peer": None, "goal": "<= 1.2", "met": bool(o["ratio"] <= 1.2)})
    c = out["corners"]
    goals.append({"figure": "corners.vnl written and read back: largest parameter difference from the images' "
                            "calibration, in its sigmas", "unit": "", "graphpose": c["max_abs_difference_sigmas"],
                  "peer": None, "goal": "<= 0.01", "met": bool(c["ok"] and c["max_abs_difference_sigmas"] <= 0.01)})
    bb = out["bent"]
    goals.append({"figure": f"bent board ({bb['sag_true_mm']:g} mm sag, {bb['views']} rendered views): projection "
                            "error over the image vs the truth, bent set with the warp / flat set", "unit": "",
                  "graphpose": bb["ratio"], "peer": None, "goal": "<= 1.2", "met": bool(bb["ok"] and bb["ratio"] <= 1.2)})
    goals.append({"figure": "bent board: (sag found - truth) / its sigma", "unit": "", "graphpose": bb["sag_z"],
                  "peer": None, "goal": "within +-2", "met": bool(abs(bb["sag_z"]) <= 2)})
    pn = out["pose_nees"]
    goals.append({"figure": f"pose NEES with the calibration's covariance over {pn['trials']} trials",
                  "unit": "", "graphpose": pn["nees_first"], "peer": None,
                  "goal": "4.5-7.5 (>= 20 trials)", "met": bool(4.5 <= pn["nees_first"] <= 7.5 and pn["trials"] >= 20)})
    goals.append({"figure": "pose NEES with the pixel noise's covariance alone (same trials)", "unit": "",
                  "graphpose": pn["nees_pixel_first"], "peer": None, "goal": "reference", "met": None})
    if isinstance(out["samples"], dict):
        for side in ("left", "right"):
            s = out["samples"][side]
            goals.append({"figure": f"OpenCV samples {side}: reprojection RMS", "unit": "px",
                          "graphpose": s["graphpose_rms_px"], "peer": s["opencv_rms_px"],
                          "goal": "<= OpenCV's", "met": bool(s["graphpose_rms_px"] <= s["opencv_rms_px"])})
            goals.append({"figure": f"OpenCV samples {side}: projection uncertainty at the centre, at the boards' "
                                    f"median distance ({s['distance_m']:.2f} m)", "unit": "px",
                          "graphpose": s["at_boards_px"][0], "peer": None,
                          "goal": "0.013-0.030 (0.67-1.5 x mrcal's 0.020, left)" if side == "left"
                          else "reference (mrcal: not quoted)",
                          "met": bool(0.0134 <= s["at_boards_px"][0] <= 0.030) if side == "left" else None})
            mrcal_rms = {"left": 0.150, "right": 0.147}[side]
            goals.append({"figure": f"OpenCV samples {side}: reprojection RMS, radtan with the board warp "
                                    f"({'estimated' if s['warp_used'] else 'not constrained: flat'}; warp on)",
                          "unit": "px",
                          "graphpose": s["rms_px"], "peer": None,
                          "goal": f"<= {mrcal_rms} (mrcal's with its warp)",
                          "met": bool(s["rms_px"] <= mrcal_rms)})
            goals.append({"figure": f"OpenCV samples {side}: reprojection RMS with model rational (OpenCV's 8 "
                                    f"coefficients) and the board warp (warp on)", "unit": "px",
                          "graphpose": s["rational_rms_px"], "peer": None,
                          "goal": f"<= {mrcal_rms} (mrcal's with its warp / OPENCV8)",
                          "met": bool(s["rational_rms_px"] <= mrcal_rms)})
            goals.append({"figure": f"OpenCV samples {side}: cross-validation, odd / even images, median projection "
                                    "difference after the fitted rotation (warp auto: the default, "
                                    f"{'kept' if s['auto_warp_used'] else 'flat'})", "unit": "px",
                          "graphpose": s["cross_validation_median_px"], "peer": None,
                          "goal": "<= 0.089 (mrcal's on the same halves)" if side == "left"
                          else "reference", "met": bool(s["cross_validation_median_px"] <= 0.089) if side == "left"
                          else None})
            goals.append({"figure": f"OpenCV samples {side}: the same cross-validation with the warp always estimated "
                                    "(warp on)", "unit": "px", "graphpose": s["cross_validation_warp_median_px"],
                          "peer": None, "goal": "reference", "met": None})
            goals.append({"figure": f"OpenCV samples {side}: the same cross-validation with a flat board (warp off)",
                          "unit": "px", "graphpose": s["cross_validation_flat_median_px"], "peer": None,
                          "goal": "<= 0.089 (mrcal's on the same halves)" if side == "left"
                          else "reference", "met": bool(s["cross_validation_flat_median_px"] <= 0.089)
                          if side == "left" else None})
    sp = out["speed"]
    goals.append({"figure": f"speed: {sp['images']} images of 640 x 480, wall", "unit": "s", "graphpose": sp["graphpose_s"],
                  "peer": sp["opencv_s"], "goal": "< OpenCV (SB + calibrateCamera)", "met": bool(sp["ratio"] < 1)})
    out["goals"] = goals
    out["seconds"] = time.time() - started
    return out


def section(out) -> dict:
    """The figures of :func:`main` as a section of the benchmark (the dict :mod:`benchmarks` describes)."""
    figures = [{"figure": g["figure"], "unit": g["unit"], "fmt": ".3g", "graphpose": g["graphpose"],
                "peer_name": None if g["peer"] is None else "OpenCV", "peer": g["peer"],
                "ratio": None if g["peer"] is None else g["graphpose"] / g["peer"], "goal": g["goal"], "met": g["met"]}
               for g in out["goals"]]
    rows = []
    for name in ("radtan", "fisheye"):
        r = out["rendered"][name]
        rows.append([name, r["views"], r["graphpose_used"], r["opencv_used"], r["graphpose_projection_px"],
                     r["opencv_projection_px"], r["graphpose_projection_whole_px"], r["opencv_projection_whole_px"],
                     r["graphpose_prediction_px"], r["opencv_prediction_px"],
                     r["graphpose_rms_px"], r["opencv_rms_px"], r["max_abs_z"], r["cross_check"]])
    blocks = [{"title": "Rendered calibration sets against the true camera", "text": None, "values": {},
               "columns": ["lens", "views", "graphpose used", "OpenCV used", "graphpose at junctions px",
                           "OpenCV at junctions px", "graphpose whole image px", "OpenCV whole image px",
                           "graphpose prediction px", "OpenCV prediction px",
                           "graphpose RMS px", "OpenCV RMS px", "max abs z", "solvers' difference"],
               "formats": ["", "d", "d", "d", ".4f", ".4f", ".3f", ".3f", ".4f", ".4f", ".4f", ".4f", ".2f", ".1e"],
               "rows": rows}]
    for name in ("radtan", "fisheye"):
        r = out["rendered"][name]
        names = MODELS[name].parameter_names
        blocks.append({"title": f"{name}: parameters (truth, graphpose +- sigma, OpenCV)", "text": None, "values": {},
                       "columns": ["parameter", "truth", "graphpose", "sigma", "z", "OpenCV"],
                       "formats": ["", ".6g", ".6g", ".2g", ".2f", ".6g"],
                       "rows": [[k, r["truth"][i], r["graphpose"][i], r["sigmas"][i], r["z"][k], r["opencv"][i]]
                                for i, k in enumerate(names)]})
    rows = []
    for name in ("radtan", "fisheye"):
        for r in out["nees"][name]["rows"]:
            if r["ok"]:
                rows.append([name, r["seed"], r["used"], r["parameter_nees"], r["grid_nees_boards"],
                             r["grid_nees_infinity"], r["distance_m"], r["grid_sigma_median_px_boards"],
                             r["grid_error_rms_px_boards"], r["centre_sigma_px"], r["centre_error_px"],
                             r["centre_sigma_intrinsics_only_px"], r["sigma_px"]])
            else:
                rows.append([name, r["seed"], 0] + [float("nan")] * 10)
    blocks.append({"title": "Projection uncertainty and parameter NEES on rendered sets",
                   "text": ("Each set calibrated from its rendered images; the projection uncertainty (mrcal's: the camera "
                            "frame tied to the board poses) judged over a 16 x 12 grid covering the image against the "
                            "error after mrcal's alignment (the true camera's point carried into each board's true frame "
                            "and back through the estimated poses' mean), at the boards' median distance and at "
                            "infinity: NEES 2 on average when right; the parameter NEES P (9 radtan, 8 fisheye). Beside "
                            "them the centre's 1-sigma and actual error at the boards' distance, and the intrinsics-only "
                            "figure at the centre."),
                   "values": {}, "columns": ["lens", "seed", "used", "parameter NEES", "grid NEES boards",
                                             "grid NEES infinity", "distance m", "median sigma px", "grid error RMS px",
                                             "centre sigma px", "centre error px", "centre intrinsics-only px",
                                             "pixel sigma px"],
                   "formats": ["", "d", "d", ".2f", ".2f", ".2f", ".2f", ".4f", ".4f", ".4f", ".4f", ".3f", ".4f"],
                   "rows": rows})
    o = out["outliers"]
    blocks.append({"title": "Single outliers",
                   "text": ("{moved} of the {junctions} junctions of a rendered radtan set moved by 2-5 px in random "
                            "directions, calibrated from the corners: {caught} of them flagged ({flagged} flagged in all, "
                            "{rejected} images rejected); projection error over the image against the truth {bad:.4f} px, "
                            "the same junctions unmoved {clean:.4f} px. A message: \"{example}\"."),
                   "values": {"moved": o["moved"], "junctions": o["junctions"], "caught": o["flagged_of_moved"],
                              "flagged": o["flagged_total"], "rejected": o["images_rejected"],
                              "bad": o["outlier_projection_px"], "clean": o["clean_projection_px"],
                              "example": o["message_example"]}, "columns": [], "formats": [], "rows": []})
    bb = out["bent"]
    blocks.append({"title": "A bent board",
                   "text": ("{n} rendered radtan views of a board bent by mrcal's warp, {true:g} mm of sag at its centre "
                            "(half along each axis), and the same poses' flat set. With the warp: sag {sag:.3f} +- "
                            "{sd:.3f} mm (z {z:+.2f}); projection error over the image against the true camera "
                            "{bent:.4f} px, the flat set's {flat:.4f} px (its sag {fsag:+.3f} +- {fsd:.3f} mm). The bent "
                            "set calibrated as flat (warp off): {asflat:.3f} px, RMS {asflat_rms:.3f} px against "
                            "{bent_rms:.3f} px with the warp."),
                   "values": {"n": bb["views"], "true": bb["sag_true_mm"], "sag": bb["sag_mm"], "sd": bb["sag_sigma_mm"],
                              "z": bb["sag_z"], "bent": bb["bent_projection_px"], "flat": bb["flat_projection_px"],
                              "fsag": bb["flat_set_sag_mm"] if bb["flat_set_sag_mm"] is not None else float("nan"),
                              "fsd": bb["flat_set_sag_sigma_mm"] if bb["flat_set_sag_sigma_mm"] is not None
                              else float("nan"),
                              "asflat": bb["bent_as_flat_projection_px"], "asflat_rms": bb["bent_as_flat_rms_px"],
                              "bent_rms": bb["bent_rms_px"]},
                   "columns": [], "formats": [], "rows": []})
    if isinstance(out["samples"], dict):
        for side in ("left", "right"):
            s = out["samples"][side]
            blocks.append({
                "title": f"OpenCV samples, {side}: {s['images']} images",
                "text": ("graphpose RMS {g:.3f} px on {gu} images ({out} junctions left out as outliers), OpenCV "
                         "calibrateCamera {o:.3f} px on {ou}. Projection uncertainty (1-sigma, worst direction) at the "
                         "centre and the four corners (upper left, upper right, lower left, lower right) at the boards' "
                         "median distance {d:.2f} m: {b}; at infinity: {f}; intrinsics only: "
                         "{p}. Cross-validation (odd and even images, {h0} + {h1} used, calibrated apart): d^T (C1 + C2)^-1 "
                         "d = {m:.1f} (9 if the noise were all); their projections differ by {cv:.3f} px median over the "
                         "image after the best-fitting rotation (mrcal's projection_diff), against {cp:.3f} px predicted "
                         "by their covariances; the default (warp auto) {auto}, RMS {arms:.3f} px. Board warp always "
                         "estimated (warp on): sag {sag} mm (halves {hsag}), the views' agreement on it chi-square "
                         "{chi:.1f} for {dof} dof, RMS {wrms:.3f} px (rational {wrat:.3f}), cross-validation {wcv:.3f} "
                         "px against {wcp:.3f} predicted; with a flat board (warp off): RMS {frms:.3f} px (rational "
                         "{frat:.3f}), cross-validation {fcv:.3f} px against {fcp:.3f} predicted."),
                "values": {"g": s["graphpose_rms_px"], "gu": s["graphpose_used"], "o": s["opencv_rms_px"],
                           "ou": s["opencv_used"], "m": s["halves_mahalanobis"], "out": s["outliers"],
                           "d": s["distance_m"], "b": ", ".join(f"{x:.3f}" for x in s["at_boards_px"]),
                           "f": ", ".join(f"{x:.3f}" for x in s["at_infinity_px"]),
                           "p": ", ".join(f"{x:.3f}" for x in s["intrinsics_only_px"]),
                           "h0": s["halves_used"][0], "h1": s["halves_used"][1],
                           "cv": s["cross_validation_median_px"], "cp": s["cross_validation_predicted_median_px"],
                           "sag": "flat" if s["sag_mm"] is None else f"{s['sag_mm']:+.3f} +- {s['sag_sigma_mm']:.3f}",
                           "hsag": ", ".join("flat" if x is None else f"{x:+.3f}" for x in s["halves_sag_mm"]),
                           "frms": s["flat_rms_px"], "frat": s["rational_flat_rms_px"],
                           "auto": "kept the warp" if s["auto_warp_used"] else "took the board as flat",
                           "arms": s["auto_rms_px"], "chi": s["warp_agreement_chi2"], "dof": s["warp_agreement_dof"],
                           "wrms": s["rms_px"], "wrat": s["rational_rms_px"],
                           "wcv": s["cross_validation_warp_median_px"],
                           "wcp": s["cross_validation_warp_predicted_median_px"],
                           "fcv": s["cross_validation_flat_median_px"],
                           "fcp": s["cross_validation_flat_predicted_median_px"]},
                "columns": ["parameter", "graphpose", "sigma", "OpenCV", "published", "halves z"],
                "formats": ["", ".6g", ".2g", ".6g", ".6g", ".2f"],
                "rows": [[k, s["graphpose"][i], s["sigmas"][i], s["opencv"][i], s["published"][i], s["halves_z"][i]]
                         for i, k in enumerate(s["names"])]})
    pn = out["pose_nees"]
    blocks.append({"title": "The pose with the calibration's uncertainty",
                   "text": ("{trials} trials ({failed} calibrations failed): calibrate on 8 rendered views, write and "
                            "read the camera file, estimate held-out views of the same camera "
                            "(benchmarks/calibration_pose_nees.py). Pose NEES of each trial's first held-out view: "
                            "{full:.2f} with the covariance that includes the calibration's, {pixel:.1f} with the "
                            "pixel noise's alone; over all {views} held-out views {full_all:.2f} and {pixel_all:.1f}; "
                            "the along-axis 1-sigma grows {ratio:.1f} times with the calibration's share."),
                   "values": {"trials": pn["trials"], "failed": pn["failed"], "full": pn["nees_first"],
                              "pixel": pn["nees_pixel_first"], "views": pn["views"], "full_all": pn["nees_all"],
                              "pixel_all": pn["nees_pixel_all"], "ratio": pn["sigma_ratio_z"]},
                   "columns": [], "formats": [], "rows": []})
    sp = out["speed"]
    blocks.append({"title": "Speed", "text": ("{images} rendered images of 640 x 480: graphpose.calibrate {g:.2f} s wall "
                                              "({gc:.2f} s CPU), OpenCV findChessboardCornersSB + calibrateCamera "
                                              "{o:.2f} s ({oc:.2f} s CPU)."),
                   "values": {"images": sp["images"], "g": sp["graphpose_s"], "gc": sp["graphpose_cpu_s"],
                              "o": sp["opencv_s"], "oc": sp["opencv_cpu_s"]}, "columns": [], "formats": [], "rows": []})
    goal = ("Calibration: graphpose.calibrate on rendered raw images of two lenses with exact truth and on "
            "OpenCV's samples, beside OpenCV's calibrateCamera / fisheye.calibrate on its own corners; the reported "
            "covariance judged by the parameters' errors (z, NEES) and by two disjoint halves.")
    return {"goal": goal, "figures": figures, "blocks": blocks}


if __name__ == "__main__":
    import sys

    from benchmarks.cli import main as bench_main

    sys.exit(bench_main(["calibration", *sys.argv[1:]]))

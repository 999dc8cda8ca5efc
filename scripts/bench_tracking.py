#!/usr/bin/env python
"""Tracking benchmark: a synthetic hand-held sequence, graphpose's tracker beside OpenCV per frame.

Run through ``python scripts/bench.py tracking [--quick]`` or directly. Every figure is measured
in this run. OpenCV (the peer) is imported here only.

1. Render a sequence with :func:`graphpose.render_sequence` (noise 2, blur 1, board centre
   0.6-1.3 m away, motion blur on fast frames, whip pans that throw the board out of view):
   300 frames (quick: 120).
2. Track it with :func:`graphpose.track_sequence` (frames in memory, smoothing on), and run
   OpenCV on every frame independently: findChessboardCorners + cornerSubPix 11 x 11 +
   solvePnP(IPPE) + solvePnPRefineLM. OpenCV's corners are matched to the true junctions by
   proximity (the benefit of the doubt on its 180-degree ordering ambiguity).
3. ATE: RMSE of the position error (mm) and of the rotation angle error (deg) against the true
   trajectory. Both trajectories are camera poses in the target frame, the frame the truth is
   in, so no alignment (no Umeyama/SE(3) fit) is applied: the errors are absolute.
4. Lost frames: every frame with the board out of view must be lost; recovery after each pan.
5. Speed: per-frame front end (junctions + single-frame fit) + back end (the frame's factors,
   iSAM2 update, marginal), median, against OpenCV's per-frame time on the SAME frames (those
   both found); and, like for like with OpenCV's per-frame detection, graphpose's single-frame
   pipeline without tracking on those frames (extract_junctions over the whole image,
   pose_from_homography, gauss_newton; quick: every third of them). Back-end time at frame 10
   and at the last frame (single values and medians of 11-frame windows). Then the tracked frames' junctions replayed into
   each back-end form (resection, landmarks, frame_landmarks) with each motion prior
   (constant_velocity, random_walk, wnoa): median
   and growth of the back-end time, batch smoothing time, and the poses' agreement with the
   resection form.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def _opencv_pose(cv2, image, K, truth_uv, Wpts):
    """OpenCV on one frame: (T_WC or None, seconds)."""
    start = time.perf_counter()
    ok, corners = cv2.findChessboardCorners(image, (8, 6), flags=cv2.CALIB_CB_ADAPTIVE_THRESH)
    if not ok:
        return None, time.perf_counter() - start
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-4)
    corners = cv2.cornerSubPix(image, corners, (5, 5), (-1, -1), criteria).reshape(-1, 2)
    obj = np.ascontiguousarray(Wpts.T, dtype=np.float64)
    elapsed = time.perf_counter() - start
    order = np.argmin(np.linalg.norm(truth_uv[:, :, None] - corners.T[:, None, :], axis=0), axis=1)
    if len(set(order.tolist())) != Wpts.shape[1]:
        return None, elapsed
    img = np.ascontiguousarray(corners[order], dtype=np.float64)
    start = time.perf_counter()
    _, rvec, tvec = cv2.solvePnP(obj, img, K, None, flags=cv2.SOLVEPNP_IPPE)
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, K, None, rvec, tvec)
    elapsed += time.perf_counter() - start
    R, _ = cv2.Rodrigues(rvec)
    T = np.eye(4)
    T[:3, :3] = R.T  # OpenCV gives the target-to-camera transform
    T[:3, 3] = -R.T @ tvec.ravel()
    return T, elapsed


def _errors(P, truth):
    """Position error (mm) and rotation angle error (deg) per frame; NaN where P is NaN."""
    d = np.linalg.norm(P[:, :3, 3] - truth[:, :3, 3], axis=1) * 1000
    R = np.einsum("kji,kjl->kil", P[:, :3, :3], truth[:, :3, :3])
    cos = np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1, 1)
    return d, np.rad2deg(np.arccos(cos))


def _rmse(x, mask):
    return float(np.sqrt(np.mean(x[mask] ** 2))) if mask.any() else float("nan")


def _median(x, mask):
    """Median of ``x[mask]``; NaN (printed as nan) for an empty selection, without a warning."""
    return float(np.median(x[mask])) if np.any(mask) else float("nan")


def _single_frame_times(images, K, board, frames):
    """graphpose on each chosen frame alone, as OpenCV runs: (ms (m,), found (m,) bool)."""
    from graphpose.detect.junctions import extract_junctions
    from graphpose.errors import BoardNotFoundError, InputError
    from graphpose.pose.gauss_newton import gauss_newton
    from graphpose.pose.homography import pose_from_homography

    W = board.world_points()
    ms, ok = np.full(len(frames), np.nan), np.zeros(len(frames), dtype=bool)
    for i, k in enumerate(frames):
        h, w = images[k].shape
        whole = np.array([[0.0, w - 1.0, w - 1.0, 0.0], [0.0, 0.0, h - 1.0, h - 1.0]])
        start = time.perf_counter()
        try:
            J = extract_junctions(images[k], whole, board)
            use = J.trusted
            T0 = pose_from_homography(K, J.points[:, use], W[:, use])
            ok[i] = gauss_newton(K, T0, J.points[:, use], W[:, use]).converged
        except (BoardNotFoundError, InputError):
            pass
        ms[i] = (time.perf_counter() - start) * 1000
    return ms, ok


def main(quick: bool = False) -> None:
    import cv2

    from graphpose import Board, K_from_params, project, render_sequence, track_sequence
    from graphpose.track.tracker import LOST, TrackerConfig

    K = K_from_params(564.9, 564.3, 337.3, 226.5)
    board = Board()
    W = board.world_points()
    n = 120 if quick else 300
    start = time.perf_counter()
    seq = render_sequence(K, n, rng=0, excursions=1 if quick else 2, noise_sigma=2.0, blur_sigma=1.0,
                          distance=(0.6, 1.3))
    centre = W.mean(axis=1)
    dist = np.linalg.norm(seq.T_WC[:, :3, 3] - centre, axis=1)
    print(f"sequence: {n} frames 640x480 at {seq.fps:.0f} fps, noise 2, blur 1, board centre "
          f"{dist.min():.2f}-{dist.max():.2f} m away; {int((seq.subframes > 1).sum())} frames with motion "
          f"blur (up to {seq.subframes.max()} sub-frames); {int(seq.out_of_view.sum())} frames with the "
          f"board out of view, {int((~seq.in_view & ~seq.out_of_view).sum())} partly out "
          f"(rendered in {time.perf_counter() - start:.0f} s)\n")

    track = track_sequence(seq.images, K, seq.bounds, timestamps=seq.timestamps, smooth=True)
    found = track.found
    cv_poses = np.full((n, 4, 4), np.nan)
    cv_times = []
    for k in range(n):
        T, seconds = _opencv_pose(cv2, seq.images[k], K, project(K, seq.T_WC[k], W), W)
        cv_times.append(seconds)
        if T is not None:
            cv_poses[k] = T
    cv_found = ~np.isnan(cv_poses[:, 0, 0])
    both = found & cv_found

    # ------------------------------------------------------------------ accuracy
    rows = [("graphpose tracker, online (iSAM2)", track.poses("online"), found),
            ("graphpose tracker, smoothed (batch)", track.poses("smoothed"), found),
            ("graphpose single-frame fits", track.poses("single"), found),
            ("OpenCV per frame", cv_poses, cv_found)]
    print("ATE against the true trajectory (no alignment: all poses are in the target frame)")
    print(f"{'':38s} {'frames':>7s} {'all its frames':>22s} {'frames both found':>22s}")
    print(f"{'':38s} {'':>7s} {'mm':>10s} {'deg':>11s} {'mm':>10s} {'deg':>11s}")
    ate = {}
    for name, P, mask in rows:
        d, a = _errors(P, seq.T_WC)
        ate[name] = (_rmse(d, both), _rmse(a, both))
        print(f"{name:38s} {int(mask.sum()):7d} {_rmse(d, mask):10.4f} {_rmse(a, mask):11.5f} "
              f"{_rmse(d, both):10.4f} {_rmse(a, both):11.5f}")
    ours, peer = ate["graphpose tracker, smoothed (batch)"], ate["OpenCV per frame"]
    online = ate["graphpose tracker, online (iSAM2)"]
    print(f"ratio OpenCV / graphpose on the {int(both.sum())} common frames: translation "
          f"{peer[0] / ours[0]:.2f}x (online {peer[0] / online[0]:.2f}x), rotation {peer[1] / ours[1]:.2f}x "
          f"(online {peer[1] / online[1]:.2f}x)")
    single = ate["graphpose single-frame fits"]
    print(f"smoothing: single-frame {single[0]:.4f} mm / {single[1]:.5f} deg -> online {online[0]:.4f} mm / "
          f"{online[1]:.5f} deg -> smoothed {ours[0]:.4f} mm / {ours[1]:.5f} deg "
          f"({100 * (1 - ours[0] / single[0]):.0f} % / {100 * (1 - ours[1] / single[1]):.0f} % lower)\n")

    # ------------------------------------------------------------- lost frames
    status = track.status
    out = np.flatnonzero(seq.out_of_view)
    print(f"out-of-view frames: {out.size}, reported lost: {int(np.sum(status[out] == LOST))}; frames "
          f"lost in all: {int(np.sum(status == LOST))} (the rest are partly out of view or heavily blurred); "
          f"status counts: " + ", ".join(f"{s} {int(np.sum(status == s))}" for s in ("tracked", "detected", "lost")))
    runs = np.split(out, np.flatnonzero(np.diff(out) > 1) + 1) if out.size else []
    for i, run in enumerate(runs):
        later = np.arange(n) > run[-1]
        back = np.flatnonzero(later & seq.in_view)
        first = np.flatnonzero(later & found)
        if back.size and first.size:
            # Until the board next starts to leave the view (or the end).
            end = runs[i + 1][0] if i + 1 < len(runs) else n
            while end > first[0] and not seq.in_view[end - 1]:
                end -= 1
            print(f"  pan out of view at frames {run[0]}-{run[-1]}: board fully back at frame {back[0]}, "
                  f"pose again at frame {first[0]} ({status[first[0]]}); frames {first[0]}-{end - 1} "
                  f"(board in view): {int(np.sum(status[first[0]:end] == LOST))} lost")
        else:
            print(f"  pan out of view at frames {run[0]}-{run[-1]}: no pose after it")
    print(f"missing frames with the whole board in view: graphpose {int(np.sum(seq.in_view & ~found))}, "
          f"OpenCV {int(np.sum(seq.in_view & ~cv_found))}\n")

    # ------------------------------------------------------------------- speed
    frames = [f for f in track.frames if f.status != LOST]
    cv_ms = np.array(cv_times) * 1000
    ours_ms = np.array([f.frontend_s + f.update_s for f in track.frames]) * 1000
    is_tracked = status == "tracked"
    front = _median(np.array([f.frontend_s for f in track.frames]) * 1000, is_tracked)
    back = _median(np.array([f.update_s for f in track.frames]) * 1000, found)
    print(f"speed per frame (median, ms): graphpose tracked frames {_median(ours_ms, is_tracked):.2f} (front "
          f"end {front:.2f} + back end {back:.2f}); all frames with a pose {_median(ours_ms, found):.2f}; "
          f"OpenCV on its {int(cv_found.sum())} frames {_median(cv_ms, cv_found):.2f}")
    for name, mask in (("tracked by graphpose", is_tracked & cv_found), ("with a graphpose pose", both)):
        ours_m, cv_m = _median(ours_ms, mask), _median(cv_ms, mask)
        print(f"  same {int(mask.sum())} frames {name} and found by OpenCV: graphpose {ours_m:.2f}, "
              f"OpenCV {cv_m:.2f} (ratio OpenCV / graphpose {cv_m / ours_m:.2f}x)")
    sample = np.flatnonzero(both)[::3 if quick else 1]
    single_ms, single_ok = _single_frame_times(seq.images, K, board, sample)
    ok = sample[single_ok]
    print(f"  single-frame pipeline, no tracking (whole-image extraction + homography + Gauss-Newton), "
          f"{sample.size} of those frames ({int(single_ok.sum())} found): graphpose {_median(single_ms, single_ok):.2f}, "
          f"OpenCV {_median(cv_ms, np.isin(np.arange(n), ok)):.2f} on the frames both found "
          f"(ratio OpenCV / graphpose {_median(cv_ms, np.isin(np.arange(n), ok)) / _median(single_ms, single_ok):.2f}x)")
    config = TrackerConfig()
    print(_update_times(f"back end as tracked ({config.target}, {config.motion.model})",
                        [(f.index, f.update_s) for f in frames]))
    _compare_forms(K, board, frames)


def _compare_forms(K, board, frames):
    """The tracked frames' junctions replayed into each back-end form and motion prior."""
    from graphpose.track.tracker import (
        MOTION_MODELS,
        TARGET_FORMS,
        MotionPrior,
        SequenceGraph,
    )

    print("\nback-end forms, the same junctions replayed (pixel sigma 0.05; update = factors + iSAM2 + "
          "marginal, ms; poses against resection with the same motion prior):")
    for model in MOTION_MODELS:
        reference = None
        for target in TARGET_FORMS:
            graph = SequenceGraph(K, board, MotionPrior(model), target=target)
            times, poses = [], []
            for f in frames:
                if f.status == "detected":
                    graph.break_segment()
                r = graph.add_frame(f.index, f.timestamp, f.points, f.ids, f.single_T_WC, 0.05)
                times.append((f.index, r.update_s))
                poses.append(r.T_WC)
            start = time.perf_counter()
            smoothed = graph.smooth()
            smooth_s = time.perf_counter() - start
            online = np.array(poses)
            batch = np.array([smoothed[f.index].T_WC for f in frames])
            if reference is None:
                reference, agree = (online, batch), "reference"
            else:
                d_on = np.max(np.linalg.norm(online[:, :3, 3] - reference[0][:, :3, 3], axis=1)) * 1e6
                d_sm = np.max(np.linalg.norm(batch[:, :3, 3] - reference[1][:, :3, 3], axis=1)) * 1e6
                agree = f"max |dt| online {d_on:.3f} um, smoothed {d_sm:.4f} um"
            ms = np.array([s for _, s in times]) * 1000
            print(f"  {target:15s} {model:17s} median {np.median(ms):5.2f}; {_update_times('', times, short=True)}; "
                  f"batch smoothing {smooth_s:.2f} s; {agree}")


def _update_times(name, times, short=False):
    idx = np.array([k for k, _ in times])
    ms = np.array([s for _, s in times]) * 1000
    if idx.size == 0:
        return f"{name}: no frame with a pose" if not short else "no frame with a pose"
    early = _median(ms, (idx >= 5) & (idx <= 15))  # NaN when no frame of 5-15 has a pose
    late = np.median(ms[-11:])
    window = (f"frames 5-15 {early:.2f} -> frames {idx[-11:][0]}-{idx[-1]} {late:.2f} "
              f"(ratio {late / early:.2f})")
    if short:
        return window
    at10 = ms[np.argmin(np.abs(idx - 10))]
    return (f"{name}: frame 10 {at10:.2f} ms, frame {idx[-1]} {ms[-1]:.2f} ms (ratio {ms[-1] / at10:.2f}); "
            f"medians of 11-frame windows: {window} ms")


if __name__ == "__main__":
    sys.path.insert(0, str(REPO))
    main(quick="--quick" in sys.argv)

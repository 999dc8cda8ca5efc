#!/usr/bin/env python
"""Junction benchmark: graphpose beside OpenCV on the same images, every figure measured here.

Run through ``python scripts/bench.py junctions [--quick]`` or directly. OpenCV (the peer)
is imported here only.

Sections
--------
1. Real images (../shared/data/rob501): RMS and median reprojection residual of a pinhole pose
   (graphpose.pose.gauss_newton.pose_estimate_nls with the known K, from the case guess) fitted to
   our 48 junctions, beside the same for OpenCV ``findChessboardCornersSB`` with
   ``CALIB_CB_ACCURACY`` (its corners matched to ours by nearest neighbour).
2. Synthetic images (graphpose.synth.render, random poses like the real ones, loose polygons,
   half of them inside the white margin): RMS and median junction error against the exact
   truth for ours, ``cornerSubPix`` (11 x 11, started from the truth rounded to whole
   pixels), ``findChessboardCornersSB``
   (CALIB_CB_ACCURACY; on the images where it finds the board) and the Cramer-Rao bound
   ``sqrt(mean_j trace(inv FIM_j))`` from the noise-free render's derivatives, both for the
   square window containing our refinement disc (half-width 12 px; the disc is smaller, so
   this bound is optimistic for us) and for 11 x 11 (cornerSubPix's window).
3. Speed: median wall time over the six real images of ``extract_junctions`` (image in memory,
   polygon given) and of ``findChessboardCornersSB`` twice: on the whole image (how each tool
   is used: SB takes no polygon) and on the polygon's bounding box plus ``CROP_MARGIN`` px (the
   closer peer), with both ratios and whether SB found the board in the box.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data" / "rob501"
#: The real camera; synthetic images use it too.
K_REAL = np.array([[564.9, 0.0, 337.3], [0.0, 564.3, 226.5], [0.0, 0.0, 1.0]])
SETTINGS = ((2.0, 1.0), (6.0, 2.0))  # (noise sigma in grey levels, blur sigma in px)
#: Pixels added around the polygon's bounding box when SB is timed on the crop.
CROP_MARGIN = 10


def _median_time(fn, repeats):
    fn()  # warm up caches and lazy imports
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def _opencv_sb(cv2, image8, board):
    """findChessboardCornersSB corners as (2, n), or None when it fails."""
    # ACCURACY alone: the setting behind the figures (adding NORMALIZE_IMAGE is
    # worse on these images and misses target 02).
    found, corners = cv2.findChessboardCornersSB(image8, (board.cols, board.rows), flags=cv2.CALIB_CB_ACCURACY)
    return corners.reshape(-1, 2).T.astype(float) if found else None


def _match(points, reference):
    """Columns of ``points`` reordered to the nearest column of ``reference``, or None."""
    d = np.hypot(reference[0][:, None] - points[0][None, :], reference[1][:, None] - points[1][None, :])
    order = np.argmin(d, axis=1)
    if len(set(order.tolist())) != points.shape[1] or d[np.arange(len(order)), order].max() > 3.0:
        return None
    return points[:, order]


def _pose_residuals(K, guess, points, board):
    """Reprojection residual lengths (n,) in pixels of a pinhole pose fitted to ``points``."""
    from graphpose.camera import project
    from graphpose.pose.gauss_newton import pose_estimate_nls

    W = board.world_points()
    T = pose_estimate_nls(K, guess, points, W)
    return np.hypot(*(project(K, T, W) - points))


def _rms(x):
    return float(np.sqrt(np.mean(np.square(x)))) if len(x) else float("nan")


def _median(x):
    return float(np.median(x)) if len(x) else float("nan")


def real_images(cv2):
    from graphpose import extract_junctions, load_cases, read_image

    cases = load_cases(DATA / "cases.json")
    print("### Real images: reprojection residual of a pinhole pose fitted to the junctions (px)\n")
    print("| image | ours RMS | ours median | OpenCV SB (ACCURACY) RMS | SB median | ours / SB (RMS) "
          "| ours / SB (median) | trusted |")
    print("|---|---|---|---|---|---|---|---|")
    for case in cases.cases:
        image = read_image(case.image)
        image8 = np.rint(image * 255).astype(np.uint8)
        J = extract_junctions(image8, case.bounds, cases.board)
        ours = _pose_residuals(cases.K, case.guess_T_WC, J.points, cases.board)
        sb = _opencv_sb(cv2, image8, cases.board)
        sb = None if sb is None else _match(sb, J.points)
        theirs = np.array([]) if sb is None else _pose_residuals(cases.K, case.guess_T_WC, sb, cases.board)
        print(f"| {case.image.name} | {_rms(ours):.3f} | {_median(ours):.3f} | {_rms(theirs):.3f} "
              f"| {_median(theirs):.3f} | {_rms(ours) / _rms(theirs):.2f} | {_median(ours) / _median(theirs):.2f} "
              f"| {int(J.trusted.sum())}/{cases.board.n} |")
    print()


def synthetic(cv2, count):
    from graphpose import Board, extract_junctions
    from graphpose.detect.refine import MAX_RADIUS
    from graphpose.synth.render import (
        junction_information,
        loose_polygon,
        random_pose,
        render,
    )

    board = Board()
    half = int(np.ceil(MAX_RADIUS))
    print(f"### Synthetic images: junction error against the truth (px), {count} images per setting\n")
    print("RMS:\n")
    print("| noise, blur | ours | cornerSubPix 11x11 | SB (found/all) | ours on SB's images | "
          f"CRB {2 * half + 1}x{2 * half + 1} | CRB 11x11 | ours / cornerSubPix | ours / SB | "
          f"ours / CRB {2 * half + 1}x{2 * half + 1} |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-4)
    medians = []
    for noise, blur in SETTINGS:
        rng = np.random.default_rng(2024)
        ours, subpix, sb, ours_sb, crb, crb11 = [], [], [], [], [], []
        for k in range(count):
            T = random_pose(rng, K_REAL, board)
            R = render(K_REAL, T, board, noise_sigma=noise, blur_sigma=blur, rng=rng)
            poly = loose_polygon(R, rng, inset=bool(k % 2))
            J = extract_junctions(R.image, poly, board)
            err = np.hypot(*(J.points - R.junctions))
            ours.append(err)
            # cornerSubPix starts from the truth rounded to whole pixels (within 0.71 px): a start
            # at least as good as any detector's, independent of our extraction.
            start = np.ascontiguousarray(np.rint(R.junctions).T, dtype=np.float32).reshape(-1, 1, 2)
            refined = cv2.cornerSubPix(R.image, start, (5, 5), (-1, -1), criteria)
            subpix.append(np.hypot(*(refined.reshape(-1, 2).T - R.junctions)))
            corners = _opencv_sb(cv2, R.image, board)
            corners = None if corners is None else _match(corners, R.junctions)
            if corners is not None:
                sb.append(np.hypot(*(corners - R.junctions)))
                ours_sb.append(err)
            # Quantisation adds 1/12 grey level^2 of noise to every pixel.
            sigma = np.sqrt(noise**2 + 1.0 / 12.0)
            for out, hw in ((crb, half), (crb11, 5)):
                fim = junction_information(K_REAL, T, board, half_width=hw, noise_sigma=sigma, blur_sigma=blur)
                out.append(np.sqrt(np.trace(np.linalg.inv(fim), axis1=1, axis2=2)))

        def flat(errs):
            return np.concatenate(errs) if errs else np.array([])

        o, c, s_, os_, b, b11 = (_rms(flat(e)) for e in (ours, subpix, sb, ours_sb, crb, crb11))
        print(f"| {noise:g}, {blur:g} | {o:.4f} | {c:.4f} | {s_:.4f} ({len(sb)}/{count}) | {os_:.4f} | "
              f"{b:.4f} | {b11:.4f} | {o / c:.2f} | {os_ / s_:.2f} | {o / b:.2f} |")
        medians.append((noise, blur, *(_median(flat(e)) for e in (ours, subpix, sb, ours_sb)), len(sb)))
    print("\nMedian (same junctions):\n")
    print("| noise, blur | ours | cornerSubPix 11x11 | SB (found/all) | ours on SB's images | ours / cornerSubPix "
          "| ours / SB |")
    print("|---|---|---|---|---|---|---|")
    for noise, blur, o, c, s_, os_, found in medians:
        print(f"| {noise:g}, {blur:g} | {o:.4f} | {c:.4f} | {s_:.4f} ({found}/{count}) | {os_:.4f} | {o / c:.2f} "
              f"| {os_ / s_:.2f} |")
    print()


def _crop(image, polygon, margin):
    """The polygon's bounding box grown by ``margin`` px, clipped to the image, and its (col, row) origin."""
    polygon = np.asarray(polygon, dtype=float)
    c0, r0 = np.maximum(np.floor(polygon.min(axis=1)).astype(int) - margin, 0)
    c1, r1 = np.ceil(polygon.max(axis=1)).astype(int) + margin + 1
    return np.ascontiguousarray(image[r0:r1, c0:c1]), np.array([[c0], [r0]], dtype=float)


def speed(cv2, repeats):
    from graphpose import extract_junctions, load_cases, read_image

    cases = load_cases(DATA / "cases.json")
    ours, whole, crop, found = [], [], [], []
    for case in cases.cases:
        image8 = np.rint(read_image(case.image) * 255).astype(np.uint8)
        part, origin = _crop(image8, case.bounds, CROP_MARGIN)
        ours.append(_median_time(lambda: extract_junctions(image8, case.bounds, cases.board), repeats))
        whole.append(_median_time(lambda: _opencv_sb(cv2, image8, cases.board), max(3, repeats // 10)))
        crop.append(_median_time(lambda: _opencv_sb(cv2, part, cases.board), max(3, repeats // 10)))
        # Found means all 48 corners within 3 px of ours, not merely SB's own flag.
        corners = _opencv_sb(cv2, part, cases.board)
        points = extract_junctions(image8, case.bounds, cases.board).points
        found.append(corners is not None and _match(corners + origin, points) is not None)
    o, w, c = (1000 * np.median(t) for t in (ours, whole, crop))
    print("### Speed: one 640 x 480 image in memory (median ms over the six real images)\n")
    print("extract_junctions is given the board's polygon. findChessboardCornersSB is timed twice: on the "
          "whole image, which is how each tool is used (SB takes no polygon and searches everything), and on "
          f"the polygon's bounding box plus {CROP_MARGIN} px, the closer peer (roughly the region ours is "
          "given). The times include failed searches.\n")
    print(f"| extract_junctions (polygon given) | SB, whole image | SB whole / ours | SB, bounding box + {CROP_MARGIN} px "
          "| SB box / ours | SB found the board in the box |")
    print("|---|---|---|---|---|---|")
    print(f"| {o:.1f} | {w:.1f} | {w / o:.1f} | {c:.1f} | {c / o:.1f} | {sum(found)}/{len(found)} |")
    print("\nPer image (ms, ours / SB whole / SB box, * where SB missed the board in the box): " + ", ".join(
        f"{1000 * a:.1f}/{1000 * b:.0f}/{1000 * d:.0f}{'' if f else '*'}"
        for a, b, d, f in zip(ours, whole, crop, found)))
    print()


def main(quick: bool = False) -> None:
    import cv2

    if (DATA / "cases.json").is_file():
        real_images(cv2)
    else:
        print(f"(real images absent: {DATA})\n")
    synthetic(cv2, 8 if quick else 50)
    if (DATA / "cases.json").is_file():
        speed(cv2, 20 if quick else 100)


if __name__ == "__main__":
    main(quick="--quick" in sys.argv[1:])

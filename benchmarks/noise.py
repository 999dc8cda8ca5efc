"""Noise benchmark: boards found under noise, blur, low contrast, motion, shot noise and JPEG, beside OpenCV.

Rendered 640 x 480 images with exact truth (``graphpose.synth.render_degraded``), random poses
(tilts to 40 degrees, in-plane rotations to 40 degrees) of three boards (8 x 6, 7 x 5, 9 x 6),
squares of 25 to 50 px (40 px at most for 9 x 6, whose sheet must fit), the same poses in every
cell. The cells:

- a grid of additive noise sigma {0, 3, 6, 9, 12, 16} grey levels x optical Gaussian blur sigma
  {0.5, 1, 2, 3, 4} px;
- rows for low contrast (black 100, white 135, noise 6), motion blur (4 px during the exposure,
  sub-frame renders), shot noise (1 grey level per electron, read noise 2), JPEG (quality 50,
  noise 3), defocus (a 3 px disc, noise 3) and a dark image (a fifth of the exposure, shot and
  read noise, amplified 5 x, vignetting 40 %), blur 1 px unless said;
- uneven light: 1280 x 720 images of boards with squares of 60-80 px (8 x 6),
  80-100 (7 x 5) and 100-120 (6 x 4), lit by a lamp over one corner junction so that the light
  falls to a quarter at the opposite one (:func:`falling_light`, the cos^4 law), a dark
  exposure with shot and read noise brightened by a gain, JPEG 90: "noise 2" (read noise 1.5,
  exposure 0.4) and "noise 5" (read noise 4, exposure 0.3), blur 1 px; tilts to 30 degrees and
  in-plane rotations to 5 (the sheet of 100-120 px squares fills most of the image's height).

Every image is rendered once and given, 8-bit, to each tool:

- graphpose: ``extract_junctions(image, polygon, board)`` with a loose polygon
  (``loose_polygon``, half of them inside the white margin) and without (``None``);
- OpenCV classic: ``findChessboardCorners`` (default flags) + ``cornerSubPix`` (11 x 11 window),
  and ``findChessboardCornersSB`` (``CALIB_CB_ACCURACY``), as the detect section (:mod:`benchmarks.detect`)
  calls them.

A result is *found* when its junctions (graphpose's trusted ones; all of OpenCV's) lie within
``TOLERANCE_PX`` of the truth in their labelled order; anything else returned is wrong: *off*
when the labels are right (each junction nearest its own true junction) but a junction lies
beyond the tolerance, else *mislabelled*.
graphpose with a polygon must name junction 0 where the polygon's vertex 0 is; without, a
board symmetry's relabelling counts as right (as in the detect section). OpenCV names no
junction 0: its order is compared with the truth and with the truth turned by half a turn.
Junction RMS is over the found results; the ratio of graphpose's RMS to cornerSubPix's is on
the images both found. Times are medians per image (OpenCV single-threaded; failures
included).

Run it as a section of the benchmark: ``python -m benchmarks noise [--quick]`` (or
``python -m benchmarks.noise [--quick]``, the same).
"""

from __future__ import annotations

import sys

import numpy as np

from benchmarks._common import K_REAL as K
from benchmarks._common import rms, scaled_K
from benchmarks.detect import best_errors, run_opencv, run_ours, symmetries
from graphpose import Board
from graphpose.synth import Degradation, degrade, motion_blur_ideal, vignette
from graphpose.synth.poses import loose_polygon, random_pose
from graphpose.synth.render import render, render_ideal
from graphpose.track.frontend import board_symmetries

SIZE = (640, 480)
#: Boards and the range of their squares' side in the image, pixels.
BOARDS = ((Board(8, 6, 0.0635), (25.0, 50.0)), (Board(7, 5, 0.05), (25.0, 50.0)), (Board(9, 6, 0.03), (25.0, 40.0)))
NOISE = (0.0, 3.0, 6.0, 9.0, 12.0, 16.0)
BLUR = (0.5, 1.0, 2.0, 3.0, 4.0)
#: The rows beside the grid: name -> (optical blur sigma, scene grey levels or None, degradation).
ROWS = {
    "low contrast (100-135), noise 6": (1.0, {"black": 100.0, "white": 135.0, "background": 118.0},
                                        Degradation(noise_sigma=6.0)),
    "motion blur 4 px, noise 3": (1.0, None, Degradation(noise_sigma=3.0, motion_px=4.0)),
    "shot noise (gain 1), read noise 2": (1.0, None, Degradation(noise_sigma=2.0, shot_gain=1.0)),
    "JPEG quality 50, noise 3": (1.0, None, Degradation(noise_sigma=3.0, jpeg_quality=50)),
    "defocus disc 3 px, noise 3": (0.5, None, Degradation(noise_sigma=3.0, defocus_px=3.0)),
    "dark: exposure 0.2, gain 5, vignetting 0.4": (1.0, None, Degradation(noise_sigma=1.0, shot_gain=0.25,
                                                                          exposure=0.2, vignetting=0.4)),
}
#: Uneven light (a dark, noisy 1280 x 720 image of a plain board with squares of about
#: 90 px, the light falling to a quarter across it): boards and their squares' range (px);
#: boards large enough for the squares' range whose sheet fits the image.
UNEVEN_SIZE = (1280, 720)
UNEVEN_BANDS = ((Board(8, 6, 0.0635), (60.0, 80.0)), (Board(7, 5, 0.0635), (80.0, 100.0)),
                (Board(6, 4, 0.0635), (100.0, 120.0)))
#: ... their noise: a dark exposure brightened by a digital gain, with shot and read noise, JPEG.
UNEVEN_NOISE = {"noise 2": Degradation(noise_sigma=1.5, shot_gain=0.3, exposure=0.4, jpeg_quality=90),
                "noise 5": Degradation(noise_sigma=4.0, shot_gain=0.5, exposure=0.3, jpeg_quality=90)}
#: ... and the light at the board's far corner junction, a fraction of the light at its near one.
UNEVEN_TO = 0.25
TOOLS = ("graphpose, polygon", "graphpose, no polygon", "OpenCV classic", "OpenCV SB")
#: A found board's junctions lie within this distance of the truth, pixels.
TOLERANCE_PX = 2.0
SEED = 16


def poses(count: int, rng) -> list:
    """``count`` (board, T_WC, truth Rendering, polygon), cycling through the boards."""
    out = []
    for k in range(count):
        board, (lo, hi) = BOARDS[k % len(BOARDS)]
        depth = K[0, 0] * board.square_m / rng.uniform(lo, hi)
        T = random_pose(K, board, SIZE, distance=(depth, depth), max_tilt_deg=40.0, max_roll_deg=40.0, rng=rng)
        R = render(K, T, board, SIZE, noise_sigma=0.0, quantize=False, blur_sigma=0.0)  # the truth only
        out.append((board, T, R, loose_polygon(R, inset=bool(k % 2), rng=rng)))
    return out


def uneven_scenes(count: int, rng) -> dict:
    """Per square band of :data:`UNEVEN_BANDS`: ``count`` (board, noise-free image lit unevenly
    (:func:`falling_light`), truth Rendering, polygon) at 1280 x 720, random poses."""
    K2 = scaled_K(UNEVEN_SIZE)
    out = {}
    for board, (lo, hi) in UNEVEN_BANDS:
        rows = []
        for k in range(count):
            depth = K2[0, 0] * board.square_m / rng.uniform(lo, hi)
            T = random_pose(K2, board, UNEVEN_SIZE, distance=(depth, depth), max_tilt_deg=30.0, max_roll_deg=5.0,
                            margin=0.15, rng=rng)
            R = render(K2, T, board, UNEVEN_SIZE, noise_sigma=0.0, quantize=False, blur_sigma=0.0, margin=0.15)
            ideal = render_ideal(K2, T, board, UNEVEN_SIZE, blur_sigma=1.0, margin=0.15)
            corners = R.junctions[:, [0, board.cols - 1, board.n - 1, board.n - board.cols]]
            near = int(rng.integers(4))
            lit = falling_light(ideal, corners[:, near], corners[:, (near + 2) % 4], UNEVEN_TO)
            rows.append((board, lit, R, loose_polygon(R, inset=bool(k % 2), rng=rng)))
        out[f"{lo:g}-{hi:g}"] = rows
    return out


def falling_light(image, bright, dark, to: float) -> np.ndarray:
    """``image`` lit by a lamp over the point ``bright`` (u, v): the cos^4 law about it
    (:func:`graphpose.synth.vignette`), the light at ``dark`` the fraction ``to`` of that at
    ``bright``."""
    bright = np.asarray(bright, dtype=float)
    h, w = np.shape(image)
    d2 = float(np.sum((np.asarray(dark, dtype=float) - bright) ** 2))
    corner2 = max((x - bright[0]) ** 2 + (y - bright[1]) ** 2 for x in (0, w - 1) for y in (0, h - 1))
    inv_f2 = (to ** -0.5 - 1.0) / d2  # (1 + d2 / f^2)^-2 == to
    return vignette(image, 1.0 - (1.0 + corner2 * inv_f2) ** -2, centre=bright)


def score(result, truth, orders):
    """(verdict, errors px of the junctions scored) of one result: verdict "found", "off" (labelled
    right, each junction nearest its own truth, but one beyond ``TOLERANCE_PX``), "mislabelled", or
    None when the tool refused; errors only for "found"."""
    if result is None:
        return None, None
    points, trusted = result
    err = best_errors(points, trusted, truth, orders)
    if err.size and err.max() <= TOLERANCE_PX:
        return "found", err
    if err.size:
        perm = min(orders, key=lambda p: np.hypot(*(points[:, trusted] - truth[:, p[trusted]])).max())
        d = np.hypot(truth[0][None, :] - points[0][trusted][:, None], truth[1][None, :] - points[1][trusted][:, None])
        if np.array_equal(np.argmin(d, axis=1), perm[trusted]):
            return "off", None
    return "mislabelled", None


def run_tools(cv2, image, board, polygon, truth) -> dict:
    """Every tool on one 8-bit image: {tool: (verdict or None, errors or None, seconds)} (:func:`score`)."""
    calls = {
        "graphpose, polygon": (lambda: run_ours(image, board, polygon), [np.arange(board.n)]),
        "graphpose, no polygon": (lambda: run_ours(image, board), symmetries(board)),
        "OpenCV classic": (lambda: run_opencv(cv2, image, board, sb=False), board_symmetries(board)),
        "OpenCV SB": (lambda: run_opencv(cv2, image, board, sb=True), board_symmetries(board)),
    }
    out = {}
    for tool, (call, orders) in calls.items():
        result, dt = call()
        verdict, err = score(result, truth, orders)
        out[tool] = (verdict, err, dt)
    return out


def _rms(errors) -> float:
    """RMS over every junction of the results' errors (None: a result without errors)."""
    errors = [e for e in errors if e is not None]
    return rms(np.concatenate(errors)) if errors else float("nan")


def summarise(results) -> dict:
    """One cell's figures from its per-image tool results."""
    cell = {"images": len(results)}
    for tool in TOOLS:
        rows = [r[tool] for r in results]
        cell[tool] = {v: sum(f == v for f, _, _ in rows) for v in ("found", "off", "mislabelled")}
        cell[tool]["rms"] = _rms([e for f, e, _ in rows if f == "found"])
        cell[tool]["ms"] = 1e3 * float(np.median([t for _, _, t in rows]))
    for tool in TOOLS[:2]:
        both = [r for r in results if r[tool][0] == "found" and r["OpenCV classic"][0] == "found"]
        ours, theirs = _rms([r[tool][1] for r in both]), _rms([r["OpenCV classic"][1] for r in both])
        cell[tool]["both"] = len(both)
        cell[tool]["ratio"] = ours / theirs if both else float("nan")
    return cell


def measure(count: int, progress=None) -> dict:
    """Every cell's figures: {cell name: summary}, the grid's first, in order."""
    import cv2

    cv2.setNumThreads(1)
    rng = np.random.default_rng(SEED)
    scenes = poses(count, rng)
    ideal = {}  # (blur, levels name) -> the noise-free images of every pose

    def ideal_images(blur, levels=None):
        key = (blur, None if levels is None else tuple(sorted(levels.items())))
        if key not in ideal:
            ideal[key] = [render_ideal(K, T, board, SIZE, blur_sigma=blur, **(levels or {}))
                          for board, T, _, _ in scenes]
        return ideal[key]

    cells = {}
    uneven = uneven_scenes(count, np.random.default_rng([SEED, 26]))
    for band, scenes_band in uneven.items():
        for noise_name, degradation in UNEVEN_NOISE.items():
            name = f"uneven light to {UNEVEN_TO:g}, squares {band} px, {noise_name}, 1280 x 720"
            noise_rng = np.random.default_rng([SEED, 26, len(cells)])
            results = [run_tools(cv2, degrade(lit, degradation, rng=noise_rng), board, polygon, R.junctions)
                       for board, lit, R, polygon in scenes_band]
            cells[name] = summarise(results)
            if progress is not None:
                progress(name, cells[name])
    plan = [(f"noise {n:g}, blur {b:g}", b, None, Degradation(noise_sigma=n)) for b in BLUR for n in NOISE]
    plan += [(name, b, levels, d) for name, (b, levels, d) in ROWS.items()]
    for index, (name, blur, levels, degradation) in enumerate(plan):
        noise_rng = np.random.default_rng([SEED, index])
        results = []
        for k, (board, T, R, polygon) in enumerate(scenes):
            if degradation.motion_px > 0:
                angle = float(noise_rng.uniform(0.0, 180.0))
                base = motion_blur_ideal(K, T, board, SIZE, motion_px=degradation.motion_px, angle_deg=angle,
                                         subframe_px=degradation.subframe_px, blur_sigma=blur)
            else:
                base = ideal_images(blur, levels)[k]
            image = degrade(base, degradation, rng=noise_rng)
            results.append(run_tools(cv2, image, board, polygon, R.junctions))
        cells[name] = summarise(results)
        if progress is not None:
            progress(name, cells[name])
    return cells


def _grid_name(noise, blur) -> str:
    return f"noise {noise:g}, blur {blur:g}"


def main(quick: bool = False) -> dict:
    """Measure the section; returns its goal, headline figures and detail blocks (:mod:`benchmarks`)."""
    count = 4 if quick else 30
    cells = measure(count, progress=lambda name, c: print(
        f"noise: {name}: found " + " / ".join(str(c[t]["found"]) for t in TOOLS), file=sys.stderr, flush=True))
    names = list(cells)
    margin = {tool: min(c[tool]["found"] - max(c["OpenCV classic"]["found"], c["OpenCV SB"]["found"])
                        for c in cells.values()) for tool in TOOLS[:2]}
    worst_cell = {tool: min(names, key=lambda n: cells[n][tool]["found"]
                            - max(cells[n]["OpenCV classic"]["found"], cells[n]["OpenCV SB"]["found"]))
                  for tool in TOOLS[:2]}
    wrong = {tool: sum(c[tool]["mislabelled"] + c[tool]["off"] for c in cells.values()) for tool in TOOLS}
    ratios = [(c[tool]["ratio"], n, tool) for n, c in cells.items() for tool in TOOLS[:2]
              if np.isfinite(c[tool]["ratio"])]
    worst_ratio = max(ratios) if ratios else (float("nan"), "none", "")
    times = {tool: float(np.median([c[tool]["ms"] for c in cells.values()])) for tool in TOOLS}
    best_peer = lambda c: max(c["OpenCV classic"]["found"], c["OpenCV SB"]["found"])  # noqa: E731
    figures = []
    for tool in TOOLS[:2]:
        figures.append({
            "figure": f"worst cell: boards found by {tool} minus the better of classic and SB ({count} images a cell; "
                      f"{worst_cell[tool]})",
            "unit": "", "fmt": "d", "graphpose": margin[tool], "peer_name": "better of classic and SB",
            "peer": best_peer(cells[worst_cell[tool]]), "ratio": None, "goal": ">= 0", "met": margin[tool] >= 0})
    figures += [
        {"figure": f"mislabelled (or a junction over {TOLERANCE_PX:g} px off) results, all {len(cells)} cells, "
                   "with and without a polygon", "unit": "", "fmt": "d",
         "graphpose": wrong[TOOLS[0]] + wrong[TOOLS[1]], "peer_name": "OpenCV classic + SB",
         "peer": wrong["OpenCV classic"] + wrong["OpenCV SB"], "ratio": None, "goal": "0",
         "met": wrong[TOOLS[0]] + wrong[TOOLS[1]] == 0},
        {"figure": f"worst junction RMS ratio to cornerSubPix on the images both found ({worst_ratio[1]}, "
                   f"{worst_ratio[2]})", "unit": "", "fmt": ".2f", "graphpose": worst_ratio[0],
         "peer_name": None, "peer": None, "ratio": None, "goal": "<= 0.6",
         "met": bool(worst_ratio[0] <= 0.6) if np.isfinite(worst_ratio[0]) else None},
        {"figure": "find time per image, median over the cells' medians, polygon given", "unit": "ms", "fmt": ".1f",
         "graphpose": times[TOOLS[0]], "peer_name": "OpenCV classic", "peer": times["OpenCV classic"],
         "ratio": times[TOOLS[0]] / times["OpenCV classic"], "goal": "", "met": None},
        {"figure": "find time per image, median over the cells' medians, no polygon", "unit": "ms", "fmt": ".1f",
         "graphpose": times[TOOLS[1]], "peer_name": "OpenCV SB", "peer": times["OpenCV SB"],
         "ratio": times[TOOLS[1]] / times["OpenCV SB"], "goal": "", "met": None},
    ]
    short = ("polygon", "no polygon", "classic", "SB")
    grid_rows = [[f"{n:g}"] + [" / ".join(str(cells[_grid_name(n, b)][t]["found"]) for t in TOOLS) for b in BLUR]
                 for n in NOISE]
    found_rows = [[n, c["images"]] + [c[t]["found"] for t in TOOLS]
                  + [f"{c[t]['mislabelled']} / {c[t]['off']}" for t in TOOLS] for n, c in cells.items()]
    rms_rows = [[n] + [c[t]["rms"] for t in TOOLS] + [c[t]["both"] for t in TOOLS[:2]]
                + [c[t]["ratio"] for t in TOOLS[:2]] for n, c in cells.items()]
    time_rows = [[n] + [c[t]["ms"] for t in TOOLS] for n, c in cells.items()]
    blocks = [
        {"title": f"Boards found, noise sigma (rows, grey levels) x blur sigma (columns, px), {count} images a cell",
         "text": "Each cell: graphpose with a polygon / graphpose without / OpenCV classic / OpenCV SB.",
         "values": {}, "columns": ["noise"] + [f"blur {b:g}" for b in BLUR], "formats": [""] * (len(BLUR) + 1),
         "rows": grid_rows},
        {"title": "Found and wrong, every cell",
         "text": "Wrong results as mislabelled / off: off is labelled right (every junction nearest its own true "
                 "junction) with a junction more than {tol:g} px from it, as cornerSubPix's 11 x 11 window does "
                 "under a wide blur.", "values": {"tol": TOLERANCE_PX},
         "columns": ["cell", "images"] + [f"found: {s}" for s in short] + [f"wrong: {s}" for s in short],
         "formats": ["", "d"] + ["d"] * 4 + [""] * 4, "rows": found_rows},
        {"title": "Junction RMS against the truth (px), on the found results",
         "text": "graphpose's trusted junctions, all of OpenCV's. The ratio is graphpose's RMS over cornerSubPix's on "
                 "the images both graphpose and classic found (their count beside it).",
         "values": {}, "columns": ["cell"] + [f"RMS {s}" for s in short] + ["both: polygon", "both: no polygon",
                                                                           "ratio: polygon", "ratio: no polygon"],
         "formats": ["", ".4f", ".4f", ".4f", ".4f", "d", "d", ".2f", ".2f"], "rows": rms_rows},
        {"title": "Median time per image (ms), failures included", "text": None, "values": {},
         "columns": ["cell"] + list(short), "formats": ["", ".1f", ".1f", ".1f", ".1f"], "rows": time_rows},
    ]
    goal = (f"Find the board under noise, blur, low contrast, motion, shot noise, JPEG, defocus and low light: "
            f"{count} rendered 640 x 480 images a cell (boards 8 x 6, 7 x 5 and 9 x 6, squares of 25 to 50 px, "
            "random poses; the same poses in every cell), each rendered once and given, 8-bit, to graphpose "
            "(with a loose polygon and without) and to OpenCV (findChessboardCorners + cornerSubPix 11 x 11; "
            "findChessboardCornersSB with CALIB_CB_ACCURACY). Found: the junctions lie within "
            f"{TOLERANCE_PX:g} px of the truth in their labelled order (graphpose's trusted ones; OpenCV's, "
            "which name no junction 0, in its order or turned by half a turn); anything else returned is "
            "wrong (mislabelled, or off: labelled right with a junction too far). Goals: in every cell at least the better of classic and SB, with and without "
            "a polygon; 0 wrong; junction RMS at most 0.6 x cornerSubPix's wherever both find the board.")
    return {"goal": goal, "figures": figures, "blocks": blocks}


if __name__ == "__main__":
    from benchmarks.cli import main as bench_main

    sys.exit(bench_main(["noise", *sys.argv[1:]]))

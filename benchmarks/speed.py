"""Speed benchmark: image file to cross-checked pose with covariance, beside OpenCV's classic chain.

What ``graphpose estimate`` does for one image, timed from the file on disk:
``read_image(path, as_float=False)`` (8-bit grey straight from the decoder), the size check,
``estimate_pose`` (junctions, the homography start, Gauss-Newton, the GTSAM graph from
Gauss-Newton's answer with its marginal covariance, the cross-check). The peer is OpenCV's
classic chain from the same file: ``imread`` (grey), ``findChessboardCorners`` (default
flags), ``cornerSubPix`` (11 x 11), ``solvePnP`` (IPPE) and ``solvePnPRefineLM``: OpenCV's default flags, as its calibration
sample uses them; one pose, without a covariance or a second solver. Both
run single-threaded (``cv2.setNumThreads(1)``), each image timed several times in turn
with the other tool, medians over the repeats and then over the images.

Cases: the six real 640 x 480 images of ``../shared/data/rob501`` (when present) and
rendered 640 x 480 images (``graphpose.synth``, written as PNG), with their polygons and
without; rendered 4032 x 3024 (12 MP) images written as JPEG, as a phone writes them, with
the peak memory of each tool on them (:mod:`benchmarks.memory_probe`: each in a fresh process,
after a warm-up on a small image, the resident set's peak while it handles the image over its
size before; the peak is reset first through ``/proc/self/clear_refs``), for graphpose both as
a library user calls it (``graphpose.read_image`` with its default, then ``estimate_pose``: the
goal's figure) and as ``graphpose estimate`` reads the file (8-bit). In memory, on the same
640 x 480 images (8-bit grey, decoded before the clock starts): graphpose's extraction alone
(``extract_junctions``, with the polygon and without) beside OpenCV's ``findChessboardCorners``
+ ``cornerSubPix`` (11 x 11), timed in turn. Per stage, graphpose's time on the 640 x 480 images
with their polygons. Last, ``graphpose track`` over a long run (:mod:`benchmarks.long_track`:
10,000 frames, 1,000 with ``--quick``): memory growth, the back end's growth, the whole
tracker's time a frame and that of its parts (reading, front end, back end; OpenCV's ``imread``
beside the reading). GTSAM's solve with its marginals as ``estimate_pose`` runs it (from
Gauss-Newton's answer, on each real image's trusted junctions) beside ``solvePnPRefineLM`` from
the same pose; and the command itself on one image in a fresh process beside a six-line OpenCV
script (:mod:`benchmarks.startup`). Goals: like for like, the memory and tracking goals in
:mod:`benchmarks.long_track`.

Run it as a section of the benchmark: ``python -m benchmarks speed [--quick]`` (or
``python -m benchmarks.speed [--quick]``, the same).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from functools import partial
from pathlib import Path

import numpy as np

from benchmarks._common import (DATA, REPO, median, opencv_classic, opencv_pnp, scaled_K, single_thread_environment,
                                timed)
from graphpose import Board, BoardNotFoundError
from graphpose.camera_models import as_camera, check_image_size
from graphpose.detect.find import find_board
from graphpose.detect.junctions import extract_junctions
from graphpose.image import read_image
from graphpose.io.files import encode_png
from graphpose.estimate import estimate_pose
from graphpose.estimate import _compare_with_flip, fit_pose
from graphpose.pose.graph import graph_pose
from graphpose.synth.poses import loose_polygon, random_pose
from graphpose.synth.render import render

BOARD = Board()
BIG = (4032, 3024)
#: cornerSubPix as OpenCV's calibration sample calls it: an 11 x 11 half-size (23 x 23 window), 30 iterations.
SUBPIX = {"window": (11, 11), "iterations": 30, "eps": 0.01}


def ours(path, bounds, camera, board=BOARD):
    """graphpose estimate's work on one file; the estimate, or None where it refuses."""
    image = read_image(path, as_float=False)
    check_image_size(camera, image.shape)
    try:
        return estimate_pose(image, camera, bounds=bounds, board=board)
    except BoardNotFoundError:
        return None


def opencv(cv2, path, K_, board=BOARD):
    """OpenCV's classic chain from the file; (rvec, tvec) or None where it finds no board."""
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    corners = opencv_classic(cv2, image, (board.cols, board.rows), **SUBPIX)
    if corners is None:
        return None
    W = board.world_points().T.copy()
    ok, rvec, tvec = cv2.solvePnP(W, corners, K_, None, flags=cv2.SOLVEPNP_IPPE)
    return cv2.solvePnPRefineLM(W, corners, K_, None, rvec, tvec)


def compare(cv2, items, repeats):
    """Per image: median ms of graphpose and of OpenCV, timed in turn; and who found a pose."""
    rows = []
    for path, bounds, camera in items:
        K_ = as_camera(camera).K
        t_ours, t_cv = [], []
        for _ in range(repeats):
            dt, est = timed(partial(ours, path, bounds, camera))
            t_ours.append(dt)
            dt, pose = timed(partial(opencv, cv2, path, K_))
            t_cv.append(dt)
        rows.append({"image": Path(path).name, "ours_ms": 1e3 * float(np.median(t_ours)),
                     "opencv_ms": 1e3 * float(np.median(t_cv)), "ours_ok": bool(est is not None and est.ok),
                     "opencv_ok": pose is not None})
    return rows


#: The stages the issue keeps whatever they cost: reading the file with the project's decoder
#: and the GTSAM solve with its marginals (the GTSAM solve, its marginals and the
#: cross-check stay in the default path).
KEPT_STAGES = ("read", "GTSAM + marginals")


def stages(cv2, items, repeats):
    """graphpose's median time per stage (ms) over the images, beside OpenCV's imread and its
    whole classic chain from the same files (timed in the same rounds), and the share of that
    chain the kept stages (:data:`KEPT_STAGES`) take by themselves."""
    names = ("read", "find board", "refine and judge", "start + Gauss-Newton", "tilt check", "GTSAM + marginals",
             "total", "OpenCV imread", "OpenCV classic chain")
    per = {n: [] for n in names}
    W = BOARD.world_points()
    for path, bounds, camera in items:
        cam = as_camera(camera)
        image = read_image(path, as_float=False)
        J = extract_junctions(image, bounds=bounds, board=BOARD, camera=cam)
        gn, _ = fit_pose(J.points, W, cam, mask=J.trusted)
        t = {n: [] for n in names}
        calls = {
            "read": partial(read_image, path, as_float=False),
            "find board": partial(find_board, image, BOARD, bounds),
            "extract": partial(extract_junctions, image, bounds=bounds, board=BOARD, camera=cam),
            "start + Gauss-Newton": partial(fit_pose, J.points, W, cam, mask=J.trusted),
            # the tilt-ambiguity check: Gauss-Newton again from the board tilted the other way
            "tilt check": partial(_compare_with_flip, cam, J.points, W, J.trusted, None, gn),
            # as estimate_pose runs it: from Gauss-Newton's converged answer (from_minimum)
            "GTSAM + marginals": partial(graph_pose, J.points, W, cam, guess=gn.T_WC, mask=J.trusted,
                                         from_minimum=gn.converged),
            "total": partial(ours, path, bounds, cam),
            "OpenCV imread": partial(cv2.imread, str(path), cv2.IMREAD_GRAYSCALE),
            "OpenCV classic chain": partial(opencv, cv2, path, cam.K),
        }
        for _ in range(repeats):
            times = {name: timed(call)[0] for name, call in calls.items()}
            times["refine and judge"] = times.pop("extract") - times["find board"]
            for name in names:
                t[name].append(times[name])
        for n in names:
            per[n].append(np.median(t[n]))
    out = {n: 1e3 * float(np.median(v)) for n, v in per.items()}
    out["kept stages / OpenCV chain"] = sum(out[n] for n in KEPT_STAGES) / out["OpenCV classic chain"]
    return out


def gtsam_stage(cv2, items, repeats):
    """GTSAM's solve with its marginal covariance as ``estimate_pose`` runs it (from Gauss-Newton's
    converged answer, ``from_minimum``, on the trusted junctions of each image) beside OpenCV's
    ``solvePnPRefineLM`` from the same pose on the same points, timed in turn: per image the
    medians (ms) and the points used."""
    rows = []
    W = BOARD.world_points()
    for path, bounds, camera in items:
        cam = as_camera(camera)
        J = extract_junctions(read_image(path, as_float=False), bounds=bounds, board=BOARD, camera=cam)
        gn, _ = fit_pose(J.points, W, cam, mask=J.trusted)
        # estimate_pose checks its inputs once at its edge and calls the solvers' unchecked cores
        ours = partial(graph_pose, J.points, W, cam, guess=gn.T_WC, mask=J.trusted, from_minimum=gn.converged, check=False)
        peer = partial(opencv_pnp, cv2, cam.K, J.points[:, J.trusted], W[:, J.trusted], guess=gn.T_WC)
        ours(), peer()
        t_ours, t_peer = [], []
        for _ in range(repeats):
            t_ours.append(timed(ours)[0])
            t_peer.append(timed(peer)[0])
        rows.append({"image": Path(path).name, "points": int(J.trusted.sum()), "ours_ms": 1e3 * median(t_ours),
                     "opencv_ms": 1e3 * median(t_peer), "ours_ok": True, "opencv_ok": True})
    return rows


def rendered(folder, count, size, rng, suffix=".png"):
    """``count`` rendered images written to ``folder``; (path, polygon, K) each."""
    from PIL import Image

    K_ = scaled_K(size)
    items = []
    for k in range(count):
        T = random_pose(K_, BOARD, size, distance=(0.8, 1.6), rng=rng)
        R = render(K_, T, BOARD, size, noise_sigma=2.0, rng=rng, blur_sigma=float(rng.uniform(0.7, 1.5)) * size[0] / 640)
        path = Path(folder) / f"scene_{size[0]}_{k:02d}{suffix}"
        if suffix == ".png":
            path.write_bytes(encode_png(R.image))
        else:
            Image.fromarray(R.image).save(path, quality=95)
        items.append((path, loose_polygon(R, offset_px=(-4.0 * size[0] / 640, 4.0 * size[0] / 640), rng=rng), K_))
    return items


def real_items():
    if not (DATA / "cases.json").is_file():
        return []
    doc = json.loads((DATA / "cases.json").read_text())
    return [(DATA / c["image"], np.array(c["bounds"], dtype=float), np.array(doc["K"], dtype=float))
            for c in doc["cases"]]


def peak_memory(tool, warm, path):
    """Growth of the peak resident set (MB) while ``tool`` handles ``path``, in a fresh process
    (:mod:`benchmarks.memory_probe`)."""
    if not Path("/proc/self/status").exists():
        return None
    out = subprocess.run([sys.executable, "-m", "benchmarks.memory_probe", tool, str(warm), str(path)], cwd=REPO,
                         capture_output=True, text=True, env=single_thread_environment(), check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    # Without the reset the peak may be the warm-up's or the imports': not this image's.
    return result["growth_mb"] if result["reset"] else None


def _extract(image, bounds, camera):
    """graphpose's extraction alone (junctions, trusted or not); None where it finds no board."""
    try:
        return extract_junctions(image, bounds=bounds, board=BOARD, camera=camera)
    except BoardNotFoundError:
        return None


def in_memory(cv2, items, repeats):
    """Per image in memory (8-bit grey): median ms of graphpose's extraction and of OpenCV's
    findChessboardCorners + cornerSubPix, timed in turn; and who found the board."""
    rows = []
    for path, bounds, camera in items:
        image, cam = read_image(path, as_float=False), as_camera(camera)
        t_ours, t_cv = [], []
        for _ in range(repeats):
            dt, J = timed(partial(_extract, image, bounds, cam))
            t_ours.append(dt)
            dt, corners = timed(partial(opencv_classic, cv2, image, (BOARD.cols, BOARD.rows), **SUBPIX))
            t_cv.append(dt)
        rows.append({"image": Path(path).name, "ours_ms": 1e3 * median(t_ours), "opencv_ms": 1e3 * median(t_cv),
                     "ours_ok": J is not None, "opencv_ok": corners is not None})
    return rows


def _figure(name, rows, goal_ratio, goal, peer="OpenCV classic"):
    both = [r for r in rows if r["ours_ok"] and r["opencv_ok"]]
    a, b = median([r["ours_ms"] for r in both]), median([r["opencv_ms"] for r in both])
    return {"figure": f"{name} ({len(both)} images both found), median", "unit": "ms", "fmt": ".1f",
            "graphpose": a, "peer_name": peer, "peer": b, "ratio": a / b, "goal": goal,
            "met": bool(a / b <= goal_ratio)}


def _per_image(title, rows, peer, fmt=".1f"):
    return {"title": title, "text": None, "values": {},
            "columns": ["image", "graphpose", peer, "ratio", "graphpose ok", "OpenCV found"],
            "formats": ["", fmt, fmt, ".2f", "", ""],
            "rows": [[r["image"], r["ours_ms"], r["opencv_ms"], r["ours_ms"] / r["opencv_ms"], r["ours_ok"],
                      r["opencv_ok"]] for r in rows]}


#: File to pose: (case, goal ratio to OpenCV classic) as the goals set them (like for like: the
#: GTSAM cross-check and the read included, at most 1.3x at VGA with or without a polygon).
FILE_GOALS = (("real, polygon", 1.3), ("rendered, polygon", 1.3), ("real, no polygon", 1.3),
              ("rendered, no polygon", 1.3), ("12 MP JPEG, no polygon", 0.6))
#: The memory probe's tools (:mod:`benchmarks.memory_probe`) and how the page names them.
MEMORY_TOOLS = {"graphpose": "graphpose.read_image (its default) + estimate_pose",
                "graphpose estimate": "as graphpose estimate reads it (8-bit) + estimate_pose",
                "opencv": "OpenCV classic"}


def main(quick: bool = False) -> dict:
    """Measure the section; returns its goal, headline figures and detail blocks (:mod:`benchmarks`)."""
    import cv2

    from benchmarks import long_track, startup

    cv2.setNumThreads(1)
    rng = np.random.default_rng(11)
    repeats = 3 if quick else 7
    with tempfile.TemporaryDirectory() as folder:
        real = real_items()
        synth = rendered(folder, 4 if quick else 12, (640, 480), rng)
        big = rendered(folder, 1 if quick else 3, BIG, rng, suffix=".jpg")
        ours(synth[0][0], None, synth[0][2])  # imports and first calls out of the timing
        opencv(cv2, synth[0][0], synth[0][2])
        cases = {"real, polygon": real, "rendered, polygon": synth,
                 "real, no polygon": [(p, None, k) for p, _, k in real],
                 "rendered, no polygon": [(p, None, k) for p, _, k in synth]}
        results = {name: compare(cv2, items, repeats) for name, items in cases.items()}
        results["12 MP JPEG, no polygon"] = compare(cv2, [(p, None, k) for p, _, k in big], max(2, repeats // 2))
        extraction = {name: in_memory(cv2, items, repeats) for name, items in cases.items()}
        stage = stages(cv2, real or synth, repeats)
        graph_rows = gtsam_stage(cv2, real or synth, 10 * repeats)
        memory = {tool: [peak_memory(tool, synth[0][0], p) for p, _, _ in big] for tool in MEMORY_TOOLS}
    figures = []
    for name, ratio in FILE_GOALS:
        if results[name]:
            size = "4032 x 3024" if "12 MP" in name else "640 x 480"
            figures.append(_figure(f"file to cross-checked pose, {size}, {name}", results[name], ratio,
                                   f"<= {ratio:.1f}x OpenCV classic"))
    subpix = "findChessboardCorners + cornerSubPix"
    for name, rows in extraction.items():
        if rows:
            figures.append(_figure(f"in memory, extraction alone, 640 x 480, {name}", rows, 1.0,
                                   f"<= 1.0x {subpix}", peer=subpix))
    points = sorted({r["points"] for r in graph_rows})
    figures.append(_figure(f"GTSAM's solve with marginals, {'/'.join(map(str, points))} points, from Gauss-Newton's "
                           "answer as estimate_pose runs it", graph_rows, 4.0, "<= 4x solvePnPRefineLM from the same pose",
                           peer="solvePnPRefineLM from the same pose") | {"fmt": ".2f"})
    peak = {tool: median([m for m in values if m is not None]) for tool, values in memory.items()}
    if np.isfinite(peak["graphpose"]) and np.isfinite(peak["opencv"]):
        a, b = peak["graphpose"], peak["opencv"]
        figures.append({"figure": f"peak memory growth, 12 MP JPEG, {MEMORY_TOOLS['graphpose']}, median",
                        "unit": "MB", "fmt": ".0f", "graphpose": a, "peer_name": "OpenCV classic", "peer": b,
                        "ratio": a / b, "goal": "below OpenCV classic's", "met": bool(a < b)})
    blocks = [
        {"title": "graphpose per stage, 640 x 480 with the polygon (median ms), beside OpenCV",
         "text": "The same images, each stage timed in turn with OpenCV's imread and its whole classic chain from the "
                 "file. The last column is the share of OpenCV's whole chain that two stages the issue keeps whatever "
                 "they cost take by themselves: reading the file with the project's decoder (Pillow) and the GTSAM "
                 "solve with its marginals. At 1 or more, the 1.0x goal would need the rest (finding, refining, "
                 "judging, Gauss-Newton, the cross-check) to take no time.",
         "values": {}, "columns": list(stage), "formats": [".2f"] * len(stage), "rows": [list(stage.values())]},
        {"title": f"Peak memory growth at 12 MP, median over {len(big)} JPEG images (MB)",
         "text": "Each tool in a fresh process, after a warm-up on a 640 x 480 image: the resident set's peak while it "
                 "handles the image, over its size before (the peak reset through /proc/self/clear_refs).",
         "values": {}, "columns": list(MEMORY_TOOLS.values()), "formats": [".0f"] * len(MEMORY_TOOLS),
         "rows": [[peak[tool] for tool in MEMORY_TOOLS]]},
    ]
    blocks.append(_per_image(f"Per image, GTSAM's solve with marginals from Gauss-Newton's answer (median ms of "
                             f"{10 * repeats} runs)", graph_rows, "solvePnPRefineLM from the same pose", ".3f"))
    for name, rows in results.items():
        if rows:
            blocks.append(_per_image(f"Per image, file to pose: {name} (median ms of {repeats} runs)", rows,
                                     "OpenCV classic"))
    for name, rows in extraction.items():
        if rows:
            blocks.append(_per_image(f"Per image, in memory, extraction alone: {name} (median ms of {repeats} "
                                     "runs)", rows, subpix))
    start_figure, start_block = startup.measure(REPO / "graphpose" / "data" / "synthetic_01.png", scaled_K((640, 480)),
                                                3 if quick else 9)
    figures.append(start_figure)
    blocks.append(start_block)
    long_figures, long_block = long_track.measure(quick, cv2)
    figures += long_figures
    blocks.append(long_block)
    goal = ("From an image file to a cross-checked pose with covariance, as `graphpose estimate` does (both "
            "solvers, the marginal covariance, the cross-check), beside OpenCV's classic chain from the same file "
            "(imread, findChessboardCorners with its default flags, cornerSubPix 11 x 11, IPPE, "
            "solvePnPRefineLM: one pose, no covariance, no second solver); the extraction alone in memory beside "
            "findChessboardCorners + cornerSubPix; peak memory at 12 MP; and `graphpose track` over a long run. "
            "Also GTSAM's solve with its marginals as estimate_pose runs it beside solvePnPRefineLM from the same "
            "pose, and `graphpose estimate` on one image in a fresh process beside a six-line OpenCV script. "
            "Single-threaded, each image timed in turn with the peer, medians. Goals: file to pose at "
            "most 1.3x the peer's time at 640 x 480 with or without a polygon, 0.6x at 4032 x 3024; the "
            "extraction at most 1.0x; GTSAM's solve at most 4x; the command at most 1.6x the script; less peak memory than the peer at 12 MP through the library's read_image; "
            "over 10,000 frames, tracker memory growing by less than 2 MB per 1,000 frames, the back end's time "
            "per frame over the last 100 frames at most 1.2x that of frames 100-199, and the whole tracker under "
            "3 ms a frame.")
    return {"goal": goal, "figures": figures, "blocks": blocks}


if __name__ == "__main__":
    from benchmarks.cli import main as bench_main

    sys.exit(bench_main(["speed", *sys.argv[1:]]))

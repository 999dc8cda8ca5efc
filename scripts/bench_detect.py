"""Board identification benchmark: find and label the board without a polygon, beside OpenCV.

A sweep over random rendered scenes (graphpose.synth.scenes) with exact truth: random
board sizes (symmetric and not), poses of any in-plane rotation (portrait, upside down),
tilts up to 60 degrees, squares from about 10 pixels to a third of the image, occluders
(a bar, a blob, a bright reflection, the image edge), clutter (text-like strokes, a small
grid), low contrast, vignetting, noise and blur. Each tool is run on every image:

- graphpose: ``extract_junctions(image, None, board)``;
- OpenCV ``findChessboardCorners`` (+ ``cornerSubPix``) and ``findChessboardCornersSB``.

A result is *right* when every junction it trusts lies within 1 px of the true junction
of its label; for a board whose pattern a half turn leaves unchanged (and quarter turns,
square boards) labels related by that symmetry count as right, since no image can tell
them apart (graphpose then says ``orientation_ambiguous``). Anything else it returns is
*mislabelled* (a confident wrong answer); a refusal is *not found*. On whole, unoccluded
boards the goal is to find at least as many as SB; everywhere the goal is 0 mislabelled.

Speed: the median time without a polygon on 640 x 480 images, and the growth of that time
with the pixel count (the same scenes rendered at 320 x 240 to 1280 x 960; exponent of a
log-log fit).

Run ``python scripts/bench_detect.py [--quick] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from graphpose import Board, BoardNotFoundError, K_from_params, extract_junctions  # noqa: E402
from graphpose.synth.scenes import random_scene  # noqa: E402

K = K_from_params(564.9, 564.3, 337.3, 226.5)
BOARDS = [Board(8, 6, 0.0635), Board(9, 6, 0.03), Board(7, 5, 0.04), Board(5, 4, 0.05), Board(11, 8, 0.025),
          Board(6, 6, 0.04), Board(10, 7, 0.025)]
#: Scene classes: name -> (occluders, clutter)
CLASSES = {
    "whole": ((), ()),
    "clutter": ((), ("text", "grid")),
    "bar": (("bar",), ()),
    "blob": (("blob",), ()),
    "reflection": (("reflection",), ()),
    "image edge": (("edge",), ()),
}


def symmetries(board: Board) -> list:
    """Label permutations that map the board's pattern onto itself (identity first)."""
    idx = np.arange(board.n)
    c, r = idx % board.cols, idx // board.cols
    out = [idx]
    if (board.cols + board.rows) % 2 == 0:
        out.append((board.rows - 1 - r) * board.cols + (board.cols - 1 - c))
        if board.cols == board.rows:
            n = board.cols - 1
            out.append(c * board.cols + (n - r))        # quarter turn
            out.append((n - c) * board.cols + r)        # three quarters
    return out


def verdict(points, trusted, truth, board) -> str:
    """'right' or 'mislabelled' for a result (points (2, n) in label order, trusted mask)."""
    best = np.inf
    for perm in symmetries(board):
        err = np.hypot(*(points[:, trusted] - truth[:, perm[trusted]]))
        best = min(best, float(err.max()) if err.size else np.inf)
    return "right" if best <= 1.0 else "mislabelled"


def scene(rng, k: int, cls: str, size=(640, 480)):
    board = BOARDS[rng.integers(len(BOARDS))]
    occluders, clutter = CLASSES[cls]
    # The same camera at another resolution: pixel (u, v) covers [u - 0.5, u + 0.5].
    s = size[0] / 640
    Kc = K_from_params(s * K[0, 0], s * K[1, 1], s * (K[0, 2] + 0.5) - 0.5, s * (K[1, 2] + 0.5) - 0.5)
    f = s * K[0, 0]
    far = board.square_m * f / (11 * s)   # squares of about 11 px (at 640 x 480) at the far end
    near = board.square_m * f / (90 * s)  # about 90 px at the near end
    extent = max(board.cols, board.rows) + 2
    near = max(near, extent * board.square_m * f / (0.9 * size[1]))  # the sheet must fit the image
    return random_scene(
        int(rng.integers(2**31)), Kc, board, size, occluders=occluders, clutter=clutter,
        distance=(near, max(far, near * 1.2)), max_tilt_deg=float(rng.uniform(20, 60)),
        noise_sigma=float(rng.uniform(1, 5)), blur_sigma=float(rng.uniform(0.5, 2.0)),
        contrast=float(rng.uniform(0.4, 1.0)), vignetting=float(rng.uniform(0, 0.5)),
        margin=float(rng.choice([0.15, 0.5, 1.0]))), board


def run_ours(image, board):
    t = time.perf_counter()
    try:
        J = extract_junctions(image, None, board)
    except BoardNotFoundError:
        return None, time.perf_counter() - t
    return (J.points, J.trusted), time.perf_counter() - t


def run_opencv(cv2, image, board, sb: bool):
    t = time.perf_counter()
    if sb:
        ok, corners = cv2.findChessboardCornersSB(image, (board.cols, board.rows), flags=cv2.CALIB_CB_ACCURACY)
    else:
        ok, corners = cv2.findChessboardCorners(image, (board.cols, board.rows))
        if ok:
            corners = cv2.cornerSubPix(image, corners, (5, 5), (-1, -1),
                                       (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01))
    dt = time.perf_counter() - t
    if not ok:
        return None, dt
    P = corners.reshape(-1, 2).T.astype(float)
    return (P, np.ones(P.shape[1], dtype=bool)), dt


def sweep(n: int, seed: int = 0) -> dict:
    try:
        import cv2
    except ImportError:
        cv2 = None
    rng = np.random.default_rng(seed)
    names = list(CLASSES)
    tools = ["graphpose"] + (["OpenCV classic", "OpenCV SB"] if cv2 is not None else [])
    counts = {c: {t: {"right": 0, "mislabelled": 0, "not found": 0} for t in tools} for c in names}
    times = {t: [] for t in tools}
    mislabelled = []
    for k in range(n):
        cls = names[k % len(names)]
        sc, board = scene(rng, k, cls)
        truth = sc.rendering.junctions
        for tool in tools:
            if tool == "graphpose":
                res, dt = run_ours(sc.image, board)
            else:
                res, dt = run_opencv(cv2, sc.image, board, sb=tool == "OpenCV SB")
            times[tool].append(dt)
            if res is None:
                counts[cls][tool]["not found"] += 1
                continue
            v = verdict(*res, truth, board)
            counts[cls][tool][v] += 1
            if v == "mislabelled" and tool == "graphpose":
                mislabelled.append({"scene": k, "class": cls, "board": f"{board.cols}x{board.rows}"})
    return {"n": n, "counts": counts, "median_ms": {t: 1e3 * float(np.median(v)) for t, v in times.items()},
            "graphpose_mislabelled": mislabelled}


def scaling(n: int, seed: int = 1) -> dict:
    """Median time without a polygon at four image sizes, and the log-log exponent."""
    sizes = [(320, 240), (640, 480), (960, 720), (1280, 960)]
    out = {}
    for size in sizes:
        rng = np.random.default_rng(seed)
        ts = []
        for k in range(n):
            sc, board = scene(rng, k, "whole", size)
            _, dt = run_ours(sc.image, board)
            ts.append(dt)
        out[f"{size[0]}x{size[1]}"] = 1e3 * float(np.median(ts))
    px = np.array([w * h for w, h in sizes], dtype=float)
    ms = np.array(list(out.values()))
    slope = float(np.polyfit(np.log(px), np.log(ms), 1)[0])
    return {"median_ms": out, "exponent": slope}


def format_report(result: dict) -> str:
    lines = [f"Board identification: {result['sweep']['n']} random rendered scenes, no polygon", ""]
    tools = list(next(iter(result["sweep"]["counts"].values())))
    lines.append("| scenes | " + " | ".join(f"{t} right / mislabelled / not found" for t in tools) + " |")
    lines.append("|---" * (len(tools) + 1) + "|")
    for cls, row in result["sweep"]["counts"].items():
        cells = [f"{row[t]['right']} / {row[t]['mislabelled']} / {row[t]['not found']}" for t in tools]
        lines.append(f"| {cls} | " + " | ".join(cells) + " |")
    total = {t: {k: sum(r[t][k] for r in result["sweep"]["counts"].values()) for k in ("right", "mislabelled", "not found")}
             for t in tools}
    lines.append("| all | " + " | ".join(f"{total[t]['right']} / {total[t]['mislabelled']} / {total[t]['not found']}"
                                        for t in tools) + " |")
    lines.append("")
    lines.append("Median time per image, ms (all scenes, 640 x 480): " +
                 ", ".join(f"{t} {v:.1f}" for t, v in result["sweep"]["median_ms"].items()))
    s = result["scaling"]
    lines.append("graphpose without a polygon by image size, median ms: " +
                 ", ".join(f"{k} {v:.1f}" for k, v in s["median_ms"].items()) +
                 f"; time grows as pixels^{s['exponent']:.2f}")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="120 scenes instead of 1200")
    parser.add_argument("--json", type=Path, help="write the figures to this JSON file")
    args = parser.parse_args(argv)
    n = 120 if args.quick else 1200
    result = {"sweep": sweep(n), "scaling": scaling(10 if args.quick else 40)}
    print(format_report(result))
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Fuzz: no `ok` answer may be wrong, over thousands of random hard inputs with truth.

Each input is one :func:`graphpose.synth.fuzz.fuzz_case`: a board of a random size at a random
pose (any in-plane rotation), whole or partly hidden (the image edge, a bar, a blob, a
specular highlight), clutter beside it, contrast down to a quarter, noise to 7 grey levels,
blur, vignetting; given to ``extract_junctions`` or to ``estimate_pose``, without a polygon,
with the board's outline (exact, loose, inside the margin) or with the outline rolled by one
to three vertices (another corner named junction 0). Each answer is

- *refused*: a :class:`graphpose.BoardNotFoundError` (or another of graphpose's typed
  refusals), or a pose whose ``ok`` is False;
- *right*: every junction it trusts within 1 px of the truth of its label (labels that a
  symmetry of the board's pattern relates count as right, as in the ``detect`` section) and,
  for a pose, every parameter within 5 of its sigmas of the truth (turned by that symmetry);
- *mislabelled*: a trusted junction more than half a square from the truth under every
  symmetry (another junction's label);
- *off*: labels right, but a trusted junction more than 1 px from its truth, or a pose more
  than 5 sigma from the truth.

The goal is 0 mislabelled and 0 off. Run it as a section of the benchmark:
``python -m benchmarks fuzz [--quick]``; ``tests/test_fuzz.py`` runs a smaller fixed seed.
"""

from __future__ import annotations

import sys
from collections import Counter

import numpy as np

from benchmarks._common import params_error
from benchmarks.detect import best_errors, polygon_labellings
from graphpose import GraphposeError, InputError, estimate_pose, extract_junctions
from graphpose.synth.fuzz import ENTRIES, POLYGONS, fuzz_case

#: A trusted junction farther than this from its truth (px) is wrong (the ``detect`` section's rule).
JUNCTION_PX = 1.0
#: A pose parameter farther than this many of its sigmas from the truth is off.
SIGMAS = 5.0


def run_case(case) -> dict:
    """Run one :class:`graphpose.synth.fuzz.FuzzCase` through its entry point and judge the answer.

    Returns
    -------
    dict
        ``verdict`` (``"refused"``, ``"input"``, ``"right"``, ``"mislabelled"`` or ``"off"``),
        ``worst_px`` (largest trusted junction error under the best symmetry, NaN when none),
        ``sigmas`` (largest pose error in its sigmas, NaN without a pose) and ``message``.
    """
    out = {"verdict": "refused", "worst_px": float("nan"), "sigmas": float("nan"), "message": ""}
    try:
        if case.entry == "pose":
            est = estimate_pose(case.image, case.K, bounds=case.bounds, board=case.board)
            J = est.junctions
        else:
            est, J = None, extract_junctions(case.image, bounds=case.bounds, board=case.board)
    except InputError as exc:
        return {**out, "verdict": "input", "message": str(exc)}
    except GraphposeError as exc:
        return {**out, "message": str(exc)}
    if est is not None and not est.ok:
        return {**out, "message": est.message}
    perm, err = _best_labelling(J.points, J.trusted, case)
    out["worst_px"] = float(err.max()) if err.size else float("nan")
    if not err.size:
        return {**out, "verdict": "mislabelled"}
    if err.max() > JUNCTION_PX:
        # Labels right (every trusted junction within half a square of its own truth) but one
        # farther than the tolerance: off; else mislabelled.
        step = np.nanmedian(np.hypot(*np.diff(case.truth.reshape(2, case.board.rows, case.board.cols), axis=2)))
        return {**out, "verdict": "off" if err.max() < 0.5 * step else "mislabelled"}
    if est is not None:
        e = params_error(est.params, _turned(case.board, perm) @ case.T_WC)
        sigma = np.sqrt(np.diag(est.cov))
        out["sigmas"] = float(np.max(np.abs(e) / sigma))
        if out["sigmas"] > SIGMAS:
            return {**out, "verdict": "off"}
    return {**out, "verdict": "right"}


def _best_labelling(points, trusted, case):
    """The right relabelling (:func:`benchmarks.detect.polygon_labellings`) that fits the trusted points best,
    and their errors (px) under it."""
    best = None
    for perm in polygon_labellings(case.board, case.roll):
        err = best_errors(points, trusted, case.truth, [perm])
        if best is None or (err.size and err.max() < best[1].max()):
            best = (perm, err)
    return best


def _turned(board, perm) -> np.ndarray:
    """The rigid transform F (4, 4) from the true target frame to the one a detector that puts
    label ``k`` on physical junction ``perm[k]`` estimates in: ``W[:, k] = F W[:, perm[k]]``
    (identity for the identity)."""
    W = board.world_points()
    A, B = W[:, perm], W
    a, b = A.mean(axis=1, keepdims=True), B.mean(axis=1, keepdims=True)
    U, _, Vt = np.linalg.svd((B - b) @ (A - a).T)
    R = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, (b - R @ a)[:, 0]
    return T


def run(n: int, seed: int = 0, **fixed) -> dict:
    """Run ``n`` fuzz cases from ``seed``; counts per entry point and polygon, and the wrong ones."""
    rng = np.random.default_rng(seed)
    counts = {(e, p): Counter() for e in ENTRIES for p in POLYGONS}
    wrong = []
    for k in range(n):
        case = fuzz_case(rng, **fixed)
        result = run_case(case)
        counts[(case.entry, case.polygon)][result["verdict"]] += 1
        if result["verdict"] in ("mislabelled", "off"):
            wrong.append({"case": k, "entry": case.entry, "polygon": case.polygon, "roll": case.roll,
                          "board": f"{case.board.cols}x{case.board.rows}", **result,
                          "occluders": "+".join(case.settings["occluders"]) or "-"})
    return {"n": n, "seed": seed, "counts": counts, "wrong": wrong}


def main(quick: bool = False) -> dict:
    """Measure the section; returns its goal, headline figures and detail blocks (:mod:`benchmarks`)."""
    n = 200 if quick else 2000
    result = run(n)
    counts = result["counts"]
    total = Counter()
    for c in counts.values():
        total.update(c)
    answered = total["right"] + total["mislabelled"] + total["off"]
    figures = [
        {"figure": f"ok answers mislabelled, {n} fuzz inputs", "unit": "", "fmt": "d",
         "graphpose": total["mislabelled"], "peer_name": None, "peer": None, "ratio": None, "goal": "0",
         "met": total["mislabelled"] == 0},
        {"figure": f"ok answers off: a junction over {JUNCTION_PX:g} px or a pose over {SIGMAS:g} sigma from the truth",
         "unit": "", "fmt": "d",
         "graphpose": total["off"], "peer_name": None, "peer": None, "ratio": None, "goal": "0",
         "met": total["off"] == 0},
        {"figure": "inputs answered (not refused)", "unit": "", "fmt": "d", "graphpose": answered,
         "peer_name": None, "peer": None, "ratio": None, "goal": "(reported)", "met": None},
    ]
    rows = [[entry, polygon, c["right"], c["mislabelled"], c["off"], c["refused"], c["input"]]
            for (entry, polygon), c in counts.items()]
    rows.append(["all", "", total["right"], total["mislabelled"], total["off"], total["refused"], total["input"]])
    blocks = [{"title": "Answers per entry point and polygon", "text": None, "values": {},
               "columns": ["entry", "polygon", "right", "mislabelled", "off", "refused", "input refused"],
               "formats": ["", "", "d", "d", "d", "d", "d"], "rows": rows}]
    if result["wrong"]:
        blocks.append({"title": "Wrong answers", "text": None, "values": {},
                       "columns": ["case", "entry", "polygon", "roll", "board", "occluders", "worst px", "sigmas"],
                       "formats": ["d", "", "", "d", "", "", ".2f", ".1f"],
                       "rows": [[w["case"], w["entry"], w["polygon"], w["roll"], w["board"], w["occluders"],
                                 w["worst_px"], w["sigmas"]] for w in result["wrong"]]})
    goal = (f"No answer that says ok may be wrong: {n} random rendered inputs (graphpose.synth.fuzz, seed 0) "
            "to extract_junctions and estimate_pose: boards of seven sizes at any in-plane rotation, whole or "
            "partly hidden (image edge, bar, blob, specular highlight), clutter, contrast 0.25-1, noise 0.5-7 "
            "grey levels, blur, vignetting; no polygon, the outline (exact, loose, inside the margin) or the "
            "outline rolled by one to three vertices. Right: trusted junctions within 1 px of their truth "
            "(board symmetries allowed), a pose within 5 sigma; a refusal is never wrong.")
    return {"goal": goal, "figures": figures, "blocks": blocks}


if __name__ == "__main__":
    from benchmarks.cli import main as bench_main

    sys.exit(bench_main(["fuzz", *sys.argv[1:]]))

"""The lens section's NEES, split into what it is made of (:mod:`benchmarks.lens`).

Per image the NEES of the whole pose and of its translation and rotation parts; per set of
scenes their means beside the junctions' error against the truth, the pixel sigma the pose's
covariance used, and the noise-free junctions' mean radial error (a bias the pose absorbs, which
its residuals and so its sigma do not see).
"""

from __future__ import annotations

import numpy as np

from benchmarks._common import mean, nees, params_error, rms


def nees_parts(estimate, T):
    """NEES of the whole pose, of its translation (3 on average) and of its rotation (3)."""
    e = params_error(estimate.params, T)
    C = estimate.cov
    return nees(C, e), nees(C[:3, :3], e[:3]), nees(C[3:, 3:], e[3:])


def diagnosis(results, bias):
    """What the NEES of a set of scenes is made of: its mean, its translation and rotation
    parts (each 3 on average), the junction error per coordinate against truth beside the
    pixel sigma the covariance used (its reprojection residuals'), and the noise-free junctions'
    mean radial error (``bias``: per scene, px, positive outward), which a pose absorbs."""
    solved = [r for r in results if r["solved"]]
    if not solved:
        return {"images": 0}
    err = np.concatenate([r["junction_err"] for r in solved])
    return {"images": len(solved), "nees_mean": mean([r["nees"] for r in solved]),
            "nees_translation_mean": mean([r["nees_t"] for r in solved]),
            "nees_rotation_mean": mean([r["nees_r"] for r in solved]),
            "junction_error_per_coordinate_px": rms(err) / np.sqrt(2.0),
            "sigma_px_rms": rms([r["sigma_px"] for r in solved]),
            "noise_free_radial_error_px": mean([b for b in bias if np.isfinite(b)])}


def nees_block(rendered) -> dict:
    """The NEES of each lens set beside what it is made of (:func:`diagnosis`)."""
    rows = []
    for name in ("radtan", "fisheye", "fisheye whole field"):
        for image, d in rendered[name]["nees_diagnosis"].items():
            if d.get("images"):
                rows.append([name, image, d["images"], d["nees_mean"], d["nees_translation_mean"],
                             d["nees_rotation_mean"], d["junction_error_per_coordinate_px"], d["sigma_px_rms"],
                             d["noise_free_radial_error_px"]])
    return {"title": "NEES by lens set, and what it is made of",
            "text": ("Translation and rotation parts: 3 each on average. The pixel sigma is the pose's own (from its "
                     "reprojection residuals); beside it the junctions' error against the truth. The noise-free "
                     "junctions' mean radial error (positive outward) is a bias the pose absorbs (a scale of the "
                     "board's image: translation along the axis), which the residuals and so the sigma do not see."),
            "values": {}, "columns": ["set", "image", "images", "NEES", "translation", "rotation",
                                      "junction error px / coordinate", "sigma px", "noise-free radial px"],
            "formats": ["", "", "d", ".2f", ".2f", ".2f", ".4f", ".4f", "+.4f"], "rows": rows}

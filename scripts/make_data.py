#!/usr/bin/env python
"""Regenerate the bundled synthetic case file and images in data/ (deterministic).

    python scripts/make_data.py [OUT_DIR]      # default: the repository's data/

Writes ``cases.json`` (the format of the real case files, plus exact ``true_T_WC`` and
``true_junctions``) and ``synthetic_01.png`` ... ``synthetic_04.png``: the real camera's K,
640 x 480, random poses like the real images, blur 1 px, noise 2 grey levels, 8 bits.
``bounds`` is a loose polygon (the sheet outline, each vertex moved up to 4 px) and
``guess_T_WC`` the truth moved by 8-12 degrees and 15-25 cm. Same seed, same files.
"""

import json
import sys
from pathlib import Path

import numpy as np
from skimage.io import imsave

from graphpose.board import Board
from graphpose.synth.poses import loose_polygon, perturb_pose, random_pose
from graphpose.synth.render import render

SEED = 20261122
COUNT = 4
#: The real ROB501 camera (images already undistorted).
K = np.array([[564.9, 0.0, 337.3], [0.0, 564.3, 226.5], [0.0, 0.0, 1.0]])
SIZE = (640, 480)


def make(out_dir) -> dict:
    """Render the cases into ``out_dir`` and return the case file's content."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(SEED)
    board = Board()
    cases = []
    for i in range(1, COUNT + 1):
        T_WC = random_pose(K, board, SIZE, rng=rng)
        rendering = render(K, T_WC, board, SIZE, noise_sigma=2.0, blur_sigma=1.0, rng=rng)
        name = f"synthetic_{i:02d}.png"
        imsave(out_dir / name, rendering.image, check_contrast=False)
        cases.append(
            {
                "image": name,
                "bounds": loose_polygon(rendering, rng=rng).tolist(),
                "guess_T_WC": perturb_pose(T_WC, rng=rng).tolist(),
                "true_T_WC": T_WC.tolist(),
                "true_junctions": rendering.junctions.tolist(),
            }
        )
    doc = {
        "K": K.tolist(),
        "image_size": list(SIZE),
        "square_m": board.square_m,
        "grid": {"cols": board.cols, "rows": board.rows},
        "world_points": board.world_points().tolist(),
        "cases": cases,
    }
    (out_dir / "cases.json").write_text(json.dumps(doc, indent=1) + "\n")
    return doc


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out_dir = Path(argv[0]) if argv else Path(__file__).resolve().parents[1] / "graphpose" / "data"
    make(out_dir)
    print(f"wrote {COUNT} images and cases.json to {out_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

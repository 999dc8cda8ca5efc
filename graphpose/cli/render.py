"""``graphpose render-sequence``: a synthetic sequence with its true trajectory, to measure a tracker.

Calls :func:`graphpose.synth.sequence.render_sequence` and :func:`graphpose.synth.sequence.write_sequence`:
OUT_DIR gets ``frame_00000.png ...``, ``truth.tum`` (the true pose of every frame) and
``bounds.json`` (K, board, fps, the first frame's bounding polygon, per-frame labels), and
the command prints the ``graphpose track`` line that tracks it.
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

from . import HelpFormatter, EXIT_OK, exit_codes_help
from .options import (
    Progress,
    add_target_options,
    parse_count,
    parse_distance,
    parse_non_negative,
    parse_positive,
    target_from_args,
)

_EXAMPLES = """\
examples:
  graphpose render-sequence seq/                       # 300 frames, seed 0
  graphpose render-sequence seq/ --frames 60 --seed 3 --excursions 1 --noise 1
  graphpose track seq/ --tum est.tum && evo_ape tum seq/truth.tum est.tum

""" + exit_codes_help(None)


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``render-sequence`` subcommand's parser to ``subparsers``."""
    p = subparsers.add_parser(
        "render-sequence",
        aliases=["render"],  # the module's name, as the subcommand protocol expects
        help="render a synthetic hand-held sequence of the board with its true trajectory (TUM)",
        description=textwrap.fill(
            "Render a synthetic sequence: smooth hand-held motion 0.6-1.3 m from the board, motion "
            "blur on fast frames, whip pans that take the board out of view. Writes PNG frames, "
            "truth.tum and bounds.json (the first frame's polygon) into OUT_DIR.", 88),
        epilog=_EXAMPLES,
        formatter_class=HelpFormatter,
    )
    p.set_defaults(command="render")  # the module that runs it (graphpose/cli/render.py)
    p.add_argument("out_dir", type=Path, metavar="OUT_DIR", help="folder to write (created if absent)")
    p.add_argument("--frames", type=parse_count(2), default=300, help="number of frames (default 300)")
    p.add_argument("--seed", type=parse_count(0), default=0, help="random seed, >= 0 (default 0)")
    p.add_argument("--fps", type=parse_positive, default=30.0, help="frame rate (default 30)")
    p.add_argument("--noise", type=parse_non_negative, default=2.0,
                   help="Gaussian noise, grey levels of 255 (default 2)")
    p.add_argument("--blur", type=parse_non_negative, default=1.0, help="optical blur sigma, pixels (default 1)")
    p.add_argument("--distance", type=parse_distance, default=(0.6, 1.3), metavar="NEAR,FAR",
                   help="range of the board centre's distance, metres (default 0.6,1.3)")
    p.add_argument("--excursions", type=parse_count(0), default=2, help="whip pans out of view (default 2)")
    add_target_options(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no summary on stdout")
    return p


def run(args) -> int:
    """Run ``graphpose render-sequence`` with parsed ``args``; returns the exit code."""
    from ..synth.sequence import render_sequence, write_sequence

    K, board = target_from_args(args)
    progress = Progress(args.frames, sys.stderr)
    seq = render_sequence(K, args.frames, rng=args.seed, board=board, fps=args.fps,
                          noise_sigma=args.noise, blur_sigma=args.blur, distance=args.distance,
                          excursions=args.excursions, progress=lambda k, n: progress.show(k + 1, f"frame {k}"))
    progress.clear()
    out = write_sequence(seq, args.out_dir)
    if not args.quiet:
        bounds = ",".join(f"{u:.1f},{v:.1f}" for u, v in zip(*seq.bounds))
        print(f"{len(seq)} frames in {out}: {int(seq.out_of_view.sum())} with the board out of view, "
              f"{int((seq.subframes > 1).sum())} motion-blurred; truth in {out / 'truth.tum'}")
        print(f"track it: graphpose track {out} --bounds {bounds} --fps {seq.fps:g} --tum est.tum --json est.json")
    return EXIT_OK

"""``graphpose batch``: the camera pose in many images on a Dask cluster, one row per image.

Turns the arguments into image paths (:func:`graphpose.batch.inputs.collect_images`),
polygons, a camera (``--camera FILE`` with its lens model, or a pinhole ``--K``; there is no
default) and a :class:`Board`, leaves out the images the result set already has with the
same parameters (and refuses to go on when it has some made with others), runs the rest with :func:`graphpose.batch.estimate_many` (a local cluster, or the one
at ``--scheduler``) and writes each row as it arrives (:mod:`graphpose.batch.results`).
Exit code 0 when every image named has a pose, 1 when one has not (its row says why; a
row left from an earlier run counts too),
2 for bad usage or input, 130 when interrupted (the rows written stay; run again to do the
rest).
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import textwrap
import threading
import time
from collections import Counter

from ..errors import InputError
from . import HelpFormatter, EXIT_FAILED, EXIT_OK, exit_codes_help, prefix
from .recordings import add_topic_option, camera_note, frame_keys, open_recording_input, recording_camera
from .options import (
    Progress,
    add_camera_option,
    board_hint,
    add_target_options,
    camera_file,
    camera_from_args,
    parse_bounds,
    parse_positive,
)

_EXAMPLES = """\
examples:
  graphpose batch images/ --out results.parquet --camera left.opencv.yml --board 9x6x0.03
  graphpose batch 'campaign/**/*.png' list.txt --out results.jsonl --K 564.9,564.3,337.3,226.5 --workers 2
  graphpose batch cam1/ --out cam1.parquet --camera camchain.yaml --camera-name cam1 --board 9x6x0.03 \\
      --bounds-file bounds.json
  graphpose batch images/ --out /shared/results.parquet --scheduler tcp://HEAD:8786

INPUTS are folders (their image files), glob patterns (quote them; ** crosses folders) or
text files (.txt, .lst, .list) listing one image path a line. Without --bounds or
--bounds-file the board is searched in the whole image, as 'graphpose estimate IMAGE' does;
a polygon narrows the search and names junction 0's corner. --out ending in .parquet is a Parquet data set (a folder); .jsonl is JSON lines.
Images need their camera: --camera FILE (raw images, their lens) or --K (undistorted).
Run again with the same --out to do only the images it does not have yet; rows made there
with another camera, board, bounds or --robust are refused (give another --out).
On a cluster (dask scheduler; dask worker tcp://HOST:8786 on each machine) every worker
must see the images at the same absolute paths. See docs/batch.md.
""" + exit_codes_help("some images have no pose (see their rows)")


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``batch`` subcommand's parser to ``subparsers``."""
    p = subparsers.add_parser(
        "batch",
        help="camera pose in many images on a Dask cluster; Parquet or JSON lines, resumable",
        description=textwrap.fill(
            "Estimate the camera pose T_WC in every image named by INPUTS, as 'graphpose estimate' "
            "does for one, on a local Dask cluster of worker processes or an existing one; write one "
            "row per image to RESULTS as results arrive, skipping the images RESULTS already has.", 88),
        epilog=_EXAMPLES,
        formatter_class=HelpFormatter,
    )
    p.add_argument("inputs", nargs="+", metavar="INPUTS",
                   help="folders, glob patterns or list files of images, or one video or ROS bag (one row a frame, "
                   "named by index and time; each task's worker opens the recording and seeks)")
    add_topic_option(p)
    p.add_argument("--out", required=True, metavar="RESULTS",
                   help="results: NAME.parquet (a Parquet data set, a folder) or NAME.jsonl (JSON lines)")
    add_target_options(p)
    add_camera_option(p)
    where = p.add_mutually_exclusive_group()
    where.add_argument("--bounds", type=parse_bounds, metavar="U1,V1,U2,V2,U3,V3,U4,V4",
                       help="the board's bounding polygon in pixels, the same in every image")
    where.add_argument("--bounds-file", metavar="FILE",
                       help="per-image polygons: a JSON object image path -> 2 x 4 polygon (or null: the whole "
                       "image), or a case file (a case without bounds: the whole image); paths relative to the "
                       "file's folder")
    p.add_argument("--robust", action="store_true", help="down-weight outlying junctions (robust loss)")
    cluster = p.add_mutually_exclusive_group()
    cluster.add_argument("--workers", type=_positive_int, metavar="N",
                         help="worker processes of the local cluster (default: one per core)")
    cluster.add_argument("--scheduler", metavar="ADDRESS",
                         help="run on the existing Dask cluster of this scheduler, e.g. tcp://HOST:8786")
    p.add_argument("--images-per-task", type=_positive_int, metavar="N",
                   help="images in one task (default: sized from the measured time per image, about 0.5 s of work)")
    p.add_argument("--flush-seconds", type=parse_positive, default=5.0, metavar="S",
                   help="Parquet: write waiting rows at least this often (default 5); all of them on exit or "
                   "Ctrl-C, so only a hard kill loses up to S seconds of rows, done again by the next run")
    p.add_argument("-q", "--quiet", action="store_true", help="no summary on stdout (errors still on stderr)")
    return p


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return value


def run(args) -> int:
    """Run ``graphpose batch`` with parsed ``args``; returns the exit code."""
    from .._extras import require
    from ..batch.engine import distributed_module, estimate_many
    from ..batch.inputs import collect_images, read_bounds_file
    from ..batch.results import open_results, parameters, results_format
    from ..io.records import target_keys, target_words

    kind = results_format(args.out)  # a wrong ending fails before anything is read
    recording = open_recording_input(args)
    camera, board, info = recording_camera(args, recording) if recording else (*camera_from_args(args), None)
    distributed_module()  # a missing extra is found before any image is looked at
    if kind == "parquet":
        require("pyarrow.parquet", "batch", "Parquet results")
    target = target_keys(camera, board, *camera_file(args, info))
    paths = collect_images(args.inputs) if recording is None else frame_keys(recording)
    bounds = args.bounds
    if args.bounds_file is not None:
        bounds = read_bounds_file(args.bounds_file)
        named = sum(p in bounds for p in paths)
        if not named:
            raise InputError(f"--bounds-file {args.bounds_file} names none of the {len(paths)} images "
                             f"(its paths are relative to its own folder)")
        if named < len(paths) and not args.quiet:
            print(f"graphpose batch: --bounds-file names {named} of the {len(paths)} images; the other "
                  f"{len(paths) - named} are searched in the whole image", file=sys.stderr)

    def wanted(path):  # what the row of ``path`` is to be made with
        poly = bounds.get(path) if isinstance(bounds, dict) else bounds
        return parameters({**target, "bounds": None if poly is None else poly.tolist(), "robust": args.robust})

    with open_results(args.out, flush_seconds=args.flush_seconds) as results, _interrupt_on_sigterm():
        _refuse_other_parameters(results, paths, wanted, args.out)
        todo = [p for p in paths if p not in results.done]
        kept = Counter(results.made[p][1] for p in paths if p in results.done)
        counts, seconds = Counter(), 0.0
        if todo:
            stream = estimate_many(todo, camera, board=board, bounds=bounds, robust=args.robust,
                                   client=args.scheduler, workers=args.workers,
                                   images_per_task=args.images_per_task)
            counts, seconds = _write_all(stream, results, len(todo), target["camera"],
                                         board_given=args.board is not None)
    if not args.quiet:
        print(_summary(counts, kept, seconds, args.out))
        print("camera: {}; board: {}".format(*target_words(target)))
        if info:
            print(camera_note(info))
    every = counts + kept
    if every["ok"] != sum(every.values()):  # the failure's reason on stderr, as every command's
        failed = sum(every.values()) - every["ok"]
        print(f"{prefix('batch')}: error: {failed} of {sum(every.values())} images have no pose; each row's "
              f"status and message in {args.out} say why", file=sys.stderr, flush=True)
    return EXIT_OK if every["ok"] == sum(every.values()) else EXIT_FAILED


def _refuse_other_parameters(results, paths, wanted, out) -> None:
    """InputError when ``results`` hold a row of one of ``paths`` made with other parameters
    than ``wanted(path)`` gives (:func:`graphpose.batch.results.parameters`): it is another
    result, and skipping the image would report it as this run's."""
    import json

    other = [p for p in paths if p in results.made and results.made[p][0] != wanted(p)]
    if not other:
        return
    made = results.made[other[0]][0]
    if made is None:
        what = "by a graphpose that did not record its camera and board"
    else:
        names = ("camera", "board", "bounds", "--robust")
        then, now = json.loads(made), json.loads(wanted(other[0]))
        what = "with another " + " and ".join(n for n, a, b in zip(names, then, now) if a != b)
        if then[1] != now[1]:
            what += f" ({then[1]['cols']}x{then[1]['rows']}x{then[1]['square_m']} there, " \
                    f"{now[1]['cols']}x{now[1]['rows']}x{now[1]['square_m']} now)"
    raise InputError(f"results {out} hold {len(other)} of these {len(paths)} images made {what}, e.g. {other[0]}: "
                     f"give another --out for these parameters, or remove {out} to redo them")


def _write_all(stream, results, total, camera, board_given=False):
    """Write each record of ``stream`` as it comes, its ``camera`` key the run's (which names
    the file), with a progress bar; (status counts, seconds from the first record to the last)."""
    from ..batch.work import BOARD_NOT_FOUND

    progress = Progress(total, sys.stderr)
    counts, first, last = Counter(), None, None
    quiet = logging.getLogger("distributed")
    level = quiet.level
    quiet.setLevel(logging.ERROR)  # a lost worker is Dask's to handle; its warnings are noise here
    try:
        for record in stream:
            record["camera"] = camera
            if record["status"] == BOARD_NOT_FOUND and record.get("message"):
                record["message"] = board_hint(record["message"], board_given)  # how to give the board
            results.write(record)
            counts[record["status"]] += 1
            last = time.monotonic()
            first = first or last
            done = sum(counts.values())
            rate = (done - 1) / (last - first) if last > first else 0.0
            progress.show(done, f"{rate:.1f} images/s" if rate else "")
    except KeyboardInterrupt:
        progress.clear()
        print(f"graphpose batch: stopped after {sum(counts.values())} of {total} images; the rows written stay "
              f"in {results.path}: run again to do the rest", file=sys.stderr)
        raise
    finally:
        stream.close()  # cancels what is left, stops a local cluster
        progress.clear()
        quiet.setLevel(level)
    return counts, (last - first) if first is not None else 0.0


def _summary(counts, kept, seconds, out) -> str:
    """``N images: ... ok, ...; M skipped (already in OUT[: of which ...])[; rate]``."""
    n = sum(counts.values())

    def others(c):
        return ", ".join(f"{k} {v}" for k, v in sorted(c.items(), key=lambda kv: -kv[1]) if k != "ok")

    failed = others(counts)
    line = f"{n} images: {counts['ok']} ok" + (f", {failed}" if failed else "")
    skipped = sum(kept.values())
    line += f"; {skipped} skipped (already in {out}"
    line += f": {kept['ok']} ok, {others(kept)})" if others(kept) else ")"
    if n > 1 and seconds > 0:
        line += f"; {(n - 1) / seconds:.1f} images/s"
    return line


class _interrupt_on_sigterm:
    """Within ``with``: SIGTERM (a job manager's stop) acts like Ctrl-C, so rows are flushed."""

    def __enter__(self):
        self.previous = None
        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGTERM, _raise_interrupt)
        return self

    def __exit__(self, *exc):
        if self.previous is not None:
            signal.signal(signal.SIGTERM, self.previous)


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt

#!/usr/bin/env python
"""Batch benchmark: images per second on 1 and 2 Dask workers, and what Dask costs per image.

    python scripts/bench_batch.py [--quick] [--json PATH]

Renders a set of 640 x 480 images (the bundled K; a few distinct renders named many times
through symbolic links) into a temporary folder and measures, each on a warm cluster (worker
processes started and their imports done before the clock starts):

- ``loop``: :func:`graphpose.batch.work.estimate_images` in this process, one image after
  another: the work alone;
- ``workers_1``, ``workers_2``: :func:`graphpose.batch.estimate_many` on the local cluster of
  ``graphpose batch`` (:func:`graphpose.batch.local_cluster`) with 1 and 2 single-threaded
  worker processes, images grouped automatically; the ratio of the two (goal >= 1.8 on an idle
  2-core machine: the client and the scheduler share the cores);
- ``workers_1_dask_default_environment``: 1 worker of a plain ``distributed.LocalCluster``,
  whose workers get Dask's ``MALLOC_TRIM_THRESHOLD_`` (see
  :data:`graphpose.batch.engine.WORKER_ENVIRONMENT`);
- ``overhead_ms_per_image``: the 1-worker time per image minus the loop's;
- ``one_image_per_task``: 1 worker, every image its own task; the difference from the loop is
  the cost of one task (submit, schedule, run, send back, receive);
- ``noop_tasks_per_s``: tasks that do nothing, run on 2 workers: what the scheduler (with the
  client and the workers on the same 2 cores) gets through per second, the ceiling of any
  cluster that gives it one image per task;
- ``client_us_per_row``: what the client spends on one row (receiving it, writing it as JSON
  lines or Parquet), the ceiling of a cluster whatever the grouping.

Prints the figures as JSON, and writes them to ``--json PATH`` too. Every figure is measured
in this run; the load average at the start says how busy the machine was.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SIZE = (640, 480)


def make_images(folder: Path, n_files: int, n_paths: int, seed: int = 3):
    """``n_paths`` paths (``n_files`` renders and links to them) and their polygons."""
    import imageio.v3 as iio

    from graphpose import Board
    from graphpose.io.cases import bundled_cases
    from graphpose.synth.render import loose_polygon, random_pose, render

    K, board = bundled_cases().K, Board()
    rng = np.random.default_rng(seed)
    files, polys = [], []
    for i in range(n_files):
        rendering = render(K, random_pose(rng, K, board, SIZE), board, SIZE, rng=rng)
        path = folder / f"img_{i:03d}.png"
        iio.imwrite(path, rendering.image)
        files.append(path)
        polys.append(loose_polygon(rendering, rng))
    paths, bounds = [], {}
    for k in range(n_paths):
        path = files[k] if k < n_files else folder / f"link_{k:05d}.png"
        if k >= n_files:
            os.symlink(files[k % n_files].name, path)
        paths.append(str(path))
        bounds[str(path)] = polys[k % n_files]
    return paths, bounds, K, board


def time_loop(paths, bounds, K, board):
    from graphpose.batch.work import estimate_images

    estimate_images([(paths[0], bounds[paths[0]])], K, board)  # imports and caches
    start = time.perf_counter()
    rows = estimate_images([(p, bounds[p]) for p in paths], K, board)
    seconds = time.perf_counter() - start
    return seconds, rows


def time_cluster(client, paths, bounds, K, board, **options):
    """Seconds for all of ``paths`` and what the task stream saw (tasks, worker busy time)."""
    from distributed import get_task_stream

    from graphpose.batch import estimate_many

    list(estimate_many(paths[:8], K, board, bounds=bounds, client=client, images_per_task=1))  # warm
    with get_task_stream(client) as stream:
        start = time.perf_counter()
        rows = list(estimate_many(paths, K, board, bounds=bounds, client=client, **options))
        seconds = time.perf_counter() - start
    tasks = [t for t in stream.data if str(t["key"]).startswith("graphpose-batch")]
    busy = sum(s["stop"] - s["start"] for t in tasks for s in t["startstops"] if s["action"] == "compute")
    assert sorted(r["image"] for r in rows) == sorted(paths), "a row is missing or repeated"
    return seconds, {"tasks": len(tasks), "images_per_task": len(paths) / max(len(tasks), 1),
                     "worker_compute_s": busy}


def time_rows(rows, folder: Path) -> dict:
    """Microseconds the client spends per row: receiving it (a pickle round trip) and writing
    it to JSON lines and to Parquet."""
    import pickle

    from graphpose.batch.results import open_results

    start = time.perf_counter()
    pickle.loads(pickle.dumps(rows))
    figures = {"pickle_round_trip": 1e6 * (time.perf_counter() - start) / len(rows)}
    for name in ("rows.jsonl", "rows.parquet"):
        start = time.perf_counter()
        with open_results(folder / name) as results:
            for row in rows:
                results.write(row)
        figures[name.split(".")[1] + "_write"] = 1e6 * (time.perf_counter() - start) / len(rows)
    return figures


def noop(x):
    return x


def time_noops(client, n):
    from distributed import wait

    wait(client.map(noop, range(50), pure=False))  # warm
    start = time.perf_counter()
    wait(client.map(noop, range(n), pure=False))
    return n / (time.perf_counter() - start)


def main(quick: bool = False) -> dict:
    from distributed import Client, LocalCluster

    from graphpose.batch import local_cluster

    n_files, n_paths, n_noops = (12, 300, 1000) if quick else (40, 3000, 5000)
    figures = {"quick": quick, "machine": {"cores": os.cpu_count(), "load_average_1_5_15": list(os.getloadavg()),
                                           "python": platform.python_version(), "platform": platform.platform()},
               "images": n_paths, "distinct_images": n_files, "image_size": list(SIZE)}
    with tempfile.TemporaryDirectory() as tmp:
        paths, bounds, K, board = make_images(Path(tmp), n_files, n_paths)
        loop_s, rows = time_loop(paths, bounds, K, board)
        figures["ok"] = sum(r["status"] == "ok" for r in rows)
        figures["loop"] = {"seconds": loop_s, "images_per_s": n_paths / loop_s, "ms_per_image": 1e3 * loop_s / n_paths}
        figures["image_file_kb"] = float(np.mean([os.path.getsize(p) for p in paths[:n_files]]) / 1024)
        figures["client_us_per_row"] = time_rows(rows, Path(tmp))
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as client:
            seconds, seen = time_cluster(client, paths, bounds, K, board)
            figures["workers_1_dask_default_environment"] = {"seconds": seconds, "images_per_s": n_paths / seconds,
                                                             **seen}
        for n in (1, 2):
            with local_cluster(n) as cluster, Client(cluster) as client:
                seconds, seen = time_cluster(client, paths, bounds, K, board)
                figures[f"workers_{n}"] = {"seconds": seconds, "images_per_s": n_paths / seconds, **seen}
                if n == 1:
                    one = paths[: max(n_paths // 3, 50)]
                    s1, seen1 = time_cluster(client, one, bounds, K, board, images_per_task=1)
                    per_image = s1 / len(one)
                    figures["one_image_per_task"] = {
                        "images": len(one), "seconds": s1, "images_per_s": len(one) / s1, **seen1,
                        "task_overhead_ms": 1e3 * (per_image - loop_s / n_paths)}
                else:
                    figures["noop_tasks_per_s"] = time_noops(client, n_noops)
    w1, w2 = figures["workers_1"], figures["workers_2"]
    figures["speedup_2_vs_1"] = w2["images_per_s"] / w1["images_per_s"]
    figures["speedup_goal"] = 1.8
    figures["overhead_ms_per_image"] = 1e3 * (w1["seconds"] - loop_s) / n_paths
    figures["overhead_fraction"] = (w1["seconds"] - loop_s) / loop_s
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer images (300) and no-op tasks (1000)")
    parser.add_argument("--json", metavar="PATH", help="also write the figures here")
    args = parser.parse_args()
    sys.path.insert(0, str(REPO))
    result = main(quick=args.quick)
    text = json.dumps(result, indent=1)
    print(text)
    if args.json:
        Path(args.json).write_text(text + "\n")

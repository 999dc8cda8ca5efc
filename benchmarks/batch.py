"""Batch benchmark: images per second on 1 and 2 Dask workers, and what Dask costs per image.

    python -m benchmarks batch [--quick]      (or python -m benchmarks.batch [--quick])

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

Each figure is the best of a few runs (2 with ``--quick``, else 3; the loop runs between the
cluster runs too), the least disturbed on a shared machine. Every figure is measured in this
run; the load average at the start says how busy the machine was. :func:`section` lays them
out as the page's section: the table "Measured" and the bounds "On paper" that docs/batch.md
refers to.
"""

from __future__ import annotations

import json
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

SIZE = (640, 480)


def make_images(folder: Path, n_files: int, n_paths: int, seed: int = 3):
    """``n_paths`` paths (``n_files`` renders and links to them) and their polygons."""
    import imageio.v3 as iio

    from graphpose import Board
    from graphpose.io.cases import bundled_cases
    from graphpose.synth.poses import loose_polygon, random_pose
    from graphpose.synth.render import render

    K, board = bundled_cases().K, Board()
    rng = np.random.default_rng(seed)
    files, polys = [], []
    for i in range(n_files):
        rendering = render(K, random_pose(K, board, SIZE, rng=rng), board, SIZE, rng=rng)
        path = folder / f"img_{i:03d}.png"
        iio.imwrite(path, rendering.image)
        files.append(path)
        polys.append(loose_polygon(rendering, rng=rng))
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

    list(estimate_many(paths[:8], K, board=board, bounds=bounds, client=client, images_per_task=1))  # warm
    with get_task_stream(client) as stream:
        start = time.perf_counter()
        rows = list(estimate_many(paths, K, board=board, bounds=bounds, client=client, **options))
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

    # A run's worth, each row its own objects (pickle would send a repeated one once).
    rows = [json.loads(json.dumps(rows[k % len(rows)])) for k in range(3000)]
    start = time.perf_counter()
    pickle.loads(pickle.dumps(rows))
    figures = {"rows": len(rows), "pickle_round_trip": 1e6 * (time.perf_counter() - start) / len(rows)}
    for name in ("rows.jsonl", "rows.parquet"):
        with open_results(folder / f"warm-{name}") as results:  # imports (pyarrow) outside the clock
            results.write(rows[0])
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


def best(measure, repeats):
    """The run of ``measure()`` (returning ``(seconds, details)``) with the fewest seconds: on a
    shared machine the least disturbed one."""
    return min((measure() for _ in range(repeats)), key=lambda run: run[0])


def main(quick: bool = False) -> dict:
    from distributed import Client, LocalCluster

    from graphpose.batch import local_cluster

    n_files, n_paths, n_noops, repeats = (12, 300, 1000, 2) if quick else (40, 3000, 5000, 3)
    figures = {"quick": quick, "repeats": repeats,
               "machine": {"cores": os.cpu_count(), "load_average_1_5_15": list(os.getloadavg()),
                           "python": platform.python_version(), "platform": platform.platform()},
               "images": n_paths, "distinct_images": n_files, "image_size": list(SIZE)}
    with tempfile.TemporaryDirectory() as tmp:
        paths, bounds, K, board = make_images(Path(tmp), n_files, n_paths)
        loops = [time_loop(paths, bounds, K, board)]
        rows = loops[0][1]
        figures["ok"] = sum(r["status"] == "ok" for r in rows)
        figures["image_file_kb"] = float(np.mean([os.path.getsize(p) for p in paths[:n_files]]) / 1024)
        figures["client_us_per_row"] = time_rows(rows, Path(tmp))
        one = paths[: max(n_paths // 3, 50)]
        for n in (1, 2):
            loops.append(time_loop(paths, bounds, K, board))  # the loop between the runs, as disturbed as they
            with local_cluster(n) as cluster, Client(cluster) as client:
                seconds, seen = best(lambda: time_cluster(client, paths, bounds, K, board), repeats)
                figures[f"workers_{n}"] = {"seconds": seconds, "images_per_s": n_paths / seconds, **seen}
                if n == 1:
                    s1, seen1 = best(lambda: time_cluster(client, one, bounds, K, board, images_per_task=1), repeats)
                    figures["one_image_per_task"] = {"images": len(one), "seconds": s1, "images_per_s": len(one) / s1,
                                                     **seen1}
                else:
                    figures["noop_tasks_per_s"] = max(time_noops(client, n_noops) for _ in range(repeats))
        # Last: Dask's nanny also sets its MALLOC_TRIM_THRESHOLD_ in this process's environment,
        # which every worker process started after it would inherit.
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as client:
            seconds, seen = best(lambda: time_cluster(client, paths, bounds, K, board), repeats)
            figures["workers_1_dask_default_environment"] = {"seconds": seconds, "images_per_s": n_paths / seconds,
                                                             **seen}
        loop_s = min(seconds for seconds, _ in loops)
    figures["loop"] = {"seconds": loop_s, "images_per_s": n_paths / loop_s, "ms_per_image": 1e3 * loop_s / n_paths}
    figures["one_image_per_task"]["task_overhead_ms"] = 1e3 * (
        figures["one_image_per_task"]["seconds"] / len(one) - loop_s / n_paths)
    w1, w2 = figures["workers_1"], figures["workers_2"]
    figures["speedup_2_vs_1"] = w2["images_per_s"] / w1["images_per_s"]
    figures["speedup_goal"] = 1.8
    figures["overhead_ms_per_image"] = 1e3 * (w1["seconds"] - loop_s) / n_paths
    figures["overhead_fraction"] = (w1["seconds"] - loop_s) / loop_s
    return figures


def section(f: dict) -> dict:
    """The figures of :func:`main` as a section of the benchmark (the dict :mod:`benchmarks` describes)."""
    figures = [
        {"figure": "images per second, 2 workers / 1 worker", "unit": "", "fmt": ".2f",
         "graphpose": f["speedup_2_vs_1"], "peer_name": None, "peer": None, "ratio": None,
         "goal": ">= 1.8 on an idle 2-core machine", "met": f["speedup_2_vs_1"] >= 1.8},
        {"figure": "overhead per image, 1 worker against a plain loop", "unit": "ms", "fmt": ".2f",
         "graphpose": f["overhead_ms_per_image"], "peer_name": None, "peer": None, "ratio": None,
         "goal": "small beside the work", "met": None},
    ]
    intro, rows = measured(f)
    head, columns, bounds = on_paper(f)
    blocks = [{"title": None, "text": intro, "values": {}, "columns": None, "formats": None, "rows": None},
              {"title": "Measured", "text": None, "values": {}, "columns": ["figure", "value"], "formats": ["", ""],
               "rows": rows},
              {"title": "On paper (docs/batch.md): the bounds these figures give", "text": head, "values": {},
               "columns": columns, "formats": None, "rows": bounds}]
    goal = "graphpose batch on a local Dask cluster: images per second with 1 and 2 workers, and the cost per task."
    return {"goal": goal, "figures": figures, "blocks": blocks}


def measured(f: dict):
    """The figures as the table "Measured": (a sentence on the run, rows [figure, value])."""
    w0, w1, w2, one = f["workers_1_dask_default_environment"], f["workers_1"], f["workers_2"], f["one_image_per_task"]
    rows = [
        ("work per image, plain loop in one process (t)", (f"{f['loop']['ms_per_image']:.1f} ms "
         f"({f['loop']['images_per_s']:.0f} images/s)")),
        ("1 worker, images grouped automatically", (f"{w1['images_per_s']:.1f} images/s, "
         f"{w1['images_per_task']:.1f} images a task")),
        ("2 workers, images grouped automatically", (f"{w2['images_per_s']:.1f} images/s, "
         f"{w2['images_per_task']:.1f} images a task")),
        ("2 workers / 1 worker (goal >= 1.8 when idle)", f"{f['speedup_2_vs_1']:.2f}"),
        ("overhead per image, 1 worker against the loop", (f"{f['overhead_ms_per_image']:.2f} ms "
         f"({100 * f['overhead_fraction']:.0f} %)")),
        ("1 worker, one image a task: cost of a task (o)", f"{one['task_overhead_ms']:.1f} ms"),
        ("1 worker of a plain LocalCluster (Dask's MALLOC_TRIM_THRESHOLD_)", f"{w0['images_per_s']:.1f} images/s"),
        ("no-op tasks through the scheduler, 2 workers (1/s)", (f"{f['noop_tasks_per_s']:.0f} tasks/s "
         f"({1e3 / f['noop_tasks_per_s']:.1f} ms a task)")),
        ("client per row (r): receive + JSON lines / + Parquet",
         (f"{f['client_us_per_row']['pickle_round_trip'] + f['client_us_per_row']['jsonl_write']:.0f} / "
         f"{f['client_us_per_row']['pickle_round_trip'] + f['client_us_per_row']['parquet_write']:.0f} µs")),
        ("image file (640 x 480 PNG)", f"{f['image_file_kb']:.0f} KiB"),
    ]
    load = ", ".join(f"{x:.1f}" for x in f["machine"]["load_average_1_5_15"])
    intro = (f"{f['images']} paths over {f['distinct_images']} rendered images; load average {load} "
             f"(1, 5, 15 min) on {f['machine']['cores']} cores at the start.")
    return intro, [list(row) for row in rows]


def on_paper(f: dict, task_seconds: float = 0.5):
    """The scaling bounds of docs/batch.md ("On paper") worked out from the figures: (a sentence
    naming t, o, s and r, the table's columns, its rows)."""
    t = f["loop"]["ms_per_image"] / 1e3                       # work per image, s
    o = f["one_image_per_task"]["task_overhead_ms"] / 1e3     # a task's cost beside its work, s
    s = 1.0 / f["noop_tasks_per_s"]                           # scheduler time per task (at most), s
    c = f["client_us_per_row"]
    r_json, r_pq = ((c["pickle_round_trip"] + c[k]) / 1e6 for k in ("jsonl_write", "parquet_write"))
    g = max(1, round(task_seconds / t))
    size_mb = f["image_file_kb"] * 1024 / 1e6

    def both(fn):
        return [f"{fn(1):,.0f}", f"{fn(g):,.0f}"]

    def per_worker(n):
        return n / (n * t + o)

    rows = [
        ("one worker process, images/s", *both(per_worker)),
        ("the scheduler's ceiling, images/s", *both(lambda n: n / s)),
        ("worker processes at which the scheduler becomes the limit", *both(lambda n: (n * t + o) / s)),
        ("the client's ceiling, JSON lines / Parquet, images/s", *[f"{1 / r_json:,.0f} / {1 / r_pq:,.0f}"] * 2),
        ("worker processes at which the client becomes the limit", *[
            f"{1 / r_json / per_worker(n):,.0f} / {1 / r_pq / per_worker(n):,.0f}" for n in (1, g)]),
        (f"a file system of 100 MB/s / 1 GB/s ({f['image_file_kb']:.0f} KiB an image), images/s",
         *[f"{100 / size_mb:,.0f} / {1000 / size_mb:,.0f}"] * 2),
    ]
    head = (f"With t = {1e3 * t:.1f} ms, o = {1e3 * o:.1f} ms, s <= {1e3 * s:.1f} ms and r = {1e6 * r_json:.0f} us "
            f"(JSON lines) or {1e6 * r_pq:.0f} us (Parquet):")
    columns = ["", "one image a task", f"{g} images a task (about {task_seconds:g} s)"]
    return head, columns, [list(row) for row in rows]


if __name__ == "__main__":
    import sys

    from benchmarks.cli import main as bench_main

    sys.exit(bench_main(["batch", *sys.argv[1:]]))

"""graphpose batch on a real Dask cluster of subprocesses (``dask scheduler``, two ``dask
worker``) on 127.0.0.1: the command line's rows, a client stopped mid-run and started again,
and a worker killed mid-run. The cluster and one rendered image set serve the whole module;
the cluster is stopped at its end whatever happened.
"""

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from graphpose.batch import estimate_many, read_results
from tests.batch.helpers import SubprocessCluster, check_rows, make_image_set

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    return make_image_set(tmp_path_factory.mktemp("batch-images"))


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    cluster = SubprocessCluster(tmp_path_factory.mktemp("dask-cluster"))
    try:
        yield cluster
    finally:
        cluster.stop()


def batch(*args, wait=True, **kwargs):
    """``python -m graphpose batch ARGS``: the CompletedProcess, or the Popen with ``wait=False``."""
    cmd = [sys.executable, "-m", "graphpose", "batch", *map(str, args)]
    if wait:
        return subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=300, **kwargs)
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kwargs)


def k_option(images):
    K = images.K
    return ",".join(repr(float(v)) for v in (K[0, 0], K[1, 1], K[0, 2], K[1, 2]))


def list_file(images, folder):
    path = folder / "images.txt"
    path.write_text("\n".join(images.all_paths) + "\n")
    return path


@pytest.mark.slow  # a local Dask cluster of subprocesses
def test_command_line_on_the_cluster_every_image_once(images, cluster, tmp_path):
    out = tmp_path / "results.parquet"
    done = batch(list_file(images, tmp_path), "--out", out, "--bounds-file", images.bounds_file,
                 "--K", k_option(images), "--scheduler", cluster.address)
    assert done.returncode == 1, done.stderr  # two images have no pose
    rows = read_results(out)
    check_rows(rows, images)
    assert {r["worker"] for r in rows if r["status"] == "ok"} <= set(_workers(cluster))
    assert f"{len(images.all_paths)} images: {len(images.paths)} ok" in done.stdout
    assert "0 skipped" in done.stdout
    assert f"--bounds-file names {len(images.paths)} of the {len(images.all_paths)} images" in done.stderr


def wait_for(condition, proc, timeout=120.0):
    """Poll ``condition()`` every 5 ms until true; fails if ``proc`` ends first."""
    end = time.monotonic() + timeout
    while not condition():
        assert proc.poll() is None, f"the run ended before it could be stopped: {proc.communicate()}"
        assert time.monotonic() < end, "no row was written in time"
        time.sleep(0.005)


@pytest.mark.slow  # a Dask cluster of subprocesses, killed and run again
def test_client_killed_mid_run_then_run_again_does_only_the_rest(images, cluster, tmp_path):
    out = tmp_path / "results.jsonl"
    args = [list_file(images, tmp_path), "--out", out, "--bounds-file", images.bounds_file, "--K",
            k_option(images), "--scheduler", cluster.address, "--images-per-task", "1"]
    proc = batch(*args, wait=False)
    try:
        wait_for(lambda: out.is_file() and out.read_bytes().count(b"\n") >= 1, proc)
        proc.send_signal(signal.SIGKILL)  # no chance to tidy up
    finally:
        proc.kill()
        proc.communicate()
    first = read_results(out)
    assert 0 < len(first) < len(images.all_paths)
    again = batch(*args)
    assert again.returncode == 1, again.stderr
    n = len(images.all_paths)
    assert f"{n - len(first)} images:" in again.stdout and f"{len(first)} skipped" in again.stdout
    check_rows(read_results(out), images)


@pytest.mark.slow  # a Dask cluster of subprocesses, stopped and run again
def test_client_stopped_by_sigterm_flushes_its_rows_and_resumes(images, cluster, tmp_path):
    out = tmp_path / "results.parquet"
    args = [list_file(images, tmp_path), "--out", out, "--bounds-file", images.bounds_file, "--K",
            k_option(images), "--scheduler", cluster.address, "--images-per-task", "1",
            "--flush-seconds", "0.2"]
    proc = batch(*args, wait=False)
    try:
        wait_for(lambda: any(out.glob("part-*.parquet")), proc)
        proc.send_signal(signal.SIGTERM)
        _, stderr = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 130, stderr
    assert "run again to do the rest" in stderr
    first = read_results(out)
    assert 0 < len(first) < len(images.all_paths)
    assert not list(out.glob(".*.tmp"))
    again = batch(*args)
    assert again.returncode == 1, again.stderr
    assert f"{len(first)} skipped" in again.stdout
    check_rows(read_results(out), images)


def kill_a_busy_worker(client, stream):
    """The stream's rows up to the first after which a worker has tasks in hand, which is then
    killed (SIGKILL). The stream keeps a few tasks in flight and submits more only when a row is
    taken, so the workers are asked after each row: with fast images the few in flight at one
    row may all be done before the question arrives."""
    pids = client.run(os.getpid)
    rows = []
    for row in stream:
        rows.append(row)
        busy = [address for address, keys in client.processing().items() if keys]
        if busy:
            os.kill(pids[busy[0]], signal.SIGKILL)
            return rows
    raise AssertionError("the run ended before a worker could be killed")


@pytest.mark.slow  # a Dask cluster of subprocesses, a worker killed
def test_a_worker_killed_mid_run_on_the_cluster(images, cluster):
    # allowed-failures 0: the killed worker's tasks fail (KilledWorker) and the batch runs their
    # images again one a task, on the other worker or the restarted one.
    with distributed.Client(cluster.address) as client:
        client.wait_for_workers(2, timeout=60)
        stream = estimate_many(images.all_paths, images.K, board=images.board, bounds=images.bounds, client=client,
                               images_per_task=4)
        rows = [*kill_a_busy_worker(client, stream), *stream]
        check_rows(rows, images)
        client.wait_for_workers(2, timeout=60)


@pytest.mark.slow  # a Dask cluster of subprocesses, a worker killed
def test_an_image_whose_own_task_kills_its_worker_gets_a_crashed_row(images, cluster):
    # One image a task: a task that fails (allowed-failures 0) cannot be split, so its image
    # gets a row that says why, and the others go on.
    with distributed.Client(cluster.address) as client:
        client.wait_for_workers(2, timeout=60)
        paths = images.paths[:40]
        stream = estimate_many(paths, images.K, board=images.board, bounds=images.bounds, client=client,
                               images_per_task=1)
        rows = [*kill_a_busy_worker(client, stream), *stream]
        crashed = [r["image"] for r in rows if r["status"] == "crashed"]
        assert crashed and all("KilledWorker" in r["message"] for r in rows if r["status"] == "crashed")
        check_rows([r for r in rows if r["status"] != "crashed"], images,
                   [p for p in paths if p not in crashed])
        assert sorted(r["image"] for r in rows) == sorted(paths)
        client.wait_for_workers(2, timeout=60)


def _workers(cluster):
    info = json.loads((cluster.folder / "scheduler.json").read_text())
    assert info["address"] == cluster.address
    with distributed.Client(cluster.address) as client:
        return set(client.nthreads())

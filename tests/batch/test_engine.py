"""estimate_many on a real distributed.LocalCluster of worker processes: every image once, the
single-image poses (within 1e-12: BLAS may change the last bits), failures as rows, and a worker killed mid-run.

One rendered image set and one two-process cluster serve the whole module.
"""

import os
import signal
import time

import numpy as np
import pytest

from graphpose import Board, InputError
from graphpose.batch import estimate_many, local_cluster
from graphpose.batch.work import STATUSES, estimate_images
from tests.batch.helpers import check_rows, make_image_set

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    return make_image_set(tmp_path_factory.mktemp("batch-images"))


@pytest.fixture(scope="module")
def client():
    handler = signal.getsignal(signal.SIGINT)
    cluster = local_cluster(2)  # what graphpose batch starts: a distributed.LocalCluster
    assert isinstance(cluster, distributed.LocalCluster)
    assert signal.getsignal(signal.SIGINT) is handler  # Ctrl-C still this process's
    try:
        with distributed.Client(cluster) as c:
            yield c
    finally:
        cluster.close()


@pytest.mark.slow  # a local Dask cluster interrupted
def test_local_cluster_workers_leave_ctrl_c_to_the_client(client):
    ignored = client.run(lambda: signal.getsignal(signal.SIGINT) == signal.SIG_IGN)
    assert list(ignored.values()) == [True, True]


@pytest.mark.slow  # 0.9 s or so on two idle cores: a render, a calibration or a subprocess
def test_local_cluster_workers_single_threaded_without_a_malloc_trim_threshold(client):
    names = ("MALLOC_TRIM_THRESHOLD_", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
    seen = client.run(lambda: [os.environ.get(k) for k in names])
    # Dask's nanny sets one BLAS/OpenMP thread unless this process's environment already names
    # a count, which the workers then inherit (OPENBLAS_NUM_THREADS=2 gives them two);
    # MALLOC_TRIM_THRESHOLD_ is left unset (None unless this process has one).
    expected = [os.environ.get(names[0])] + [os.environ.get(k, "1") for k in names[1:]]
    assert list(seen.values()) == [expected] * 2
    assert sorted(client.nthreads().values()) == [1, 1]
    assert all(address.startswith("tcp://127.0.0.1:") for address in seen)


@pytest.mark.slow  # a Dask cluster over 200 paths
def test_every_image_once_with_the_single_image_pose(images, client):
    rows = list(estimate_many(images.all_paths, images.K, board=images.board, bounds=images.bounds, client=client))
    check_rows(rows, images)
    assert {r["status"] for r in rows} <= set(STATUSES)
    workers = {r["worker"] for r in rows if r["status"] == "ok"}
    assert workers <= set(client.nthreads()) and len(workers) == 2  # both processes took a share
    assert all(r["time_s"] > 0 for r in rows)


@pytest.mark.slow  # a Dask worker killed and the run repeated
def test_a_worker_killed_mid_run_loses_and_repeats_nothing(images, client):
    stream = estimate_many(images.all_paths, images.K, board=images.board, bounds=images.bounds, client=client,
                           images_per_task=3)
    rows = [next(stream)]
    pids = client.run(os.getpid)
    busy = [address for address, keys in client.processing().items() if keys]
    assert busy, "the run ended before a worker could be killed"
    os.kill(pids[busy[0]], signal.SIGKILL)
    rows += list(stream)
    check_rows(rows, images)
    client.wait_for_workers(2, timeout=60)  # the nanny brings the worker back for the next test
    assert busy[0] not in client.nthreads()


@pytest.mark.slow  # 1.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_one_polygon_for_all_and_the_whole_image_for_the_rest(images, client):
    paths = images.paths[:3]
    poly = images.bounds[paths[0]]
    for bounds, polys in ((poly, [poly, poly, poly]), ({paths[0]: poly, paths[1]: None}, [poly, None, None])):
        rows = {r["image"]: r for r in estimate_many(paths, images.K, board=images.board, bounds=bounds,
                                                     client=client)}
        for path, used in zip(paths, polys):
            [want] = estimate_images([(path, used)], images.K, images.board)
            assert [rows[path][k] for k in ("status", "message", "T_WC")] == \
                [want[k] for k in ("status", "message", "T_WC")]


@pytest.mark.slow  # 2.5 s or so on two idle cores: a render, a calibration or a subprocess
def test_closing_the_stream_early_cancels_the_rest(images, client):
    stream = estimate_many(images.paths, images.K, board=images.board, bounds=images.bounds, client=client,
                           images_per_task=1)
    assert next(stream)["image"] in images.paths
    stream.close()
    ours = lambda dask_scheduler: [k for k in dask_scheduler.tasks if str(k).startswith("graphpose-batch")]
    end = time.monotonic() + 30
    while client.run_on_scheduler(ours) and time.monotonic() < end:
        time.sleep(0.1)
    assert client.run_on_scheduler(ours) == []


@pytest.mark.parametrize("kwargs, fragment", [
    ({"K": np.eye(2)}, "K"),
    ({"board": "8x6"}, "board"),
    ({"bounds": np.zeros((2, 3))}, "bounds"),
    ({"bounds": {"a.png": [[0, 1], [2, 3]]}}, "bounds of"),
    ({"workers": 0}, "workers"),
    ({"workers": 2, "client": "tcp://127.0.0.1:1"}, "local cluster"),
    ({"images_per_task": 0}, "images_per_task"),
    ({"task_seconds": -1.0}, "task_seconds"),
    ({"paths": "one.png"}, "list of image paths"),
])
@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_bad_arguments_fail_before_any_cluster_starts(images, kwargs, fragment):
    args = {"paths": ["a.png"], "K": images.K, "board": Board(), **kwargs}
    with pytest.raises(InputError, match=fragment):
        estimate_many(args.pop("paths"), args.pop("K"), board=args.pop("board"), **args)

"""Many images on a Dask cluster: groups of images as tasks, results as they arrive.

Dask (``dask.distributed``) does the scheduling, the data movement and the recovery from a
lost worker; this module only decides what a task is and keeps the cluster fed:

- A task is :func:`graphpose.batch.work.estimate_images` on a group of images. The group
  is sized from the measured time per image so that a task lasts about ``task_seconds``
  (0.5 s by default): long beside what a task costs end to end (about 10 ms measured
  here, see docs/batch.md), short enough that the last tasks spread
  over every worker and that a lost worker costs little work. The first tasks hold one
  image each, to measure; the last ones shrink so that the tail stays balanced.
- At most about two tasks per worker thread are submitted at once (plus one), so a
  million images never become a million futures, and a worker always has its next task.
- A worker that dies takes its running tasks with it; the scheduler runs them again on
  another worker, and a task's records reach the client once, when it finishes, so no
  image is lost or repeated. A task that fails anyway (``KilledWorker``: more workers died
  while running it than ``distributed.scheduler.allowed-failures`` allows) is split and its
  images run one a task; an image that still kills its worker gets a ``crashed`` row.

Dask is imported only when a batch starts: ``import graphpose.batch`` does not load it.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import itertools
import logging
import math
import os
import signal
import threading
import time
import uuid
from collections import deque

import numpy as np

from ..board import check_board
from ..board import Board
from ..camera_models import as_camera
from ..errors import GraphposeError, InputError
from .inputs import check_polygon
from .work import CRASHED, estimate_images, failed_record, warm_up

#: Default length of a task, seconds of work.
TASK_SECONDS = 0.5
#: The most images one task holds.
MAX_IMAGES_PER_TASK = 1000
#: How long to wait for the first worker of a cluster, seconds.
WORKER_TIMEOUT_S = 60.0


#: What Future.result() raises for a cancelled task (concurrent.futures' in current Dask).
_CANCELLED = (concurrent.futures.CancelledError, asyncio.CancelledError)


class ClusterError(GraphposeError):
    """The Dask cluster could not run the batch: no worker came, or the scheduler went away."""


def estimate_many(paths, camera, *, board: Board = Board(), bounds=None, robust: bool = False, client=None,
                  workers: int | None = None, images_per_task: int | None = None,
                  task_seconds: float = TASK_SECONDS):
    """Estimate the camera pose in many images on a Dask cluster; records as they arrive.

    Each image gets what ``graphpose estimate IMAGE [--bounds POLYGON]`` gives it (the same
    pose, up to the last bits that BLAS's thread count and kernel may change: docs/batch.md), as a record of :func:`graphpose.batch.work.estimate_images`: the
    keys of ``estimate --json``, ``status`` one of :data:`graphpose.batch.work.STATUSES`,
    ``time_s`` and ``worker``. One image's failure is its record's status, never an
    exception.

    Parameters
    ----------
    paths : iterable of str or Path
        The images, one record each. Made absolute here (``os.path.abspath``): the workers
        read them by that path, so on a cluster of several machines it must name the same
        file on every one (a shared file system).
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`, e.g. from
        :func:`graphpose.io.cameras.read_camera`; the images raw, with its lens
        distortion), or pinhole intrinsics ``K``, pixels, for undistorted images.
    board : Board
        The target.
    bounds : (2, 4) array_like, dict or None
        The board's bounding polygon in pixels (as ``estimate --bounds``): one for every
        image; or a dict from image path (made absolute) to polygon or None; None (for the
        image, or for all) searches the whole image (as ``graphpose estimate IMAGE`` without
        ``--bounds``). A polygon narrows the search and names junction 0's corner.
    robust : bool
        Down-weight outlying junctions (as ``estimate --robust``).
    client : distributed.Client, str or None
        The cluster: a connected client; a scheduler address (``"tcp://host:8786"``), to
        which a client is connected and closed again at the end; or None for a local
        cluster of ``workers`` worker processes on 127.0.0.1, started here and stopped at
        the end.
    workers : int, optional
        Worker processes of the local cluster (one thread each); default the cores this
        process may use. Only with ``client=None``.
    images_per_task : int, optional
        Images in one task; default: sized to last about ``task_seconds``.
    task_seconds : float
        The work a task should hold, seconds (when ``images_per_task`` is None).

    Returns
    -------
    iterator of dict
        One record per image, in the order they finish. The cluster starts on the first
        ``next()``; closing the iterator (or leaving a ``for`` loop early) cancels the
        remaining work and stops a cluster started here.

    Raises
    ------
    InputError
        On a malformed camera, board, polygon or option, or when Dask is not installed.
    ClusterError
        While iterating: no worker joined within :data:`WORKER_TIMEOUT_S`, or the scheduler
        was lost.
    """
    camera = as_camera(camera)
    board = check_board(board)
    items = _items(paths, bounds)
    if workers is not None:
        if client is not None:
            raise InputError("workers sets the size of a local cluster; it goes with client=None")
        _check_positive_int(workers, "workers")
    if images_per_task is not None:
        _check_positive_int(images_per_task, "images_per_task")
    if not (isinstance(task_seconds, (int, float)) and np.isfinite(task_seconds) and task_seconds > 0):
        raise InputError(f"task_seconds must be a positive number, got {task_seconds!r}")
    distributed_module()  # fail now, not at the first next(), when Dask is missing
    return _stream(items, camera, board, robust, client, workers, images_per_task, float(task_seconds))


def distributed_module():
    """``distributed`` (Dask's), or InputError saying how to install it."""
    from .._extras import require

    return require("distributed", "batch", "graphpose batch (Dask)")


#: Dask's nanny sets these in a worker process's environment; None leaves one unset. Dask sets
#: MALLOC_TRIM_THRESHOLD_=65536 to hand freed memory back to the system sooner, but any fixed
#: value also stops glibc from raising its mmap threshold, so every image-sized array is then a
#: fresh mmap whose pages are faulted in: the estimate took about twice as long in such a worker
#: as in a plain process (docs/batch.md). Dask's one thread per BLAS/OpenMP stays. A value in
#: this process's own environment is still inherited (Dask's nanny puts its value there too, so
#: a plain LocalCluster started earlier in the same process passes it on).
WORKER_ENVIRONMENT = {"MALLOC_TRIM_THRESHOLD_": None}


def local_cluster(workers: int | None = None):
    """A Dask ``LocalCluster`` of ``workers`` processes (default: the usable cores), one
    thread each, listening on 127.0.0.1 only (its HTTP server at a free port), with the
    worker environment of :data:`WORKER_ENVIRONMENT`.

    The worker processes ignore SIGINT: Ctrl-C in a terminal reaches every process of the
    foreground group, and it is the client's to act on (it stops the cluster); the workers
    would otherwise each die with a traceback.
    """
    import dask

    distributed = distributed_module()
    n = workers if workers is not None else len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") \
        else (os.cpu_count() or 1)
    environ = {f"distributed.nanny.pre-spawn-environ.{k}": v for k, v in WORKER_ENVIRONMENT.items()}
    # read by each nanny as it is made, and kept for its restarts
    with dask.config.set(environ), _sigint_ignored_by_children():
        return distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                        dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR)


@contextlib.contextmanager
def _sigint_ignored_by_children():
    """Ignore SIGINT while processes are started, which inherit that (Python keeps an
    inherited SIG_IGN for SIGINT); this process's own handler is restored after."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _items(paths, bounds) -> list:
    if isinstance(paths, (str, os.PathLike)):
        raise InputError("paths must be a list of image paths, not one path")
    paths = [os.path.abspath(os.fspath(p)) for p in paths]
    if bounds is None:
        return [(p, None) for p in paths]
    if isinstance(bounds, dict):
        table = {os.path.abspath(os.fspath(k)): v for k, v in bounds.items()}
        return [(p, None if table.get(p) is None else check_polygon(table[p], f"bounds of {p}")) for p in paths]
    poly = check_polygon(bounds, "bounds")
    return [(p, poly) for p in paths]


def _check_positive_int(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InputError(f"{name} must be an integer >= 1, got {value!r}")


def _stream(items, camera, board, robust, client, workers, images_per_task, task_seconds):
    """The generator behind :func:`estimate_many` (arguments checked)."""
    if not items:
        return
    distributed = distributed_module()
    owned = []
    try:
        if client is None:
            cluster = local_cluster(workers)
            owned.append(cluster)
            client = distributed.Client(cluster)
            owned.append(client)
        elif isinstance(client, str):
            try:
                client = distributed.Client(client, timeout=WORKER_TIMEOUT_S)
            except (OSError, TimeoutError) as exc:
                raise ClusterError(f"cannot reach the Dask scheduler at {client}: {exc}") from None
            owned.append(client)
        yield from _Feeder(client, items, camera, board, robust, images_per_task, task_seconds).run()
    finally:
        for thing in reversed(owned):
            with contextlib.suppress(Exception):  # closing after an interrupt may fail; nothing to save
                thing.close()


class _Feeder:
    """Keeps the cluster fed with tasks and hands back their records (see the module docstring)."""

    def __init__(self, client, items, camera, board, robust, images_per_task, task_seconds):
        self.client, self.camera, self.board, self.robust = client, camera, board, robust
        self.fixed, self.task_seconds = images_per_task, task_seconds
        self.queue = deque(items)   # not yet submitted
        self.singles = deque()      # images of a failed task, to run one a task
        self.running = {}           # future -> its items
        self.per_image = None       # seconds of work per image, smoothed
        self.keys = (f"graphpose-batch-{uuid.uuid4().hex[:8]}-{k}" for k in itertools.count())
        self.threads, self.counted = 1, -math.inf

    def run(self):
        from distributed import as_completed

        self._count_threads(wait=True)
        try:  # the workers there now; one that joins later warms up on its first task
            self.client.run(warm_up)
        except Exception as exc:  # noqa: BLE001  (whatever a worker raised, e.g. ModuleNotFoundError)
            raise ClusterError(f"a Dask worker cannot run graphpose ({type(exc).__name__}: {exc}); every "
                               f"worker needs graphpose installed, with the batch extra") from None
        finished = as_completed()
        try:
            self._submit(finished)
            for future in finished:
                records = self._records(future, self.running.pop(future))
                del future  # let the cluster forget the task's result
                yield from records
                self._count_threads()
                self._submit(finished)
        finally:
            if self.running:
                with contextlib.suppress(Exception):  # the connection may already be gone
                    self.client.cancel(list(self.running))
                self.running.clear()

    def _records(self, future, items) -> list:
        """The finished task's records; none when its images go back to run one a task."""
        try:
            records = future.result()  # waits if the result was lost with a worker and is redone
        except _CANCELLED:
            raise ClusterError("the Dask scheduler dropped a task (cancelled); the rows written so far "
                               "are kept, run again to do the rest") from None
        except Exception as exc:  # noqa: BLE001  (the task failed: KilledWorker, or a worker-side fault)
            if len(items) > 1:
                self.singles.extend(items)
                return []
            path, bounds = items[0]
            return [failed_record(path, CRASHED, f"the worker failed on this image: "
                                  f"{type(exc).__name__}: {' '.join(str(exc).split())}",
                                  self.camera, self.board, bounds, self.robust)]
        self._learn(records)
        return records

    def _count_threads(self, wait=False):
        """Worker threads of the cluster, asked again every few seconds (workers come and go)."""
        now = time.monotonic()
        if now - self.counted < 5.0:
            return
        if wait:
            try:
                self.client.wait_for_workers(1, timeout=WORKER_TIMEOUT_S)
            except TimeoutError:
                raise ClusterError(f"no Dask worker joined the scheduler {self.client.scheduler.address} "
                                   f"within {WORKER_TIMEOUT_S:g} s") from None
        self.threads = max(1, sum(self.client.nthreads().values()))
        self.counted = now

    def _submit(self, finished):
        while (self.queue or self.singles) and len(self.running) < 2 * self.threads + 1:
            if self.singles:
                items = [self.singles.popleft()]
            else:
                n = min(self._group_size(), len(self.queue))
                items = [self.queue.popleft() for _ in range(n)]
            future = self.client.submit(estimate_images, items, self.camera, self.board, self.robust,
                                        key=next(self.keys), pure=False)
            self.running[future] = items
            finished.add(future)

    def _group_size(self) -> int:
        """Images in the next task: the fixed number, or about ``task_seconds`` of work, fewer
        at the end so that every thread gets a share of what is left."""
        if self.fixed is not None:
            return self.fixed
        if self.per_image is None:
            return 1  # nothing measured yet
        n = int(self.task_seconds / max(self.per_image, 1e-6))
        tail = math.ceil(len(self.queue) / (2 * self.threads))
        return int(np.clip(min(n, tail), 1, MAX_IMAGES_PER_TASK))

    def _learn(self, records):
        times = [r["time_s"] for r in records if r.get("time_s") is not None]
        if times:
            t = float(np.median(times))  # the median skips a worker's first, slower image
            self.per_image = t if self.per_image is None else 0.7 * self.per_image + 0.3 * t

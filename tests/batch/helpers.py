"""Shared by the batch tests: a rendered image set with its expected poses, and a Dask cluster
of subprocesses on 127.0.0.1 that is always stopped.

The image set renders a few 320 x 240 images (the bundled K scaled by a half) and names each
many times through symbolic links, so that 200 paths, each its own row, cost a dozen renders;
the expected result of every distinct file comes from :func:`graphpose.estimate.estimate_pose`
in this process, the single-image path the batch must reproduce: to within 1e-12 (see
:func:`assert_same_pose`), not bit for bit, since a worker's BLAS may run another thread count
or kernel than this process's and change the last bits.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import imageio.v3 as iio
import numpy as np

from graphpose import Board
from graphpose.image import read_image
from graphpose.io.cases import bundled_cases
from graphpose.estimate import estimate_pose
from graphpose.synth.poses import loose_polygon, random_pose
from graphpose.synth.render import render

SIZE = (320, 240)


def half_K() -> np.ndarray:
    """The bundled example's K for images of half its size."""
    return np.diag([0.5, 0.5, 1.0]) @ bundled_cases().K


@dataclass
class ImageSet:
    """``paths`` (absolute str, in order; each its own row), ``bounds`` (path -> (2, 4)),
    ``expected`` (path -> the single-image PoseEstimate), ``corrupt`` and ``missing`` (two
    more paths: a file that is no image, and no file), ``bounds_file`` (JSON of ``bounds``
    with paths relative to its folder), K and the board."""

    paths: list
    bounds: dict
    expected: dict
    corrupt: str
    missing: str
    bounds_file: Path
    K: np.ndarray
    board: Board

    @property
    def all_paths(self) -> list:
        """The good paths, then the corrupt and the missing one."""
        return [*self.paths, self.corrupt, self.missing]


def make_image_set(folder: Path, n_files: int = 10, n_paths: int = 198, seed: int = 7) -> ImageSet:
    """Render ``n_files`` images into ``folder`` and name them ``n_paths`` times in all."""
    folder.mkdir(parents=True, exist_ok=True)
    K, board = half_K(), Board()
    rng = np.random.default_rng(seed)
    files, polys, estimates = [], [], []
    for i in range(n_files):
        rendering = render(K, random_pose(K, board, SIZE, rng=rng), board, SIZE, rng=rng)
        path = folder / f"img_{i:02d}.png"
        iio.imwrite(path, rendering.image)
        poly = loose_polygon(rendering, rng=rng)
        files.append(path)
        polys.append(poly)
        estimates.append(estimate_pose(read_image(path, as_float=False), K, bounds=poly, board=board))
    assert all(e.ok for e in estimates), "the seed must give images that all have a pose"
    paths, bounds, expected = [], {}, {}
    for k in range(n_paths):
        i = k % n_files
        path = files[i] if k < n_files else folder / f"link_{k:03d}.png"
        if k >= n_files:
            os.symlink(files[i].name, path)
        paths.append(str(path))
        bounds[str(path)] = polys[i]
        expected[str(path)] = estimates[i]
    corrupt = folder / "corrupt.png"
    corrupt.write_bytes(b"\x89PNG\r\n\x1a\n" + b"not really a png" * 8)
    bounds_file = folder / "bounds.json"
    bounds_file.write_text(json.dumps({os.path.basename(p): b.tolist() for p, b in bounds.items()}))
    return ImageSet(paths, bounds, expected, str(corrupt), str(folder / "missing.png"), bounds_file, K, board)


def check_rows(rows, image_set: ImageSet, paths=None) -> dict:
    """Assert one row per path of ``paths`` (default: all, corrupt and missing included) and
    nothing else, each good path's pose identical to the single-image estimate, the corrupt
    file ``unreadable`` and the missing one ``missing``, both with a message; returns
    path -> row."""
    paths = image_set.all_paths if paths is None else paths
    names = [r["image"] for r in rows]
    assert len(names) == len(set(names)), "an image has more than one row"
    assert sorted(names) == sorted(paths)
    by_path = {r["image"]: r for r in rows}
    for path in paths:
        row = by_path[path]
        if path == image_set.corrupt:
            assert row["status"] == "unreadable" and "cannot read image" in row["message"]
            assert row["T_WC"] is None
        elif path == image_set.missing:
            assert row["status"] == "missing" and "not found" in row["message"]
            assert row["T_WC"] is None
        else:
            e = image_set.expected[path]
            assert row["status"] == "ok", (path, row["message"])
            assert_same_pose(row, e)
    return by_path


#: How closely a row's pose must match the single-image estimate: BLAS (OpenBLAS's thread count
#: and the kernel it picks for the CPU, OPENBLAS_CORETYPE) changes the last bits of the small
#: products, about 1e-16 relative; the pose is well conditioned, so 1e-12 is many times that
#: and far below any real difference (a changed junction moves the pose by ~1e-6 m).
POSE_TOLERANCE = 1e-12


def assert_same_pose(row: dict, estimate) -> None:
    """Assert that a result row holds ``estimate``'s pose (a PoseEstimate): T_WC, its 1-sigma,
    the RMS within :data:`POSE_TOLERANCE` (relative for the sigma, whose conditioning is the
    covariance's), the junctions used exactly."""
    np.testing.assert_allclose(np.array(row["T_WC"]), estimate.T_WC, rtol=0, atol=POSE_TOLERANCE)
    np.testing.assert_allclose(np.array(row["sigma_xyz_m"]), estimate.sigma_xyz_m, rtol=1e3 * POSE_TOLERANCE, atol=0)
    np.testing.assert_allclose(row["reprojection_rms_px"], estimate.rms_px, rtol=0, atol=POSE_TOLERANCE)
    assert row["junctions_used"] == int(np.count_nonzero(estimate.mask))


class SubprocessCluster:
    """``dask scheduler`` and ``dask worker`` subprocesses on 127.0.0.1, ports chosen by the
    system (port 0, the address read from the scheduler file). :meth:`stop` ends exactly the
    processes (and their process groups) started here; use it in a ``finally``.

    The scheduler gives up on a task after one lost worker (allowed-failures 0), so that a
    killed worker takes the batch's own recovery path (a failed task split into single
    images), not only Dask's."""

    def __init__(self, folder: Path, n_workers: int = 2):
        self.folder, self.procs = folder, []
        self.scheduler_file = folder / "scheduler.json"
        env = dict(os.environ, DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES="0")
        dask = [sys.executable, "-m", "dask"]
        try:
            # --no-dashboard still serves HTTP (health, metrics): on 127.0.0.1 too, at a free port.
            http = ["--no-dashboard", "--dashboard-address", "127.0.0.1:0"]
            self._start(dask + ["scheduler", "--host", "127.0.0.1", "--port", "0", *http,
                                "--scheduler-file", str(self.scheduler_file), "--idle-timeout", "600"], env, "scheduler")
            self.address = self._wait_for_address()
            for k in range(n_workers):
                self._start(dask + ["worker", "--scheduler-file", str(self.scheduler_file), "--host", "127.0.0.1",
                                    "--nthreads", "1", *http, "--name", f"w{k}", "--death-timeout", "60"],
                            env, f"worker{k}")
            self._wait_for_workers(n_workers)
        except BaseException:
            self.stop()
            raise

    def _start(self, cmd, env, name):
        log = open(self.folder / f"{name}.log", "wb")  # noqa: SIM115  (closed in stop())
        self.procs.append((subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT,
                                            stdin=subprocess.DEVNULL, start_new_session=True), log))

    def _wait_for_address(self, timeout=60.0) -> str:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if self.scheduler_file.is_file():
                try:
                    return json.loads(self.scheduler_file.read_text())["address"]
                except (ValueError, KeyError):
                    pass  # being written
            if self.procs[0][0].poll() is not None:
                raise RuntimeError(f"dask scheduler exited: {self.log('scheduler')}")
            time.sleep(0.05)
        raise TimeoutError(f"dask scheduler wrote no address in {timeout} s: {self.log('scheduler')}")

    def _wait_for_workers(self, n, timeout=90.0):
        from distributed import Client

        with Client(self.address, timeout=timeout) as client:
            client.wait_for_workers(n, timeout=timeout)

    def log(self, name) -> str:
        path = self.folder / f"{name}.log"
        return path.read_text(errors="replace")[-2000:] if path.is_file() else ""

    def stop(self):
        """End every process started here (SIGTERM to its group, then SIGKILL)."""
        for proc, _ in reversed(self.procs):
            if proc.poll() is None:
                _signal_group(proc, signal.SIGTERM)
        end = time.monotonic() + 15.0
        for proc, log in reversed(self.procs):
            try:
                proc.wait(timeout=max(0.1, end - time.monotonic()))
            except subprocess.TimeoutExpired:
                _signal_group(proc, signal.SIGKILL)
                proc.wait(timeout=10)
            _signal_group(proc, signal.SIGKILL)  # a worker left behind by its nanny
            log.close()
        self.procs = []


def _signal_group(proc, sig):
    try:
        os.killpg(proc.pid, sig)  # the group this process leads (start_new_session)
    except (ProcessLookupError, PermissionError):
        pass

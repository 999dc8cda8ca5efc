"""One task's work: estimate the pose in a group of images, one result record per image.

:func:`estimate_images` is what a Dask worker runs (and what a plain loop runs, for a
comparison): for each image it does what ``graphpose estimate IMAGE [--bounds ...]`` does
(:func:`graphpose.image.read_image`, then :func:`graphpose.estimate.estimate_pose`) and
turns the outcome into the record of :func:`graphpose.io.records.result_record`, so the pose
of a row is the pose that command gives for that image (up to the last bits BLAS may change,
docs/batch.md). A failure of one image
becomes that image's row and never stops the others. The record's ``status`` says why an
image has no usable pose (:data:`STATUSES`), where ``estimate --json`` only says ``failed``;
the record names what the pose was made with, as every record does (``camera`` and
``board``, :func:`graphpose.io.records.target_keys`), and four keys are added: ``bounds``
(the polygon the image was searched in, 2 x 4 pixels, or None: the whole image), ``robust``
(the robust loss or not), ``time_s`` (seconds spent on the image) and ``worker`` (the Dask
worker's address, None outside Dask). ``camera``, ``board``, ``bounds`` and ``robust`` are
what makes the result: :func:`graphpose.batch.results.parameters` of a row.

This module imports neither Dask nor GTSAM until it runs.
"""

from __future__ import annotations

import os
import sys
import time

from ..board import Board
from ..io.records import result_record, target_keys
from ..io.sources import parse_frame_key
from ..errors import BoardNotFoundError, GraphposeError

#: Status words of a row, from best to worst.
OK = "ok"                            # a converged, cross-checked pose
NOT_CONVERGED = "not_converged"      # a pose, but not a reliable one (``message`` says why); kept
BOARD_NOT_FOUND = "board_not_found"  # no junction grid of the board inside the polygon
FAILED = "failed"                    # another estimation failure (too few trusted junctions, ...)
MISSING = "missing"                  # no such file (as the worker sees the file system)
UNREADABLE = "unreadable"            # the file is not an image the readers decode
ERROR = "error"                      # an unexpected exception: a bug, reported with its type
CRASHED = "crashed"                  # the worker process died on this image, again and again

STATUSES = (OK, NOT_CONVERGED, BOARD_NOT_FOUND, FAILED, MISSING, UNREADABLE, ERROR, CRASHED)

#: Keys a batch record adds to :func:`graphpose.io.records.result_record`'s and
#: :func:`graphpose.io.records.target_keys`' ``camera`` and ``board``.
EXTRA_KEYS = ("bounds", "robust", "time_s", "worker")


def estimate_images(items, camera, board: Board = Board(), robust: bool = False) -> list:
    """Estimate the pose in each image of ``items``; one record per image, in order.

    Parameters
    ----------
    items : sequence of (str, (2, 4) ndarray or None)
        Image path (as the process running this sees it) and the board's bounding polygon in
        pixels, or None to search the whole image (as ``graphpose estimate IMAGE`` without
        ``--bounds``).
    camera : Camera or (3, 3) ndarray
        The camera model (:mod:`graphpose.camera_models`; images raw, with its lens distortion), or
        pinhole intrinsics ``K``, pixels, for undistorted images (checked by the caller).
    board : Board
        The target.
    robust : bool
        As :func:`graphpose.estimate.estimate_pose`.

    Returns
    -------
    list of dict
        JSON-ready records (see the module docstring); never raises for one image's failure.
    """
    from ..image import read_image
    from ..estimate import estimate_pose

    worker = _worker_address()
    target = target_keys(camera, board)
    records, opened = [], {}  # opened: the recordings this task reads frames of, each opened once
    for path, bounds in items:
        start = time.perf_counter()
        estimate, status, message, frame = None, OK, None, parse_frame_key(path)
        try:
            if frame is None and not os.path.isfile(path):
                status, message = MISSING, f"image file not found: {path}"
            else:
                try:
                    image, frame = (read_image(path, as_float=False), None) if frame is None else \
                        _read_frame(opened, *frame)
                except GraphposeError as exc:
                    status, message = UNREADABLE, _one_line(exc)
                else:
                    estimate = estimate_pose(image, camera, bounds=bounds, board=board, robust=robust)
                    if not estimate.ok:
                        status, message = NOT_CONVERGED, f"no reliable pose: {estimate.message}"
        except BoardNotFoundError as exc:
            status, message = BOARD_NOT_FOUND, _one_line(exc)
        except GraphposeError as exc:
            status, message = FAILED, _one_line(exc)
        except Exception as exc:  # noqa: BLE001  (one image's bug must not stop the batch)
            status, message = ERROR, f"{type(exc).__name__}: {_one_line(exc)}"
        record = result_record(path, estimate, message)
        if frame is not None:  # a recording's frame: its index and time
            record["frame"], record["timestamp"] = frame
        record["status"] = status
        record.update(target, bounds=None if bounds is None else bounds.tolist(), robust=bool(robust),
                      time_s=time.perf_counter() - start, worker=worker)
        records.append(record)
    for recording in opened.values():
        recording.close()
    return records


def _read_frame(opened, path, topic, k):
    """Frame ``k`` of the recording ``path`` (opened once a task, then read forward or seeking)
    and ``(k, its timestamp)``."""
    from ..io.sources import open_frames

    if (path, topic) not in opened:
        opened[path, topic] = open_frames(path, topic=topic)
    frame = opened[path, topic].read(k)
    return frame.image, (k, frame.timestamp)


def warm_up() -> None:
    """Import what :func:`estimate_images` needs, so that a worker's first image is not slower."""
    from skimage import io  # noqa: F401  (read_image's reader, imported on first use)

    from .. import estimate  # noqa: F401  (estimate_pose, with the detector and the solvers)


def failed_record(path, status: str, message: str, camera=None, board: Board = Board(), bounds=None,
                  robust: bool = False) -> dict:
    """The record of an image that has no result from a worker (e.g. :data:`CRASHED`), with
    the parameters it was to be estimated with (``camera`` None: no ``camera`` nor ``board``)."""
    record = result_record(path, None, message)
    record["status"] = status
    record.update(target_keys(camera, board) if camera is not None else {"camera": None, "board": None})
    record.update(bounds=None if bounds is None else bounds.tolist(), robust=bool(robust), time_s=None, worker=None)
    return record


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _worker_address():
    """The address of the Dask worker running this, or None outside one."""
    distributed = sys.modules.get("distributed")  # a worker has imported it; nothing else need
    if distributed is None:
        return None
    try:
        return distributed.get_worker().address
    except ValueError:
        return None

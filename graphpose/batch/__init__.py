"""Pose estimates for many images, on a Dask cluster: one row per image, resumable.

- :func:`estimate_many` (:mod:`graphpose.batch.engine`) runs
  :func:`graphpose.estimate.estimate_pose` on each image on a local or remote Dask
  cluster and yields one record per image as results arrive;
- :mod:`graphpose.batch.work` is what a worker runs, and says what a record holds (the
  ``estimate --json`` keys, a status word per failure, the time);
- :mod:`graphpose.batch.results` writes the records as they arrive to a Parquet data set or
  JSON lines, knows which images a result set already has, and reads it back;
- :mod:`graphpose.batch.inputs` turns folders, glob patterns and list files into image
  paths, and reads per-image bounding polygons.

``graphpose batch`` (:mod:`graphpose.cli.batch`) is the command line; docs/batch.md the
guide. Dask and pyarrow are the optional ``batch`` extra (``pip install "graphpose[batch]"``, or ``pip install -e ".[batch]"`` in a checkout)
and are imported only when used: the names below load on first use.
"""

from __future__ import annotations

from .._lazy import lazy_getattr

#: Public name -> the module of this package that defines it (imported lazily, PEP 562).
_EXPORTS = {
    "estimate_many": "engine",
    "local_cluster": "engine",
    "ClusterError": "engine",
    "estimate_images": "work",
    "STATUSES": "work",
    "collect_images": "inputs",
    "read_bounds_file": "inputs",
    "open_results": "results",
    "read_results": "results",
}

__all__ = [
    "STATUSES",
    "ClusterError",
    "collect_images",
    "estimate_images",
    "estimate_many",
    "local_cluster",
    "open_results",
    "read_bounds_file",
    "read_results",
]

__getattr__ = lazy_getattr(__name__, _EXPORTS)


def __dir__():
    return __all__

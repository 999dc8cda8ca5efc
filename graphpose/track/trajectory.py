"""A trajectory beside its truth: poses associated by timestamp, and their per-frame errors.

The command line (``graphpose track --truth``) and the benchmark's tracking section both judge
a tracked trajectory by these two functions, as evo keeps association and error in its
``core.sync`` and ``core.metrics``: :func:`associate` finds each frame's true pose by its
timestamp, :func:`trajectory_errors` measures each frame's position and rotation error with
:func:`graphpose.geometry.pose_difference`. No alignment is made: the target frame is the
world frame of both.
"""

from __future__ import annotations

import numpy as np

from ..geometry import pose_difference

#: Largest timestamp difference (s) of an association, if half the shortest frame interval is longer.
MAX_TIME_DIFFERENCE_S = 0.01


def associate(times, poses, timestamps) -> np.ndarray:
    """The poses at the frames' timestamps: the nearest in time, or NaN if none is close.

    Parameters
    ----------
    times : (m,) array_like
        Timestamps of ``poses``, seconds, in any order.
    poses : (m, 4, 4) array_like
        Poses T_WC (e.g. a TUM file's, :func:`graphpose.io.tum.read_tum`).
    timestamps : (n,) array_like
        The frames' timestamps, seconds, increasing.

    Returns
    -------
    (n, 4, 4) ndarray
        Per frame the pose whose time is nearest, if it lies within
        :data:`MAX_TIME_DIFFERENCE_S` and half the shortest frame interval; all NaN otherwise.
    """
    timestamps = np.asarray(timestamps, dtype=float)
    step = np.min(np.diff(timestamps)) if timestamps.size > 1 else np.inf
    tolerance = min(MAX_TIME_DIFFERENCE_S, 0.5 * step)
    order = np.argsort(times)
    times, poses = np.asarray(times, dtype=float)[order], np.asarray(poses, dtype=float)[order]
    out = np.full((timestamps.size, 4, 4), np.nan)
    if times.size == 0:
        return out
    right = np.clip(np.searchsorted(times, timestamps), 1, max(times.size - 1, 1))
    left = right - 1
    nearest = np.where(np.abs(times[np.minimum(right, times.size - 1)] - timestamps) < np.abs(times[left] - timestamps),
                       np.minimum(right, times.size - 1), left)
    close = np.abs(times[nearest] - timestamps) <= tolerance
    out[close] = poses[nearest[close]]
    return out


def trajectory_errors(poses, truth) -> np.ndarray:
    """Per-frame position and rotation errors of a trajectory against its truth.

    Parameters
    ----------
    poses, truth : (n, 4, 4) array_like
        Estimated and true poses T_WC, frame by frame; NaN where a frame has none.

    Returns
    -------
    (n, 2) ndarray
        Per frame the position error (metres) and the rotation angle error (degrees), by
        :func:`graphpose.geometry.pose_difference`; NaN where either pose is missing.
    """
    out = np.full((len(poses), 2), np.nan)
    for k, (T, T_true) in enumerate(zip(poses, truth)):
        if np.all(np.isfinite(T)) and np.all(np.isfinite(T_true)):
            out[k] = pose_difference(T, T_true)
    return out

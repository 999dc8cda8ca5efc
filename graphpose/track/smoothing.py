"""Batch smoothing of a whole sequence, after either online back end
(:mod:`graphpose.track.backend`).

Every frame adds a fixed number of factors next to the newest poses
(:class:`graphpose.track.model.FactorBuilder`). At the end the whole sequence can be smoothed
in batch (Levenberg-Marquardt from the online estimates) with
marginal covariances from ``gtsam.Marginals``: :func:`smooth_frames`, which rebuilds the
graph from the frames' measurements (the fixed lag's way, since it no longer holds the old
factors), or :func:`smooth_graph` on a graph already whole (the whole-sequence back end's).
Covariances are reported in the pose parameters
``(x, y, z, roll, pitch, yaw)`` of :mod:`graphpose.geometry` (metres, radians).
"""

from __future__ import annotations

import gtsam
import numpy as np
from gtsam.symbol_shorthand import V, X

from ..board import Board
from ..camera_models import as_camera
from ..pose.graph import LANDMARK_SIGMA_M, params_cov_from_tangent
from .config import MotionPrior
from .model import FactorBuilder
from .results import BackendResult


def smooth_frames(camera, board: Board, motion: MotionPrior, target: str, measurements, initial: dict,
                  velocities: dict | None = None, landmark_sigma_m: float = LANDMARK_SIGMA_M) -> dict:
    """Batch-smooth a whole sequence: its graph rebuilt from the frames' measurements, then
    Levenberg-Marquardt and marginal covariances from ``gtsam.Marginals``.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        The camera model, or pinhole intrinsics ``K``, pixels.
    board : Board
        The target.
    motion : MotionPrior
        Prior between consecutive frames.
    target : {"resection", "frame_landmarks", "landmarks"}
        How the fixed target enters the graph.
    measurements : sequence of FrameMeasurement
        Every frame given to the back end, in order.
    initial : dict
        ``{k: (4, 4) T_WC}``, the start of every frame's pose (the online estimates).
    velocities : dict, optional
        ``{k: (6,) body velocity}`` starts of the ``"wnoa"`` velocities (default zero).
    landmark_sigma_m : float
        Sigma of the landmark pins, metres.

    Returns
    -------
    dict
        ``{k: BackendResult}`` for every frame (``update_s`` 0).

    Raises
    ------
    InputError
        If the camera or ``target`` is invalid.
    """
    builder = FactorBuilder(as_camera(camera), board, motion, target, landmark_sigma_m)
    graph, values = builder.shared_landmarks() if target == "landmarks" else (gtsam.NonlinearFactorGraph(),
                                                                              gtsam.Values())
    for m in measurements:
        if m.new_segment:
            builder.break_segment()
        factors, new, _ = builder.frame(m.index, m.timestamp, m.points, m.ids, initial[m.index], m.pixel_sigma)
        graph.push_back(factors)
        values.insert(new)
    for k, v in (velocities or {}).items():
        if values.exists(V(k)):
            values.update(V(k), np.asarray(v, dtype=float))
    return smooth_graph(graph, values, [m.index for m in measurements])


def smooth_graph(graph, initial, frames) -> dict:
    """Levenberg-Marquardt over the whole ``graph`` from ``initial``, then every frame's pose
    and marginal covariance: ``{k: BackendResult}`` for ``frames``."""
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(1e-10)
    params.setAbsoluteErrorTol(1e-10)
    values = gtsam.LevenbergMarquardtOptimizer(graph, initial, params).optimize()
    marginals = gtsam.Marginals(graph, values)
    return {k: backend_result(values.atPose3(X(k)).matrix(), marginals.marginalCovariance(X(k))) for k in frames}


def backend_result(T: np.ndarray, cov_tangent: np.ndarray, update_s: float = 0.0) -> BackendResult:
    """A frame's :class:`~graphpose.track.results.BackendResult` from GTSAM's answer: the pose
    ``T`` (4, 4) and its covariance in ``Pose3``'s tangent (rotation then translation, rad and
    m), turned into that of ``(x, y, z, roll, pitch, yaw)``; ``update_s`` seconds."""
    return BackendResult(T, params_cov_from_tangent(T, cov_tangent), update_s)

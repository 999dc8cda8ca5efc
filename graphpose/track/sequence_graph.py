"""The whole-sequence online back end, :class:`SequenceGraph`: one iSAM2 over every frame
(``TrackerConfig(lag_s=None)``; the interface it shares with the fixed lag:
:class:`graphpose.track.backend.Backend`)."""

from __future__ import annotations

import time

import gtsam
import numpy as np
from gtsam.symbol_shorthand import X

from ..board import Board
from ..camera_models import as_camera
from ..pose.graph import LANDMARK_SIGMA_M
from .config import MotionPrior
from .isam import default_isam_params, refine_pose
from .model import FactorBuilder, FrameMeasurement
from .results import BackendResult
from .smoothing import backend_result, smooth_graph


class SequenceGraph:
    """The whole-sequence back end: one factor graph over every frame, solved with iSAM2
    (``TrackerConfig(lag_s=None)``); its per-frame cost and memory grow with the sequence.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`; raw, distorted pixels), or pinhole
        intrinsics ``K``, pixels.
    board : Board
        The target.
    motion : MotionPrior
        Prior between consecutive frames.
    target : {"resection", "frame_landmarks", "landmarks"}
        How the fixed target enters the graph (:mod:`graphpose.track.model`).
    landmark_sigma_m : float
        Standard deviation of the priors pinning the target points (the landmark forms),
        metres.
    isam_params : gtsam.ISAM2Params, optional
        iSAM2 settings; default :func:`default_isam_params`.

    Raises
    ------
    InputError
        If the camera is invalid (:func:`graphpose.camera_models.as_camera`) or ``target`` is not
        one of :data:`graphpose.track.config.TARGET_FORMS`.

    Notes
    -----
    Kept for the whole sequence: the graph, iSAM2's Bayes tree and, as the fixed lag keeps
    them, one :class:`~graphpose.track.model.FrameMeasurement` per frame
    (:attr:`measurements`; the graph itself is what :meth:`smooth` smooths).
    """

    def __init__(self, camera, board: Board, motion: MotionPrior, target: str = "resection",
                 landmark_sigma_m: float = LANDMARK_SIGMA_M, isam_params: gtsam.ISAM2Params | None = None):
        self.camera = as_camera(camera)
        self._builder = FactorBuilder(self.camera, board, motion, target, landmark_sigma_m)
        self.board, self.motion, self.target = board, motion, target
        self.lag_s = None  # no lag: the whole sequence
        self._isam = gtsam.ISAM2(isam_params if isam_params is not None else default_isam_params())
        self._graph = gtsam.NonlinearFactorGraph()
        self._pending_graph, self._pending_values = (self._builder.shared_landmarks() if target == "landmarks"
                                                     else (gtsam.NonlinearFactorGraph(), gtsam.Values()))
        self._graph.push_back(self._pending_graph)
        self._measurements: list = []

    @property
    def frames(self) -> list:
        """Frame indices in the graph, in the order they were added."""
        return [m.index for m in self._measurements]

    @property
    def measurements(self) -> tuple:
        """Every frame's :class:`~graphpose.track.model.FrameMeasurement`, in order."""
        return tuple(self._measurements)

    def break_segment(self) -> None:
        """Start a new segment: the next frame gets no motion factor (called after a loss)."""
        self._builder.break_segment()

    def add_frame(self, k: int, timestamp: float, points, ids, T_WC_init, pixel_sigma: float) -> BackendResult:
        """Add frame ``k`` and update iSAM2.

        Parameters and return as :meth:`graphpose.track.backend.Backend.add_frame` (the
        frame's incremental, filtered, estimate and its marginal covariance).
        """
        start = time.perf_counter()
        points = np.asarray(points, dtype=float)
        ids = np.asarray(ids, dtype=int)
        new_segment = not self._builder.segment  # the first frame, or the first after a break
        graph, values, _ = self._builder.frame(k, timestamp, points, ids, T_WC_init, pixel_sigma)
        self._graph.push_back(graph)
        self._pending_graph.push_back(graph)
        self._pending_values.insert(values)
        self._measurements.append(FrameMeasurement(k, float(timestamp), points, ids, float(pixel_sigma), new_segment))
        self._isam.update(self._pending_graph, self._pending_values, constrainedKeys=self._order(k, ids))
        pose = refine_pose(self._isam.update, lambda: self._isam.calculateEstimatePose3(X(k)), T_WC_init)
        cov = self._isam.marginalCovariance(X(k))
        self._pending_graph, self._pending_values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        return backend_result(pose.matrix(), cov, time.perf_counter() - start)

    def estimate(self) -> dict:
        """iSAM2's current estimate of every frame: ``{k: (4, 4) T_WC}``."""
        values = self._isam.calculateEstimate()
        return {k: values.atPose3(X(k)).matrix() for k in self.frames}

    def size(self) -> tuple:
        """``(factors, variables)`` in the graph."""
        return int(self._graph.nrFactors()), int(self._isam.size())

    def smooth(self) -> dict:
        """Batch-smooth the whole graph (Levenberg-Marquardt from iSAM2's estimate).

        Returns
        -------
        dict
            ``{k: BackendResult}`` for every frame in the graph, covariances from the full
            graph's marginals.
        """
        return smooth_graph(self._graph, self._isam.calculateEstimate(), self.frames)

    def landmark_key(self, k: int, j: int) -> int:
        """Key of frame ``k``'s copy of target point ``j`` (``"frame_landmarks"``):
        ``symbol('l', k * stride + j)``, ``stride`` = :func:`graphpose.track.model.landmark_stride`."""
        return self._builder.landmark_key(k, j)

    def _order(self, k, ids):
        """Elimination groups of an update that adds frame ``k`` (None: iSAM2's default)."""
        if self.target != "frame_landmarks":
            return None
        # iSAM2 puts every key of the new factors last, in COLAMD's order, which can leave one
        # of the frame's landmarks at the root of the Bayes tree above X(k). Its partial
        # relinearisation check walks down from the root and stops at a clique whose step is
        # small, so X(k) would never be relinearised (its online estimate stuck microns off
        # the optimum). The frame's landmarks go first (group 0, with the untouched part),
        # then the older poses of the new factors, X(k) last, at the root. Groups must stay
        # below the number of re-eliminated variables (ccolamd), at least 49 here.
        groups = gtsam.KeyGroupMap()
        groups.insert2(X(k), 2)  # insert2 never overwrites: most specific first
        for j in ids.tolist():
            groups.insert2(self.landmark_key(k, j), 0)
        for key in self._pending_graph.keyVector():
            groups.insert2(key, 1)
        return groups

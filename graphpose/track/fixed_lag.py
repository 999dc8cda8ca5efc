"""The tracker's default online back end, :class:`FixedLagGraph`: GTSAM's incremental fixed-lag
smoother over the frames of the last ``lag_s`` seconds (the interface it shares with the
whole-sequence back end: :class:`graphpose.track.backend.Backend`)."""

from __future__ import annotations

import time

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, V, X

from .._checks import check_number
from ..board import Board
from ..camera_models import as_camera
from ..errors import InputError
from ..pose.graph import LANDMARK_SIGMA_M
from .config import DEFAULT_LAG_S, MotionPrior
from .isam import fixed_lag_isam_params, refine_pose
from .model import FactorBuilder, FrameMeasurement
from .results import BackendResult
from .smoothing import backend_result, smooth_frames


class FixedLagGraph:
    """The tracker's default back end: the frames of the last ``lag_s`` seconds in GTSAM's
    incremental fixed-lag smoother (iSAM2, older variables marginalised), so that a frame
    costs the same time and memory however long the sequence.

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
    lag_s : float
        Variables older than the newest frame's timestamp minus this are marginalised,
        seconds. A second (:data:`graphpose.track.config.DEFAULT_LAG_S`) keeps
        every factor the filtered estimate of a frame feels: beyond a few frames the motion
        prior's pull is nil. Shorter than two frame intervals, the constant-velocity prior
        never finds its three poses.
    landmark_sigma_m : float
        Sigma of the landmark pins (landmark forms), metres.
    isam_params : gtsam.ISAM2Params, optional
        Settings of the smoother's iSAM2; default :func:`fixed_lag_isam_params`.
    keep_measurements : bool
        Keep every frame's :class:`FrameMeasurement`, online pose (and ``"wnoa"`` velocity)
        for :meth:`smooth` (about 2 kB a frame). Without it (the tracker's way when it does not
        smooth) the back end holds nothing per frame beyond the lag but the frame's index,
        and :meth:`smooth` refuses.

    Raises
    ------
    InputError
        If the camera is invalid, ``target`` is not one of
        :data:`graphpose.track.config.TARGET_FORMS` or ``lag_s`` is not a positive number.

    Notes
    -----
    Kept for the whole sequence: each frame's index and, with ``keep_measurements``, one
    :class:`FrameMeasurement` and the online pose per frame (about 2 kB for 48 junctions),
    for :meth:`smooth`. Everything else is bounded by the lag.
    """

    def __init__(self, camera, board: Board, motion: MotionPrior, target: str = "resection",
                 lag_s: float = DEFAULT_LAG_S, landmark_sigma_m: float = LANDMARK_SIGMA_M,
                 isam_params: gtsam.ISAM2Params | None = None, keep_measurements: bool = True):
        check_number("lag_s", lag_s, 0.0, strict=True)
        self.camera = as_camera(camera)
        self._builder = FactorBuilder(self.camera, board, motion, target, landmark_sigma_m)
        self.board, self.motion, self.target, self.lag_s = board, motion, target, float(lag_s)
        self._landmark_sigma_m = landmark_sigma_m
        params = isam_params if isam_params is not None else fixed_lag_isam_params()
        self._smoother = gtsam.IncrementalFixedLagSmoother(self.lag_s, params)
        self.keep_measurements = bool(keep_measurements)
        self._frames: list = []
        self._measurements: list = []
        self._online: dict = {}
        self._velocities: dict = {}
        self._new_segment = True
        self._shared = target == "landmarks"

    @property
    def frames(self) -> list:
        """Frame indices given to the back end, in order."""
        return list(self._frames)

    @property
    def measurements(self) -> tuple:
        """Every frame's :class:`FrameMeasurement`, in order (none without ``keep_measurements``)."""
        return tuple(self._measurements)

    def landmark_key(self, k: int, j: int) -> int:
        """Key of frame ``k``'s copy of target point ``j`` (``"frame_landmarks"``):
        ``symbol('l', k * stride + j)``, ``stride`` = :func:`graphpose.track.model.landmark_stride`."""
        return self._builder.landmark_key(k, j)

    def break_segment(self) -> None:
        """Start a new segment: the next frame gets no motion factor (called after a loss)."""
        self._builder.break_segment()
        self._new_segment = True

    def add_frame(self, k: int, timestamp: float, points, ids, T_WC_init, pixel_sigma: float) -> BackendResult:
        """Add frame ``k``, update the smoother and marginalise what the lag leaves behind.

        Parameters and return as :meth:`graphpose.track.backend.Backend.add_frame` (the
        frame's filtered estimate and marginal covariance, from the smoother).
        """
        start = time.perf_counter()
        points = np.asarray(points, dtype=float)
        ids = np.asarray(ids, dtype=int)
        timestamp = float(timestamp)
        # This update marginalises every key older than this: no new factor reaches them.
        self._builder.forget_before(timestamp - self.lag_s)
        new_segment = self._new_segment or not self._builder.segment
        graph, values, stamps = self._builder.frame(k, timestamp, points, ids, T_WC_init, pixel_sigma)
        if self._shared:
            if not self._frames:
                pins, pinned = self._builder.shared_landmarks()
                graph.push_back(pins)
                values.insert(pinned)
            for j in range(self.board.n):  # re-stamped: never marginalised
                stamps[L(j)] = timestamp
        self._smoother.update(graph, values, stamps)
        pose = refine_pose(self._smoother.update, lambda: self._smoother.calculateEstimatePose3(X(k)), T_WC_init)
        cov = self._smoother.marginalCovariance(X(k))
        T = pose.matrix()
        self._frames.append(k)
        if self.keep_measurements:
            self._measurements.append(FrameMeasurement(k, timestamp, points, ids, float(pixel_sigma), new_segment))
            self._online[k] = T
            if self._builder.segment[-1][2]:
                self._velocities[k] = self._smoother.calculateEstimateVector(V(k))
        self._new_segment = False
        return backend_result(T, cov, time.perf_counter() - start)

    def estimate(self) -> dict:
        """The smoother's current estimate of the frames still inside the lag:
        ``{k: (4, 4) T_WC}`` (older frames are marginalised)."""
        values = self._smoother.calculateEstimate()
        poses = (gtsam.Symbol(key) for key in values.keys())
        return {int(p.index()): values.atPose3(p.key()).matrix() for p in poses if chr(p.chr()) == "x"}

    def size(self) -> tuple:
        """``(factors, variables)`` the smoother holds now (marginal priors included)."""
        return int(self._smoother.getFactors().nrFactors()), int(self._smoother.getLinearizationPoint().size())

    def smooth(self) -> dict:
        """Batch-smooth the whole sequence (:func:`smooth_frames`): its graph rebuilt from the
        frames' measurements, Levenberg-Marquardt from the latest online estimates.

        Returns
        -------
        dict
            ``{k: BackendResult}`` for every frame given, covariances from the full graph's
            marginals.

        Raises
        ------
        InputError
            If the back end was made without ``keep_measurements``.
        """
        if not self.keep_measurements:
            raise InputError("this fixed-lag back end kept no measurements to smooth "
                             "(make it with keep_measurements=True)")
        initial = dict(self._online)
        initial.update(self.estimate())
        return smooth_frames(self.camera, self.board, self.motion, self.target, self._measurements, initial,
                             self._velocities, self._landmark_sigma_m)

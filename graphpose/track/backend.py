"""The tracker's back end: one GTSAM factor graph over the whole sequence, solved with iSAM2.

Model
-----
Keys as in GTSAM's examples:

- ``X(k)``: ``Pose3`` of the camera in the target frame at frame ``k`` (``T_WC``); a lost
  frame has no variable at all.
- The junctions used in frame ``k``, with isotropic pixel noise (the frame's own fit
  sigma, floored). The target points are known and fixed. Three equivalent ways to say so
  (``target=``, :data:`graphpose.track.config.TARGET_FORMS`); they minimise the same cost
  up to the landmark priors' sigma and give the same poses (tested):

  * ``"resection"`` (default): one factor per frame holding all its junctions, the camera's
    projection (lens distortion included) of the FIXED target points, analytic Jacobian
    (:func:`graphpose.track.factors.resection_factor`, a Python ``CustomFactor``). This is
    the limit of the landmark forms as their prior sigma goes to 0.
  * ``"frame_landmarks"``: the single-image graph of :mod:`graphpose.pose.graph` repeated per
    frame, GTSAM's C++ factors only (but for a rational radial-tangential camera, which GTSAM
    has no calibration for): frame ``k`` gets its OWN copy of every target point
    ``j`` it observes, a ``Point3`` variable ``symbol('l', k * stride + j)`` (``stride`` from
    :func:`landmark_stride`, so for 48 junctions frame 300's junction 3 is ``l30003``; keys
    cannot collide since ``j < stride``), pinned by a ``PriorFactorPoint3`` of sigma
    ``landmark_sigma_m`` (default :data:`graphpose.pose.graph.LANDMARK_SIGMA_M`) and
    observed by one projection factor (:func:`graphpose.pose.graph.projection_factor`:
    GTSAM's ``GenericProjectionFactorCal3_S2``, ``...Cal3DS2`` or ``...Cal3Fisheye`` as the
    camera's model needs, a custom factor where GTSAM has no calibration for it). Each
    frame's landmarks hang below its pose in the Bayes tree and are eliminated locally (the
    update orders them first and ``X(k)`` last).
  * ``"landmarks"``: target point ``j`` is ONE variable ``L(j)`` pinned once by a tight
    prior and shared by every frame, one projection factor per junction.
    Every frame then touches the same variables, so every iSAM2 update re-eliminates a root
    holding all of them: the slowest form.
- A motion prior between consecutive frames of one segment (a lost or re-detected frame
  starts a new segment: no factor spans a loss or a jump), :class:`MotionPrior`:

  * ``"constant_velocity"`` (default): a three-pose factor on ``X(k-2), X(k-1), X(k)`` saying
    the body-frame twist stays the same, ``Log(X(k-1)^-1 X(k)) - r Log(X(k-2)^-1 X(k-1)) ~
    N(0, S)`` with ``r = dt_k / dt_(k-1)``
    (:func:`graphpose.track.factors.constant_velocity_factor`);
  * ``"random_walk"``: ``BetweenFactorPose3(X(k-1), X(k), identity, S)``;
  * ``"wnoa"``: constant velocity in GTSAM's C++ (white noise on acceleration,
    ``WnoaMotionFactorPose3``): a body-velocity variable ``V(k)`` (rad/s then m/s) per frame
    of a segment with two or more frames, and one factor per consecutive pair on
    ``X(k-1), V(k-1), X(k), V(k)`` whose power spectral density ``S / dt^3`` makes the
    velocity change over one interval ``dt`` cost as the twist change of
    ``"constant_velocity"``. Not the same cost (it integrates the velocity rather than
    differencing poses) but the same idea, with every factor in C++; Gaussian (the factor
    builds its own noise model, so ``huber`` does not apply).

  ``S = diag(sigma_rot_rad^2 (x3), sigma_trans_m^2 (x3))``: rotation (rad) first, then
  translation (m), in the camera frame, per frame interval (GTSAM's ``Pose3`` tangent
  order), with a Huber kernel except for ``"wnoa"`` (:func:`motion_noise`).

The graph is solved incrementally with ``gtsam.ISAM2``; every frame adds a fixed number of
factors next to the newest poses. At the end the whole graph can be smoothed in batch
(Levenberg-Marquardt from iSAM2's estimate) with marginal covariances from
``gtsam.Marginals``. Covariances are reported in the pose parameters ``(x, y, z, roll,
pitch, yaw)`` of :mod:`graphpose.camera` (metres, radians).

Trade-offs
----------
A Python ``CustomFactor`` linearised inside iSAM2 costs time in proportion to ALL the
variables in the graph (iSAM2's ``Values`` are copied for the call into Python), while a C++
factor does not. So the update grows along a sequence with the Python factors
(``"resection"``, ``"constant_velocity"``) times the graph's size:

- ``"resection"`` + ``"constant_velocity"`` (default): one variable a frame, so the copies
  stay cheap; the fastest on sequences of a few hundred frames, growing mildly.
- ``"frame_landmarks"`` + ``"constant_velocity"``: one Python factor a frame among many
  landmark variables; grows fastest. No ``ISAM2Params`` setting removes it.
- ``"frame_landmarks"`` + ``"wnoa"`` (every factor C++): about flat, but a slower update
  than the default's on short sequences, and a Gaussian motion prior.
- ``"frame_landmarks"`` + ``"random_walk"``: flat, but less accurate online.
- ``"landmarks"``: the shared root makes every update slow.

For sequences of thousands of frames, where the default's growth continues, use
``TrackerConfig(target="frame_landmarks", motion=MotionPrior("wnoa"))``. Measured figures:
``scripts/bench_tracking.py``.
"""

from __future__ import annotations

import time

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, V, X

from ..board import Board
from ..cameras import as_camera
from ..errors import InputError
from ..pose.graph import LANDMARK_SIGMA_M, params_cov_from_tangent, projection_factor
from .config import TARGET_FORMS, MotionPrior
from .factors import constant_velocity_factor, resection_factor
from .results import BackendResult

#: iSAM2 relinearises a variable whose step exceeds this (rad, m): the estimate's error is
#: of the order of its square.
RELINEARIZE_THRESHOLD = 1e-4
#: Extra iSAM2 updates allowed when a new pose's step is still large (a poor start).
RELINEARIZE_STEPS = 3


def default_isam_params() -> gtsam.ISAM2Params:
    """The back end's iSAM2 settings: relinearise above :data:`RELINEARIZE_THRESHOLD` at
    every update, checking only the cliques near the newest frames."""
    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(RELINEARIZE_THRESHOLD)
    params.relinearizeSkip = 1
    params.enablePartialRelinearizationCheck = True
    return params


def landmark_stride(board: Board) -> int:
    """Key stride of the per-frame landmarks: the smallest power of ten >= ``board.n``, so
    frame ``k``'s copy of junction ``j`` is ``symbol('l', k * stride + j)`` (for 48
    junctions frame 300, junction 3 is ``l30003``); ``j < stride`` makes keys unique."""
    return 10 ** len(str(max(board.n - 1, 1)))


def motion_noise(motion: MotionPrior) -> gtsam.noiseModel.Base:
    """GTSAM noise model of a motion prior: diagonal sigmas, rotation (rad) then translation
    (m) (:meth:`MotionPrior.sigmas`), Huber-robust when ``motion.huber`` is set."""
    model = gtsam.noiseModel.Diagonal.Sigmas(motion.sigmas())
    if motion.huber is None:
        return model
    return gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(motion.huber), model)


class SequenceGraph:
    """The tracker's back end: one factor graph over the sequence, solved with iSAM2.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.cameras`; raw, distorted pixels), or pinhole
        intrinsics ``K``, pixels.
    board : Board
        The target.
    motion : MotionPrior
        Prior between consecutive frames.
    target : {"resection", "frame_landmarks", "landmarks"}
        How the fixed target enters the graph (module docstring).
    landmark_sigma_m : float
        Standard deviation of the priors pinning the target points (the landmark forms),
        metres.
    isam_params : gtsam.ISAM2Params, optional
        iSAM2 settings; default :func:`default_isam_params`.

    Raises
    ------
    InputError
        If the camera is invalid (:func:`graphpose.cameras.as_camera`) or ``target`` is not
        one of :data:`graphpose.track.config.TARGET_FORMS`.
    """

    def __init__(self, camera, board: Board, motion: MotionPrior, target: str = "resection",
                 landmark_sigma_m: float = LANDMARK_SIGMA_M, isam_params: gtsam.ISAM2Params | None = None):
        if target not in TARGET_FORMS:
            raise InputError(f"target must be one of {TARGET_FORMS}, got {target!r}")
        self.board = board
        self.motion = motion
        self.target = target
        self.camera = as_camera(camera)
        self._Wpts = board.world_points()
        self._cal = self.camera.gtsam_calibration()  # None: custom projection factors
        self._pin = gtsam.noiseModel.Isotropic.Sigma(3, landmark_sigma_m)
        self._motion_noise = motion_noise(motion)
        self._stride = landmark_stride(board)
        self._isam = gtsam.ISAM2(isam_params if isam_params is not None else default_isam_params())
        self._graph = gtsam.NonlinearFactorGraph()
        self._pending = gtsam.NonlinearFactorGraph()
        self._pending_values = gtsam.Values()
        self._segment: list = []  # (key index, timestamp) of this segment's latest frames
        self._frames: list = []
        if target == "landmarks":
            for j, p in enumerate(self._Wpts.T):
                self._add(gtsam.PriorFactorPoint3(L(j), p, self._pin))
                self._pending_values.insert(L(j), p)

    @property
    def frames(self) -> list:
        """Frame indices in the graph, in the order they were added."""
        return list(self._frames)

    def break_segment(self) -> None:
        """Start a new segment: the next frame gets no motion factor (called after a loss)."""
        self._segment = []

    def add_frame(self, k: int, timestamp: float, points, ids, T_init, pixel_sigma: float) -> BackendResult:
        """Add frame ``k`` and update iSAM2.

        Parameters
        ----------
        k : int
            Frame index, increasing.
        timestamp : float
            Seconds.
        points : (2, m) ndarray
            Junction pixels (u, v) seen in the frame.
        ids : (m,) int ndarray
            Which junction (row-major board index) each point is.
        T_init : (4, 4) ndarray
            Initial guess of the pose (the frame's single-frame fit).
        pixel_sigma : float
            Standard deviation of a junction position, pixels.

        Returns
        -------
        BackendResult
            The incremental (filtered) estimate of the frame and its marginal covariance.
        """
        start = time.perf_counter()
        points = np.asarray(points, dtype=float)
        ids = np.asarray(ids, dtype=int)
        self._add_target(k, points, ids, pixel_sigma)
        self._add_motion(k, timestamp)
        self._pending_values.insert(X(k), gtsam.Pose3(np.asarray(T_init, dtype=float)))
        self._segment = (self._segment + [(k, timestamp)])[-2:]
        self._frames.append(k)
        self._isam.update(self._pending, self._pending_values, constrainedKeys=self._order(k, ids))
        linear, pose = gtsam.Pose3(T_init), self._isam.calculateEstimatePose3(X(k))
        for _ in range(RELINEARIZE_STEPS):
            # One update is one Gauss-Newton step; a poor start needs a few more. (Compare
            # poses: getDelta() would copy every variable's step, O(frames).)
            if np.max(np.abs(gtsam.Pose3.Logmap(linear.between(pose)))) < RELINEARIZE_THRESHOLD:
                break
            self._isam.update()
            linear, pose = pose, self._isam.calculateEstimatePose3(X(k))
        cov = self._isam.marginalCovariance(X(k))
        update_s = time.perf_counter() - start
        self._pending = gtsam.NonlinearFactorGraph()
        self._pending_values = gtsam.Values()
        T = pose.matrix()
        return BackendResult(T, params_cov_from_tangent(T, cov), update_s)

    def estimate(self) -> dict:
        """iSAM2's current estimate of every frame: ``{k: (4, 4) T_WC}``."""
        values = self._isam.calculateEstimate()
        return {k: values.atPose3(X(k)).matrix() for k in self._frames}

    def smooth(self) -> dict:
        """Batch-smooth the whole graph (Levenberg-Marquardt from iSAM2's estimate).

        Returns
        -------
        dict
            ``{k: BackendResult}`` for every frame in the graph, covariances from the full
            graph's marginals.
        """
        initial = self._isam.calculateEstimate()
        params = gtsam.LevenbergMarquardtParams()
        params.setRelativeErrorTol(1e-10)
        params.setAbsoluteErrorTol(1e-10)
        values = gtsam.LevenbergMarquardtOptimizer(self._graph, initial, params).optimize()
        marginals = gtsam.Marginals(self._graph, values)
        out = {}
        for k in self._frames:
            T = values.atPose3(X(k)).matrix()
            out[k] = BackendResult(T, params_cov_from_tangent(T, marginals.marginalCovariance(X(k))))
        return out

    def landmark_key(self, k: int, j: int) -> int:
        """Key of frame ``k``'s copy of target point ``j`` (``"frame_landmarks"``):
        ``symbol('l', k * stride + j)``, ``stride`` = :func:`landmark_stride`."""
        return gtsam.symbol("l", k * self._stride + j)

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
        for key in self._pending.keyVector():
            groups.insert2(key, 1)
        return groups

    def _add(self, factor) -> None:
        self._graph.add(factor)
        self._pending.add(factor)

    def _add_target(self, k, points, ids, pixel_sigma) -> None:
        if self.target == "resection":
            self._add(resection_factor(X(k), points, self._Wpts[:, ids], self.camera, pixel_sigma))
            return
        noise = gtsam.noiseModel.Isotropic.Sigma(2, pixel_sigma)
        for uv, j in zip(points.T, ids.tolist()):
            if self.target == "landmarks":
                key = L(j)
            else:
                key = self.landmark_key(k, j)
                self._add(gtsam.PriorFactorPoint3(key, self._Wpts[:, j], self._pin))
                self._pending_values.insert(key, self._Wpts[:, j])
            self._add(projection_factor(self.camera, uv, noise, X(k), key, self._cal))

    def _add_motion(self, k: int, timestamp: float) -> None:
        if not self._segment:
            return
        if self.motion.model == "random_walk":
            prev = self._segment[-1][0]
            self._add(gtsam.BetweenFactorPose3(X(prev), X(k), gtsam.Pose3(), self._motion_noise))
        elif self.motion.model == "wnoa":
            self._add(self._wnoa_factor(k, timestamp))
        elif len(self._segment) == 2:
            (k0, t0), (k1, t1) = self._segment
            ratio = (timestamp - t1) / (t1 - t0) if t1 > t0 else 1.0
            self._add(constant_velocity_factor(X(k0), X(k1), X(k), ratio, self._motion_noise))

    def _wnoa_factor(self, k, timestamp):
        """White-noise-on-acceleration factor from the segment's last frame to frame ``k``;
        adds the velocity variables it needs (a velocity is only created with a factor, so
        a one-frame segment has none and stays determined)."""
        k1, t1 = self._segment[-1]
        for key in (V(k1), V(k)):
            if not self._isam.valueExists(key) and not self._pending_values.exists(key):
                self._pending_values.insert(key, np.zeros(6))
        dt = timestamp - t1
        # Gaussian: the factor builds its own noise model and cannot be cloned with a robust one.
        return gtsam.WnoaMotionFactorPose3(gtsam.StateData(X(k1), V(k1), t1), gtsam.StateData(X(k), V(k), timestamp),
                                           self.motion.sigmas()**2 / dt**3)

"""The tracker's back end: a factor graph over the frames, solved online by a fixed-lag
smoother (default) or by iSAM2 over the whole sequence, and smoothed in batch at the end.

Two online back ends take the same factors (:class:`FixedLagGraph`, :class:`SequenceGraph`):

- :class:`FixedLagGraph` (``TrackerConfig(lag_s=1.0)``, the default): GTSAM's
  ``IncrementalFixedLagSmoother``, iSAM2 over the frames of the last ``lag_s`` seconds. A
  variable older than the newest frame's timestamp minus the lag is marginalised out (its
  factors become one linear prior on the variables it shared them with), so the graph holds
  about ``lag_s * fps`` frames however long the sequence: per-frame time and memory stay
  flat. The online pose of a frame, and its covariance, are the smoother's right after the
  frame was added (filtered, as before). It keeps each frame's measurements (a few hundred
  bytes) so that :meth:`FixedLagGraph.smooth` can build the whole sequence's graph once, at
  the end, and smooth it in batch.
- :class:`SequenceGraph` (``TrackerConfig(lag_s=None)``): one iSAM2 over the whole
  sequence, as before; its per-frame cost and memory grow with the sequence.

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
    whole-sequence update orders them first and ``X(k)`` last); in the fixed lag they carry
    their frame's timestamp and leave with it.
  * ``"landmarks"``: target point ``j`` is ONE variable ``L(j)`` pinned once by a tight
    prior and shared by every frame, one projection factor per junction.
    Every frame then touches the same variables, so every iSAM2 update re-eliminates a root
    holding all of them: the slowest form. In the fixed lag the ``L(j)`` are re-stamped at
    every frame, so they are never marginalised; the old poses leave a dense prior on them.
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
  order), with a Huber kernel except for ``"wnoa"`` (:func:`motion_noise`). In the fixed
  lag a motion factor only reaches frames still inside the lag (a frame interval longer
  than the lag starts a new segment, as a loss does); once marginalised, a robust factor's
  weight stays as it was at its last linearisation.

Every frame adds a fixed number of factors next to the newest poses. At the end the whole
sequence can be smoothed in batch (Levenberg-Marquardt from the online estimates) with
marginal covariances from ``gtsam.Marginals``: :func:`smooth_frames`, which rebuilds the
graph from the frames' measurements. Covariances are reported in the pose parameters
``(x, y, z, roll, pitch, yaw)`` of :mod:`graphpose.camera` (metres, radians).

Trade-offs
----------
A Python ``CustomFactor`` linearised inside iSAM2 costs time in proportion to ALL the
variables in the graph (iSAM2's ``Values`` are copied for the call into Python), while a C++
factor does not. Over the whole sequence (:class:`SequenceGraph`) the update therefore grows
with the Python factors (``"resection"``, ``"constant_velocity"``), and its memory grows with
every form. The fixed lag bounds the graph, so every form and prior stays flat; the
figures (``scripts/bench_tracking.py``) compare them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, V, X

from .._checks import check_number
from ..board import Board
from ..cameras import as_camera
from ..errors import InputError
from ..pose.graph import LANDMARK_SIGMA_M, params_cov_from_tangent, projection_factor
from .config import DEFAULT_LAG_S, TARGET_FORMS, MotionPrior
from .factors import constant_velocity_factor, resection_factor
from .results import BackendResult

#: iSAM2 relinearises a variable whose step exceeds this (rad, m): the estimate's error is
#: of the order of its square.
RELINEARIZE_THRESHOLD = 1e-4
#: Extra iSAM2 updates allowed when a new pose's step is still large (a poor start).
RELINEARIZE_STEPS = 3


def default_isam_params() -> gtsam.ISAM2Params:
    """The whole-sequence back end's iSAM2 settings: relinearise above
    :data:`RELINEARIZE_THRESHOLD` at every update, checking only the cliques near the newest
    frames."""
    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(RELINEARIZE_THRESHOLD)
    params.relinearizeSkip = 1
    params.enablePartialRelinearizationCheck = True
    return params


def fixed_lag_isam_params() -> gtsam.ISAM2Params:
    """The fixed-lag smoother's iSAM2 settings: those of :func:`default_isam_params`, the
    slots of marginalised factors reused (else iSAM2's factor list keeps growing with empty
    slots), and every clique checked for relinearisation.

    The smoother orders each update itself (the keys to marginalise first, then the rest in
    COLAMD's order), so the new pose need not be at the root of the Bayes tree. The partial
    check walks down from the root and stops at a clique whose step is small: it then left
    new poses up to 80 um off the filtered optimum (a 240-frame test), where the full check
    leaves 0.5 um. Over a window of a couple of seconds the full check is cheap.
    """
    params = default_isam_params()
    params.findUnusedFactorSlots = True
    params.enablePartialRelinearizationCheck = False
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


@dataclass(frozen=True)
class FrameMeasurement:
    """What the back end was given for one frame: all that is needed to rebuild its factors.

    Attributes
    ----------
    index : int
        Frame index.
    timestamp : float
        Seconds.
    points : (2, m) ndarray
        Junction pixels (u, v).
    ids : (m,) int ndarray
        Their board indices (row-major).
    pixel_sigma : float
        Standard deviation of a junction position, pixels.
    new_segment : bool
        The frame starts a segment (no motion factor ties it to the frames before).
    """

    index: int
    timestamp: float
    points: np.ndarray
    ids: np.ndarray
    pixel_sigma: float
    new_segment: bool


class FactorBuilder:
    """The factors and initial values of each frame, in one of the target forms with one
    motion prior (module docstring); shared by the online back ends and the batch smoothing
    so that all of them minimise the same cost.

    Parameters
    ----------
    camera : Camera
        The camera model (already checked, :func:`graphpose.cameras.as_camera`).
    board : Board
        The target.
    motion : MotionPrior
        Prior between consecutive frames.
    target : {"resection", "frame_landmarks", "landmarks"}
        How the fixed target enters the graph.
    landmark_sigma_m : float
        Standard deviation of the priors pinning the target points (landmark forms), metres.

    Raises
    ------
    InputError
        If ``target`` is not one of :data:`graphpose.track.config.TARGET_FORMS`.
    """

    def __init__(self, camera, board: Board, motion: MotionPrior, target: str, landmark_sigma_m: float):
        if target not in TARGET_FORMS:
            raise InputError(f"target must be one of {TARGET_FORMS}, got {target!r}")
        self.camera, self.board, self.motion, self.target = camera, board, motion, target
        self._Wpts = board.world_points()
        self._cal = camera.gtsam_calibration()  # None: custom projection factors
        self._pin = gtsam.noiseModel.Isotropic.Sigma(3, landmark_sigma_m)
        self._motion_noise = motion_noise(motion)
        self._stride = landmark_stride(board)
        # (frame index, timestamp, has a velocity variable) of the segment's last frames.
        self.segment: list = []

    def break_segment(self) -> None:
        """The next frame starts a new segment: no motion factor."""
        self.segment = []

    def forget_before(self, cutoff: float) -> None:
        """Drop the segment's frames older than ``cutoff`` seconds (marginalised: no new
        factor may reach them); with none left the next frame starts a new segment."""
        self.segment = [s for s in self.segment if s[1] >= cutoff]

    def shared_landmarks(self) -> tuple:
        """``(graph, values)`` of the ``"landmarks"`` form's shared, pinned target points."""
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        for j, p in enumerate(self._Wpts.T):
            graph.add(gtsam.PriorFactorPoint3(L(j), p, self._pin))
            values.insert(L(j), p)
        return graph, values

    def landmark_key(self, k: int, j: int) -> int:
        """Key of frame ``k``'s copy of target point ``j`` (``"frame_landmarks"``)."""
        return gtsam.symbol("l", k * self._stride + j)

    def frame(self, k: int, timestamp: float, points, ids, T_init, pixel_sigma: float) -> tuple:
        """Frame ``k``'s new factors and variables.

        Returns
        -------
        graph : gtsam.NonlinearFactorGraph
            Its target factors, then its motion factor (if any).
        values : gtsam.Values
            Initial values of its new variables: ``X(k)`` at ``T_init``, its landmarks at
            the target points, new velocities at zero.
        stamps : dict
            ``{key: seconds}`` of the new variables (each stamped with its own frame's time).
        """
        graph, values, stamps = gtsam.NonlinearFactorGraph(), gtsam.Values(), {}
        self._target_factors(graph, values, stamps, k, timestamp, points, ids, pixel_sigma)
        velocity = self._motion_factor(graph, values, stamps, k, timestamp)
        values.insert(X(k), gtsam.Pose3(np.asarray(T_init, dtype=float)))
        stamps[X(k)] = timestamp
        self.segment = (self.segment + [(k, timestamp, velocity)])[-2:]
        return graph, values, stamps

    def _target_factors(self, graph, values, stamps, k, timestamp, points, ids, pixel_sigma) -> None:
        if self.target == "resection":
            graph.add(resection_factor(X(k), points, self._Wpts[:, ids], self.camera, pixel_sigma))
            return
        noise = gtsam.noiseModel.Isotropic.Sigma(2, pixel_sigma)
        for uv, j in zip(points.T, ids.tolist()):
            if self.target == "landmarks":
                key = L(j)
            else:
                key = self.landmark_key(k, j)
                graph.add(gtsam.PriorFactorPoint3(key, self._Wpts[:, j], self._pin))
                values.insert(key, self._Wpts[:, j])
                stamps[key] = timestamp
            graph.add(projection_factor(self.camera, uv, noise, X(k), key, self._cal))

    def _motion_factor(self, graph, values, stamps, k, timestamp) -> bool:
        """Adds the motion factor reaching frame ``k``; True when it gave ``k`` a velocity."""
        if not self.segment:
            return False
        if self.motion.model == "random_walk":
            graph.add(gtsam.BetweenFactorPose3(X(self.segment[-1][0]), X(k), gtsam.Pose3(), self._motion_noise))
        elif self.motion.model == "wnoa":
            # A velocity is only created with a factor, so a one-frame segment has none and
            # stays determined.
            k1, t1, has_velocity = self.segment[-1]
            if not has_velocity:
                values.insert(V(k1), np.zeros(6))
                stamps[V(k1)] = t1
            values.insert(V(k), np.zeros(6))
            stamps[V(k)] = timestamp
            # Gaussian: the factor builds its own noise model and cannot be cloned with a robust one.
            graph.add(gtsam.WnoaMotionFactorPose3(gtsam.StateData(X(k1), V(k1), t1),
                                                  gtsam.StateData(X(k), V(k), timestamp),
                                                  self.motion.sigmas()**2 / (timestamp - t1)**3))
            return True
        elif len(self.segment) == 2:
            (k0, t0, _), (k1, t1, _) = self.segment
            ratio = (timestamp - t1) / (t1 - t0) if t1 > t0 else 1.0
            graph.add(constant_velocity_factor(X(k0), X(k1), X(k), ratio, self._motion_noise))
        return False


def _result(T: np.ndarray, cov_tangent: np.ndarray, update_s: float = 0.0) -> BackendResult:
    return BackendResult(T, params_cov_from_tangent(T, cov_tangent), update_s)


def _refine(update, pose_of, T_init) -> gtsam.Pose3:
    """A few more iSAM2 updates while the new pose still moves by more than
    :data:`RELINEARIZE_THRESHOLD`: one update is one Gauss-Newton step, and a poor start
    needs more. (Poses are compared: the delta of every variable would cost more.)"""
    linear, pose = gtsam.Pose3(np.asarray(T_init, dtype=float)), pose_of()
    for _ in range(RELINEARIZE_STEPS):
        if np.max(np.abs(gtsam.Pose3.Logmap(linear.between(pose)))) < RELINEARIZE_THRESHOLD:
            break
        update()
        linear, pose = pose, pose_of()
    return pose


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
    return _smooth(graph, values, [m.index for m in measurements])


def _smooth(graph, initial, frames) -> dict:
    """Levenberg-Marquardt over the whole ``graph`` from ``initial``, then every frame's pose
    and marginal covariance: ``{k: BackendResult}`` for ``frames``."""
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(1e-10)
    params.setAbsoluteErrorTol(1e-10)
    values = gtsam.LevenbergMarquardtOptimizer(graph, initial, params).optimize()
    marginals = gtsam.Marginals(graph, values)
    return {k: _result(values.atPose3(X(k)).matrix(), marginals.marginalCovariance(X(k))) for k in frames}


class FixedLagGraph:
    """The tracker's default back end: the frames of the last ``lag_s`` seconds in GTSAM's
    incremental fixed-lag smoother (iSAM2, older variables marginalised), so that a frame
    costs the same time and memory however long the sequence.

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

    Raises
    ------
    InputError
        If the camera is invalid, ``target`` is not one of
        :data:`graphpose.track.config.TARGET_FORMS` or ``lag_s`` is not a positive number.

    Notes
    -----
    Kept for the whole sequence: one :class:`FrameMeasurement` and the online pose per
    frame (about 2 kB for 48 junctions), for :meth:`smooth`. Everything else is bounded by
    the lag.
    """

    def __init__(self, camera, board: Board, motion: MotionPrior, target: str = "resection",
                 lag_s: float = DEFAULT_LAG_S, landmark_sigma_m: float = LANDMARK_SIGMA_M,
                 isam_params: gtsam.ISAM2Params | None = None):
        check_number("lag_s", lag_s, 0.0, strict=True)
        self.camera = as_camera(camera)
        self._builder = FactorBuilder(self.camera, board, motion, target, landmark_sigma_m)
        self.board, self.motion, self.target, self.lag_s = board, motion, target, float(lag_s)
        self._landmark_sigma_m = landmark_sigma_m
        params = isam_params if isam_params is not None else fixed_lag_isam_params()
        self._smoother = gtsam.IncrementalFixedLagSmoother(self.lag_s, params)
        self._measurements: list = []
        self._online: dict = {}
        self._velocities: dict = {}
        self._new_segment = True
        self._shared = target == "landmarks"

    @property
    def frames(self) -> list:
        """Frame indices given to the back end, in order."""
        return [m.index for m in self._measurements]

    @property
    def measurements(self) -> tuple:
        """Every frame's :class:`FrameMeasurement`, in order."""
        return tuple(self._measurements)

    def break_segment(self) -> None:
        """Start a new segment: the next frame gets no motion factor (called after a loss)."""
        self._builder.break_segment()
        self._new_segment = True

    def add_frame(self, k: int, timestamp: float, points, ids, T_init, pixel_sigma: float) -> BackendResult:
        """Add frame ``k``, update the smoother and marginalise what the lag leaves behind.

        Parameters and return as :meth:`SequenceGraph.add_frame` (the frame's filtered
        estimate and marginal covariance, from the smoother).
        """
        start = time.perf_counter()
        points = np.asarray(points, dtype=float)
        ids = np.asarray(ids, dtype=int)
        timestamp = float(timestamp)
        # This update marginalises every key older than this: no new factor reaches them.
        self._builder.forget_before(timestamp - self.lag_s)
        new_segment = self._new_segment or not self._builder.segment
        graph, values, stamps = self._builder.frame(k, timestamp, points, ids, T_init, pixel_sigma)
        if self._shared:
            if not self._measurements:
                pins, pinned = self._builder.shared_landmarks()
                graph.push_back(pins)
                values.insert(pinned)
            for j in range(self.board.n):  # re-stamped: never marginalised
                stamps[L(j)] = timestamp
        self._smoother.update(graph, values, stamps)
        pose = _refine(self._smoother.update, lambda: self._smoother.calculateEstimatePose3(X(k)), T_init)
        cov = self._smoother.marginalCovariance(X(k))
        T = pose.matrix()
        self._measurements.append(FrameMeasurement(k, timestamp, points, ids, float(pixel_sigma), new_segment))
        self._online[k] = T
        if self._builder.segment[-1][2]:
            self._velocities[k] = self._smoother.calculateEstimateVector(V(k))
        self._new_segment = False
        return _result(T, cov, time.perf_counter() - start)

    def estimate(self) -> dict:
        """The smoother's current estimate of the frames still inside the lag:
        ``{k: (4, 4) T_WC}`` (older frames are marginalised)."""
        values = self._smoother.calculateEstimate()
        return {k: values.atPose3(X(k)).matrix() for k in self.frames if values.exists(X(k))}

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
        """
        initial = dict(self._online)
        initial.update(self.estimate())
        return smooth_frames(self.camera, self.board, self.motion, self.target, self._measurements, initial,
                             self._velocities, self._landmark_sigma_m)


class SequenceGraph:
    """The whole-sequence back end: one factor graph over every frame, solved with iSAM2
    (``TrackerConfig(lag_s=None)``); its per-frame cost and memory grow with the sequence.

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
        self.camera = as_camera(camera)
        self._builder = FactorBuilder(self.camera, board, motion, target, landmark_sigma_m)
        self.board, self.motion, self.target = board, motion, target
        self._isam = gtsam.ISAM2(isam_params if isam_params is not None else default_isam_params())
        self._graph = gtsam.NonlinearFactorGraph()
        self._pending_graph, self._pending_values = (self._builder.shared_landmarks() if target == "landmarks"
                                                     else (gtsam.NonlinearFactorGraph(), gtsam.Values()))
        self._graph.push_back(self._pending_graph)
        self._frames: list = []

    @property
    def frames(self) -> list:
        """Frame indices in the graph, in the order they were added."""
        return list(self._frames)

    def break_segment(self) -> None:
        """Start a new segment: the next frame gets no motion factor (called after a loss)."""
        self._builder.break_segment()

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
        graph, values, _ = self._builder.frame(k, timestamp, points, ids, T_init, pixel_sigma)
        self._graph.push_back(graph)
        self._pending_graph.push_back(graph)
        self._pending_values.insert(values)
        self._frames.append(k)
        self._isam.update(self._pending_graph, self._pending_values, constrainedKeys=self._order(k, ids))
        pose = _refine(self._isam.update, lambda: self._isam.calculateEstimatePose3(X(k)), T_init)
        cov = self._isam.marginalCovariance(X(k))
        self._pending_graph, self._pending_values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        return _result(pose.matrix(), cov, time.perf_counter() - start)

    def estimate(self) -> dict:
        """iSAM2's current estimate of every frame: ``{k: (4, 4) T_WC}``."""
        values = self._isam.calculateEstimate()
        return {k: values.atPose3(X(k)).matrix() for k in self._frames}

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
        return _smooth(self._graph, self._isam.calculateEstimate(), self._frames)

    def landmark_key(self, k: int, j: int) -> int:
        """Key of frame ``k``'s copy of target point ``j`` (``"frame_landmarks"``):
        ``symbol('l', k * stride + j)``, ``stride`` = :func:`landmark_stride`."""
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


def make_backend(camera, board: Board, motion: MotionPrior, target: str = "resection",
                 lag_s: float | None = DEFAULT_LAG_S):
    """The online back end for ``lag_s``: :class:`FixedLagGraph` over that many seconds, or
    :class:`SequenceGraph` over the whole sequence when ``lag_s`` is None."""
    if lag_s is None:
        return SequenceGraph(camera, board, motion, target=target)
    return FixedLagGraph(camera, board, motion, target=target, lag_s=lag_s)

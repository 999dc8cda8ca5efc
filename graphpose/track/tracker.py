"""Tracking the camera over a sequence of frames: a front end on junctions, an iSAM2 back end.

Model
-----
One GTSAM factor graph over the whole sequence (keys as in GTSAM's examples):

- ``X(k)``: ``Pose3`` of the camera in the target frame at frame ``k`` (``T_WC``); a lost
  frame has no variable at all.
- The junctions used in frame ``k``, with isotropic pixel noise (the frame's own fit
  residual, floored). The target points are known and fixed. Three equivalent ways to say
  so (``target=``, :data:`TARGET_FORMS`); they minimise the same cost up to the landmark
  priors' sigma and give the same poses to about 1e-8 m (tested):

  * ``"resection"`` (default): one factor per frame holding all its junctions, the pinhole
    projection of the FIXED target points, analytic Jacobian (a Python ``CustomFactor``).
    This is the limit of the landmark forms as their prior sigma goes to 0. Fastest; its
    update grows mildly along a sequence (trade-offs below).
  * ``"frame_landmarks"``: the single-image graph of :mod:`graphpose.pose.graph` repeated per
    frame, GTSAM's C++ factors only: frame ``k`` gets its OWN copy of every target point
    ``j`` it observes, a ``Point3`` variable ``symbol('l', k * stride + j)`` (``stride``
    from :func:`landmark_stride`: 100 for 48 junctions, so frame 300's junction 3 is
    ``l30003``; keys cannot collide since ``j < stride``), pinned by a
    ``PriorFactorPoint3`` of sigma ``landmark_sigma_m`` (default
    :data:`graphpose.pose.graph.LANDMARK_SIGMA_M`, 1e-8 m) and observed by one
    ``GenericProjectionFactorCal3_S2``. Each frame's landmarks hang below its pose in the
    Bayes tree and are eliminated locally (the update orders them first and ``X(k)`` last).
    49 variables and 97 factors a frame.
  * ``"landmarks"``: target point ``j`` is ONE variable ``L(j)`` pinned once by a tight
    prior and shared by every frame, one ``GenericProjectionFactorCal3_S2`` per junction.
    Every frame then touches the same 48 variables, so every iSAM2 update re-eliminates a
    144-dimensional root: several times slower than the others.
- A motion prior between consecutive frames of one segment (a lost or re-detected frame
  starts a new segment: no factor spans a loss or a jump):

  * ``"constant_velocity"`` (default): a three-pose factor on ``X(k-2), X(k-1), X(k)`` saying
    the body-frame twist stays the same, ``Log(X(k-1)^-1 X(k)) - r Log(X(k-2)^-1 X(k-1)) ~
    N(0, S)`` with ``r = dt_k / dt_(k-1)``;
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
  order), with a Huber kernel except for ``"wnoa"`` (:class:`MotionPrior`).

Trade-offs (measured, ``scripts/bench_tracking.py`` and /work/notes/tracking.md): a Python
``CustomFactor`` linearised inside iSAM2 costs time in proportion to ALL the variables in
the graph (a profile shows iSAM2's ``Values`` being copied for the call into Python: one
such factor costs 1.1 ms an update among 5,000 ``Point3`` variables, 6.8 ms among 15,000,
against 0.01-0.02 ms for a C++ factor). So the growth of the update along a sequence comes from the Python factors
(``"resection"``, ``"constant_velocity"``) times the graph's size. On 300-frame synthetic
sequences (median update of frames 5-15 -> 289-299; total = front end + back end a frame):

- ``"resection"`` + ``"constant_velocity"`` (default): 0.35-0.5 -> 0.6 ms (1.3-1.7x over six
  runs), total 3.4-4.2 ms; 300 variables, so the copies stay cheap, but they grow with the
  sequence.
- ``"frame_landmarks"`` + ``"constant_velocity"``: 1.0-1.4 -> 6.8-9.4 ms (5-9.5x), total
  8.6-9.0 ms: one Python factor a frame among 15,000 variables. No ``ISAM2Params``
  setting removes it (relinearizeSkip, QR, threshold, partial check; uncached linear
  factors make it worse).
- ``"frame_landmarks"`` + ``"wnoa"`` (every factor C++): 0.8-1.1 -> 0.7-1.4 ms (0.7-0.8x
  with whip pans, 1.3-1.4x on one unbroken segment; three runs each), total 4.1-6.0 ms, the
  same accuracy as ``"constant_velocity"`` on these sequences. About flat, but twice the
  default's back end at frame 300 and a Gaussian prior.
- ``"frame_landmarks"`` + ``"random_walk"``: flat (0.4-0.6x), total 5.4-5.8 ms, less
  accurate online (0.19 against 0.12 mm).
- ``"landmarks"``: 4-6 ms an update (a 144-dimensional root every time), 10-12 ms a frame;
  with ``"wnoa"`` it grows to 15-21 ms.

The default stays ``"resection"`` + ``"constant_velocity"``: the all-C++ pair is flat but
only with a different (Gaussian) motion model, with thin margins and twice the back-end time
at frame 300. For sequences of thousands of frames, where the default's growth continues,
use ``TrackerConfig(target="frame_landmarks", motion=MotionPrior("wnoa"))``.

All forms give the same poses: tracker runs agree with ``"resection"`` (same motion prior)
to 0.11 um online and 0.001 um smoothed, with identical frame statuses.

Front end (:class:`TrackerConfig` holds its thresholds): predict every junction from the
constant-velocity pose, refine the predictions with the saddle fit
(:func:`graphpose.detect.refine.refine_junctions`), drop untrusted fits, fits far from their
prediction and residual outliers of the frame's own pose fit; fall back to full extraction
(:func:`graphpose.detect.junctions.extract_junctions`) in a ladder of polygons when too few survive,
when the motion is too fast to predict, or after a loss. A frame whose board cannot be found,
or whose fit is much worse than the sequence's usual, is lost: no pose is guessed.

The graph is solved incrementally with ``gtsam.ISAM2``; every frame adds a fixed number of
factors next to the newest poses, so each update costs about the same, up to the Python
factors' growth above. At the end the whole
graph can be smoothed in batch (Levenberg-Marquardt from iSAM2's estimate) with marginal
covariances from ``gtsam.Marginals``.

Covariances are reported in the pose parameters ``(x, y, z, roll, pitch, yaw)`` of
:mod:`graphpose.camera` (metres, radians), like :class:`graphpose.pose.estimate.PoseEstimate`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, V, X

from .._checks import as_float_array, as_points, check_K, check_number, check_timestamps
from ..board import Board
from ..camera import project, to_camera
from ..detect.junctions import extract_junctions
from ..detect.refine import refine_junctions
from ..errors import BoardNotFoundError, InputError
from ..image import as_grey, read_image
from ..pose.gauss_newton import gauss_newton
from ..pose.graph import LANDMARK_SIGMA_M, params_cov_from_tangent
from ..pose.homography import pose_from_homography

#: iSAM2 relinearises a variable whose step exceeds this (rad, m): the estimate's error is
#: of the order of its square.
RELINEARIZE_THRESHOLD = 1e-4
#: Extra iSAM2 updates allowed when a new pose's step is still large (a poor start).
RELINEARIZE_STEPS = 3

#: Pose models the back end knows.
MOTION_MODELS = ("constant_velocity", "random_walk", "wnoa")

#: How the fixed target enters the back end's graph (module docstring).
TARGET_FORMS = ("resection", "landmarks", "frame_landmarks")


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


@dataclass(frozen=True)
class MotionPrior:
    """The motion prior between consecutive frames.

    Attributes
    ----------
    model : {"constant_velocity", "random_walk", "wnoa"}
        Constant body-frame twist (a three-pose Python factor), a random walk on the pose,
        or constant velocity with velocity variables (GTSAM's C++ white-noise-on-
        acceleration factor); module docstring.
    sigma_rot_rad : float
        Standard deviation per axis, radians per frame interval, of the twist change
        (constant velocity, wnoa) or of the pose change (random walk).
    sigma_trans_m : float
        Same for the translation, metres per frame interval.
    huber : float or None
        Huber threshold of the motion factor, in sigmas (None: Gaussian; ``"wnoa"`` is
        always Gaussian). A jolt (a whip pan, a knock) then costs linearly instead of
        dragging the neighbouring poses.

    Raises
    ------
    InputError
        If ``model`` is not one of :data:`MOTION_MODELS`, a sigma is not a positive finite
        number, or ``huber`` is neither None nor a positive finite number.

    Notes
    -----
    Defaults suit a camera held steadily at 30 frames a second: the twist changes by an
    angular acceleration of about 0.9 rad/s^2 and a linear one of about 0.45 m/s^2 over one
    frame (``a dt^2``: 1 mrad and 0.5 mm); harder jolts are left to the Huber kernel. Looser
    sigmas smooth less (on the synthetic sequences of :mod:`graphpose.synth.sequence`, 5.5 mrad
    and 1.7 mm cut the single-frame error by 6 % instead of 30 %).
    """

    model: str = "constant_velocity"
    sigma_rot_rad: float = 0.001
    sigma_trans_m: float = 0.0005

    huber: float | None = 3.0

    def __post_init__(self):
        if self.model not in MOTION_MODELS:
            raise InputError(f"motion model must be one of {MOTION_MODELS}, got {self.model!r}")
        check_number("sigma_rot_rad", self.sigma_rot_rad, 0.0, strict=True)
        check_number("sigma_trans_m", self.sigma_trans_m, 0.0, strict=True)
        if self.huber is not None:
            check_number("huber", self.huber, 0.0, strict=True)

    def sigmas(self) -> np.ndarray:
        """(6,) standard deviations in GTSAM's Pose3 tangent order: rotation (rad) x3, then
        translation (m) x3."""
        return np.r_[np.full(3, float(self.sigma_rot_rad)), np.full(3, float(self.sigma_trans_m))]

    def noise(self) -> gtsam.noiseModel.Base:
        """GTSAM noise model, rotation (rad) then translation (m), Huber-robust when set."""
        model = gtsam.noiseModel.Diagonal.Sigmas(self.sigmas())
        if self.huber is None:
            return model
        return gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(self.huber), model)


@dataclass(frozen=True)
class BackendResult:
    """The back end's answer for one frame.

    Attributes
    ----------
    T_WC : (4, 4) ndarray
        Camera pose in the target frame.
    cov : (6, 6) ndarray
        Marginal covariance of ``(x, y, z, roll, pitch, yaw)``, metres and radians.
    update_s : float
        Wall time of the back end for the frame (0 for batch results), seconds: building its
        factors, the iSAM2 update(s) and the marginal covariance.
    """

    T_WC: np.ndarray
    cov: np.ndarray
    update_s: float = 0.0


class SequenceGraph:
    """The tracker's back end: one factor graph over the sequence, solved with iSAM2.

    Parameters
    ----------
    K : (3, 3) array_like
        Intrinsics, pixels.
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
        If ``K`` is invalid (:func:`graphpose.camera.check_K`) or ``target`` is not one of
        :data:`TARGET_FORMS`.
    """

    def __init__(self, K, board: Board, motion: MotionPrior, target: str = "resection",
                 landmark_sigma_m: float = LANDMARK_SIGMA_M, isam_params: gtsam.ISAM2Params | None = None):
        if target not in TARGET_FORMS:
            raise InputError(f"target must be one of {TARGET_FORMS}, got {target!r}")
        self.board = board
        self.motion = motion
        self.target = target
        K = self._K = check_K(K)
        self._Wpts = board.world_points()
        self._cal = gtsam.Cal3_S2(K[0, 0], K[1, 1], K[0, 1], K[0, 2], K[1, 2])
        self._pin = gtsam.noiseModel.Isotropic.Sigma(3, landmark_sigma_m)
        self._stride = landmark_stride(board)
        self._isam = gtsam.ISAM2(isam_params if isam_params is not None else default_isam_params())
        self._graph = gtsam.NonlinearFactorGraph()
        self._values = gtsam.Values()
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
            self._add(resection_factor(X(k), points, self._Wpts[:, ids], self._K, pixel_sigma))
            return
        noise = gtsam.noiseModel.Isotropic.Sigma(2, pixel_sigma)
        for uv, j in zip(points.T, ids.tolist()):
            if self.target == "landmarks":
                key = L(j)
            else:
                key = self.landmark_key(k, j)
                self._add(gtsam.PriorFactorPoint3(key, self._Wpts[:, j], self._pin))
                self._pending_values.insert(key, self._Wpts[:, j])
            self._add(gtsam.GenericProjectionFactorCal3_S2(uv, noise, X(k), key, self._cal))

    def _add_motion(self, k: int, timestamp: float) -> None:
        if not self._segment:
            return
        if self.motion.model == "random_walk":
            prev = self._segment[-1][0]
            self._add(gtsam.BetweenFactorPose3(X(prev), X(k), gtsam.Pose3(), self.motion.noise()))
        elif self.motion.model == "wnoa":
            self._add(self._wnoa_factor(k, timestamp))
        elif len(self._segment) == 2:
            (k0, t0), (k1, t1) = self._segment
            ratio = (timestamp - t1) / (t1 - t0) if t1 > t0 else 1.0
            self._add(_constant_velocity_factor(X(k0), X(k1), X(k), ratio, self.motion.noise()))


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


def resection_factor(key, points, Wpts, K, pixel_sigma: float) -> gtsam.CustomFactor:
    """One factor holding a frame's junctions: pinhole projection of fixed target points.

    Parameters
    ----------
    key : int
        GTSAM key of the frame's ``Pose3`` (``T_WC``).
    points : (2, m) ndarray
        Measured pixels (u, v).
    Wpts : (3, m) ndarray
        The matching target points, metres; fixed.
    K : (3, 3) ndarray
        Intrinsics.
    pixel_sigma : float
        Isotropic standard deviation of a measured pixel coordinate.

    Returns
    -------
    gtsam.CustomFactor
        Error ``(u_1 - u'_1, v_1 - v'_1, ...)`` of length 2m (predicted minus measured),
        with its analytic Jacobian for the right perturbation ``T Exp(omega, v)``:
        ``dp_C = [p_C]_x omega - v``.

    Raises
    ------
    InputError
        If ``points`` or ``Wpts`` is malformed or not finite, their counts differ, or
        ``pixel_sigma`` is not a positive finite number.
    """
    points = as_points(points, 2, "points")
    Wpts = as_points(Wpts, 3, "Wpts")
    m = points.shape[1]
    if Wpts.shape[1] != m:
        raise InputError(f"points and Wpts must hold the same number of points, got {m} and {Wpts.shape[1]}")
    check_number("pixel_sigma", pixel_sigma, 0.0, strict=True)
    fx, s, cx, fy, cy = K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]
    noise = gtsam.noiseModel.Isotropic.Sigma(2 * m, pixel_sigma)

    def error(factor, values, jacobians):
        T = values.atPose3(factor.keys()[0])
        x, y, z = T.rotation().matrix().T @ (Wpts - T.translation()[:, None])
        e = np.empty(2 * m)
        e[0::2] = (fx * x + s * y) / z + cx - points[0]
        e[1::2] = fy * y / z + cy - points[1]
        if jacobians is not None:
            iz = 1.0 / z
            du = np.column_stack([fx * iz, s * iz, -(fx * x + s * y) * iz * iz])
            dv = np.column_stack([np.zeros(m), fy * iz, -fy * y * iz * iz])
            P = np.column_stack([x, y, z])
            J = np.empty((2 * m, 6))
            J[0::2, :3], J[0::2, 3:] = np.cross(du, P), -du
            J[1::2, :3], J[1::2, 3:] = np.cross(dv, P), -dv
            jacobians[0] = J
        return e

    return gtsam.CustomFactor(noise, [key], error)


def _constant_velocity_factor(ka, kb, kc, ratio: float, noise) -> gtsam.CustomFactor:
    """Three-pose factor ``Log(B^-1 C) - ratio Log(A^-1 B)`` (body twists, rotation first)."""

    def error(factor, values, jacobians):
        A, B, C = (values.atPose3(key) for key in factor.keys())
        Ha, Hb1, Hb2, Hc = (np.zeros((6, 6), order="F") for _ in range(4))
        L1, L2 = np.zeros((6, 6), order="F"), np.zeros((6, 6), order="F")
        v1 = gtsam.Pose3.Logmap(A.between(B, Ha, Hb1), L1)
        v2 = gtsam.Pose3.Logmap(B.between(C, Hb2, Hc), L2)
        if jacobians is not None:
            jacobians[0] = -ratio * L1 @ Ha
            jacobians[1] = L2 @ Hb2 - ratio * L1 @ Hb1
            jacobians[2] = L2 @ Hc
        return v2 - ratio * v1

    return gtsam.CustomFactor(noise, [ka, kb, kc], error)


# ============================================================================ front end


#: Image file name endings read as frames (case-insensitive).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm")

#: Frame statuses.
TRACKED, DETECTED, LOST = "tracked", "detected", "lost"


@dataclass(frozen=True)
class TrackerConfig:
    """Settings of :func:`track_sequence`.

    Attributes
    ----------
    motion : MotionPrior
        The back end's motion prior.
    min_junctions : int
        Fewest trusted, consistent junctions a frame needs; below it the front end falls back
        to full extraction, and if that fails too the frame is lost.
    min_detected_fraction : float
        Full extraction must trust at least this fraction of the board's junctions. A grid
        found with many junctions untrusted (heavy motion blur, a polygon cutting the board)
        can be labelled one square off, which no residual reveals.
    window_fraction : float
        Saddle-fit window radius as a fraction of the predicted local square side.
    window_px : (float, float)
        Clip of that radius, pixels.
    gate_px : float
        A refined junction further than this from its prediction is dropped (the fit
        wandered to another feature), pixels.
    outlier_sigmas : float
        A junction whose reprojection residual after the frame's own fit exceeds this many
        robust sigmas (and ``outlier_floor_px``) is dropped, and the frame refitted.
    outlier_floor_px : float
        Smallest residual ever called an outlier, pixels.
    max_rms_px : float
        A frame whose fit leaves more RMS residual than this is not believed (lost).
    rms_factor, rms_floor_px : float
        Once five frames have a pose, a frame whose fit RMS exceeds ``rms_factor`` times the
        median of those frames (and ``rms_floor_px``) is not believed either: heavy motion
        blur, or a grid labelled one square off, fits worse than the sequence's usual noise.
    max_speed : float
        Junctions predicted to move more than this many local square sides since the last
        frame are not tracked (constant velocity cannot predict a whip pan to within the
        half-square basin of the saddle fit); the frame goes to full extraction instead.
    min_pixel_sigma_px : float
        Floor of the per-frame pixel noise given to the back end, pixels.
    target : {"resection", "frame_landmarks", "landmarks"}
        How the fixed target enters the back end's graph (module docstring; measured
        trade-offs in ``scripts/bench_tracking.py``).

    Raises
    ------
    InputError
        If ``motion`` is not a :class:`MotionPrior`, ``target`` is not one of
        :data:`TARGET_FORMS`, ``min_junctions`` is not an integer >= 4 (a pose needs four
        points), ``min_detected_fraction`` is not in [0, 1], ``window_px`` is not
        ``(low, high)`` with ``2 <= low <= high`` (the saddle fit's smallest window),
        ``rms_floor_px`` is negative, or another setting is not a positive finite number.
    """

    motion: MotionPrior = field(default_factory=MotionPrior)
    min_junctions: int = 12
    min_detected_fraction: float = 0.9
    window_fraction: float = 0.3
    window_px: tuple = (4.0, 6.0)
    gate_px: float = 4.0
    outlier_sigmas: float = 4.0
    outlier_floor_px: float = 0.5
    max_rms_px: float = 1.5
    rms_factor: float = 3.0
    rms_floor_px: float = 0.03
    max_speed: float = 0.5
    min_pixel_sigma_px: float = 0.02
    target: str = "resection"

    def __post_init__(self):
        # Checked here, at construction: a bad setting used to fail frames into the track.
        if not isinstance(self.motion, MotionPrior):
            raise InputError(f"motion must be a MotionPrior, got {type(self.motion).__name__}")
        if self.target not in TARGET_FORMS:
            raise InputError(f"target must be one of {TARGET_FORMS}, got {self.target!r}")
        n = self.min_junctions
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 4:
            raise InputError(f"min_junctions must be an integer >= 4, got {n!r}")
        check_number("min_detected_fraction", self.min_detected_fraction, 0.0, maximum=1.0)
        for name in ("window_fraction", "gate_px", "outlier_sigmas", "outlier_floor_px", "max_rms_px",
                     "rms_factor", "max_speed", "min_pixel_sigma_px"):
            check_number(name, getattr(self, name), 0.0, strict=True)
        check_number("rms_floor_px", self.rms_floor_px, 0.0)
        try:
            low, high = self.window_px
        except (TypeError, ValueError):
            raise InputError(f"window_px must be (low, high) pixels, got {self.window_px!r}") from None
        check_number("window_px[0]", low, 2.0)
        check_number("window_px[1]", high, low)


@dataclass(frozen=True)
class FrameResult:
    """The tracker's answer for one frame.

    Attributes
    ----------
    index : int
        Frame index, 0-based, in input order.
    timestamp : float
        Seconds.
    status : {"tracked", "detected", "lost"}
        Tracked from the previous frame's prediction, detected by full extraction (first
        frame, fallback, after a loss), or lost (no usable board: no pose).
    T_WC : (4, 4) ndarray or None
        Camera pose in the target frame (the graph's estimate), None when lost.
    cov : (6, 6) ndarray or None
        Marginal covariance of ``(x, y, z, roll, pitch, yaw)``, metres and radians.
    junctions : int
        Junctions whose projection factors entered the graph (0 when lost).
    reprojection_rms_px : float
        RMS reprojection residual of those junctions at ``T_WC``, pixels (NaN when lost).
    single_T_WC : (4, 4) ndarray or None
        The frame's own single-frame fit of the same junctions (no motion prior).
    points : (2, m) ndarray or None
        The junctions used, pixels.
    ids : (m,) ndarray of int or None
        Their board indices (row-major).
    frontend_s, update_s : float
        Wall time of the front end (junctions and single-frame fit) and of the iSAM2
        update, seconds.
    message : str
        Why a frame was lost or fell back, empty otherwise.
    """

    index: int
    timestamp: float
    status: str
    T_WC: np.ndarray | None = None
    cov: np.ndarray | None = None
    junctions: int = 0
    reprojection_rms_px: float = float("nan")
    single_T_WC: np.ndarray | None = None
    points: np.ndarray | None = None
    ids: np.ndarray | None = None
    frontend_s: float = 0.0
    update_s: float = 0.0
    message: str = ""

    @property
    def sigma(self) -> np.ndarray | None:
        """Standard deviations of ``(x, y, z, roll, pitch, yaw)`` (m, rad), or None when lost."""
        return None if self.cov is None else np.sqrt(np.diag(self.cov))


@dataclass(frozen=True)
class Track:
    """A tracked sequence.

    Attributes
    ----------
    frames : tuple of FrameResult
        Every input frame, online (filtered) estimates: each frame's pose as iSAM2 knew it
        right after that frame.
    smoothed : tuple of FrameResult or None
        The same frames with poses and covariances from batch smoothing of the whole graph
        (``smooth=True``), else None.
    config : TrackerConfig
        The settings used.
    """

    frames: tuple
    smoothed: tuple | None
    config: TrackerConfig

    def __len__(self) -> int:
        return len(self.frames)

    @property
    def timestamps(self) -> np.ndarray:
        """(N,) seconds."""
        return np.array([f.timestamp for f in self.frames])

    @property
    def status(self) -> np.ndarray:
        """(N,) str array of the frame statuses."""
        return np.array([f.status for f in self.frames])

    @property
    def found(self) -> np.ndarray:
        """(N,) bool: frames with a pose (not lost)."""
        return np.array([f.status != LOST for f in self.frames])

    def poses(self, which: str = "best") -> np.ndarray:
        """Poses of every frame, (N, 4, 4), NaN for lost frames.

        ``which``: ``"online"`` (filtered), ``"smoothed"``, ``"single"`` (single-frame fits),
        or ``"best"`` (smoothed when available, else online).
        """
        if which == "best":
            which = "smoothed" if self.smoothed is not None else "online"
        if which == "smoothed" and self.smoothed is None:
            raise InputError("this track was not smoothed (use smooth=True)")
        source = {"online": self.frames, "smoothed": self.smoothed, "single": self.frames}.get(which)
        if source is None:
            raise InputError(f"which must be online, smoothed, single or best, got {which!r}")
        out = np.full((len(self.frames), 4, 4), np.nan)
        for k, f in enumerate(source):
            T = f.single_T_WC if which == "single" else f.T_WC
            if T is not None:
                out[k] = T
        return out

    def best_frames(self) -> tuple:
        """The smoothed frames when available, else the online ones."""
        return self.smoothed if self.smoothed is not None else self.frames


def list_frames(folder) -> list:
    """Image files of a folder in file-name order; other files are ignored.

    Parameters
    ----------
    folder : str or Path
        The folder.

    Returns
    -------
    list of Path
        Files whose name ends in one of :data:`IMAGE_SUFFIXES`, sorted by name.

    Raises
    ------
    InputError
        If the folder does not exist or holds no image.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"frames folder not found: {folder}")
    files = sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise InputError(f"no image files ({', '.join(IMAGE_SUFFIXES)}) in {folder}")
    return files


def read_timestamps(path, n_frames: int | None = None) -> np.ndarray:
    """Frame timestamps from a text file: one number (seconds) per line, ``#`` comments.

    Parameters
    ----------
    path : str or Path
        The file. Only the first number of a line is read (so a TUM-like file works too).
    n_frames : int, optional
        Expected count.

    Returns
    -------
    (N,) ndarray
        Seconds.

    Raises
    ------
    InputError
        If the file is missing or unreadable (a folder, not text), a line is not a number,
        the count differs from ``n_frames``, or the times do not increase strictly.
    """
    path = Path(path)
    try:
        lines = path.read_text().splitlines()
    except FileNotFoundError:
        raise InputError(f"timestamps file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read timestamps file {path}: {exc}") from None
    values = []
    for number, line in enumerate(lines, start=1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        try:
            values.append(float(line.replace(",", " ").split()[0]))
        except ValueError:
            raise InputError(f"{path}:{number}: not a timestamp: {line!r}") from None
    t = np.array(values)
    if n_frames is not None and t.size != n_frames:
        raise InputError(f"{path} holds {t.size} timestamps for {n_frames} frames")
    t = check_timestamps(t, str(path))
    return t


def track_sequence(frames, K, bounds=None, *, board: Board = Board(), timestamps=None, fps: float = 30.0,
                   polygons=None, config: TrackerConfig = TrackerConfig(), smooth: bool = False,
                   progress=None) -> Track:
    """Track the camera pose over a sequence of frames of the target.

    Parameters
    ----------
    frames : str, Path, or sequence of images or paths
        A folder (its image files in name order, see :func:`list_frames`), a list of image
        files, or images (H, W) / (H, W, 3|4) arrays, or an (N, H, W) array. Files are read
        one at a time.
    K : (3, 3) array_like
        Intrinsics, pixels (undistorted images).
    bounds : (2, 4) array_like, optional
        Bounding polygon of the board in the first frame (clockwise from the upper-left
        vertex, as in :func:`graphpose.detect.junctions.extract_junctions`). Without it (and
        without ``polygons[0]``) the first frame is searched in the whole image, which finds
        a board that is not too large in the frame; frames stay lost until it is found.
    board : Board
        The target.
    timestamps : (N,) array_like, optional
        Seconds per frame, strictly increasing; default ``index / fps``.
    fps : float
        Frame rate used when ``timestamps`` is None.
    polygons : sequence of ((2, 4) array_like or None), optional
        Per-frame bounding polygons used whenever a frame needs full extraction (first frame,
        fallback, re-detection after a loss), tried before the reprojected outline of the
        last pose.
    config : TrackerConfig
        Tracker settings.
    smooth : bool
        Also smooth the whole sequence in batch at the end (``Track.smoothed``).
    progress : callable, optional
        Called as ``progress(k, n_frames)`` after every frame.

    Returns
    -------
    Track
        One :class:`FrameResult` per frame; lost frames carry no pose.

    Raises
    ------
    InputError
        If K, bounds, timestamps, polygons or config are malformed, there are no frames, or
        a frame cannot be read or is not a finite grey or colour image (checked when the
        frame is reached). A frame without a usable board is NOT an error: it is lost.
    """
    K = check_K(K)
    source = _frame_source(frames)
    n = len(source)
    if n == 0:
        raise InputError("frames is empty")
    t = _timestamps(timestamps, fps, n)
    polys = _polygons(polygons, bounds, n)
    if not isinstance(config, TrackerConfig):
        raise InputError(f"config must be a TrackerConfig, got {type(config).__name__}")
    tracker = _Tracker(K, board, config)
    results = []
    for k in range(n):
        results.append(tracker.step(k, t[k], _load(source[k], k), polys[k]))
        if progress is not None:
            progress(k, n)
    smoothed = None
    if smooth:
        smoothed = tuple(tracker.smoothed(results))
    return Track(tuple(results), smoothed, config)


def _frame_source(frames):
    if isinstance(frames, (str, Path)):
        return list_frames(frames)
    if isinstance(frames, np.ndarray) and frames.ndim in (2, 3, 4) and frames.dtype != object:
        if frames.ndim == 2:
            raise InputError(f"frames must be a sequence of images, got one array of shape {frames.shape}")
        return frames
    try:
        return list(frames)
    except TypeError:
        raise InputError(f"frames must be a folder, a list of files or of images, got {type(frames).__name__}") from None


def _load(item, k):
    """Frame ``k`` converted and checked once, for every junction call of the frame: 8-bit
    grey as it is (no NaN possible; the junction code reads it without a copy), anything else
    float64 grey checked finite (:func:`graphpose.io.as_grey`: integers scaled to [0, 1],
    floats kept)."""
    if isinstance(item, (str, Path)):
        return read_image(item)
    try:
        image = np.asarray(item)
        if image.ndim == 2 and image.dtype == np.uint8 and image.size:
            return image
        return as_grey(image)
    except (TypeError, ValueError) as exc:  # InputError is a ValueError; ragged lists raise ValueError
        raise InputError(f"frame {k} must be a finite (H, W) grey or (H, W, 3|4) colour image: {exc}") from None


def _timestamps(timestamps, fps, n):
    if timestamps is None:
        if not (np.isfinite(fps) and fps > 0):
            raise InputError(f"fps must be a positive number, got {fps!r}")
        return np.arange(n) / float(fps)
    t = as_float_array(timestamps, "timestamps").reshape(-1)
    if t.size != n:
        raise InputError(f"timestamps has {t.size} entries for {n} frames")
    t = check_timestamps(t, "timestamps")
    return t


def _polygons(polygons, bounds, n):
    polys = [None] * n
    if polygons is not None:
        polygons = list(polygons)
        if len(polygons) != n:
            raise InputError(f"polygons has {len(polygons)} entries for {n} frames")
        polys = [None if p is None else _check_poly(p, f"polygons[{k}]") for k, p in enumerate(polygons)]
    if bounds is not None:
        polys[0] = _check_poly(bounds, "bounds")
    return polys


def _check_poly(P, name):
    P = as_float_array(P, name)
    if P.shape != (2, 4) or not np.all(np.isfinite(P)):
        raise InputError(f"{name} must be a finite (2, 4) polygon (u row, v row), got shape {P.shape}")
    return P


class _Tracker:
    """Per-frame state: the front end's predictions and the back end graph."""

    def __init__(self, K, board, config):
        self.K, self.board, self.config = K, board, config
        self.Wpts = board.world_points()
        self.sheet_W = board.sheet_corners()
        self.graph = SequenceGraph(K, board, config.motion, target=config.target)
        self.recent = []  # (k, timestamp, T_WC) of the last two tracked frames, consecutive
        self.last_outline = None  # outline of the last frame with the whole sheet in view
        self.rms = []  # fit RMS of every frame with a pose

    def step(self, k, t, image, polygon) -> FrameResult:
        start = time.perf_counter()
        found, status, message = None, LOST, ""
        prediction = self._predict(k, t)
        if prediction is not None:
            found, message = _attempt(self._track, image, prediction)
            status = TRACKED if found is not None else LOST
        if found is None:
            for poly in self._detection_polygons(polygon, prediction, image.shape[:2]):
                found, why = _attempt(self._detect, image, poly)
                if found is not None:
                    status = DETECTED
                    break
                message = f"{message}; {why}" if message else why
        frontend_s = time.perf_counter() - start
        if found is None:
            self.recent = []
            self.graph.break_segment()
            return FrameResult(k, t, LOST, frontend_s=frontend_s, message=message or "no polygon to search")
        points, ids, fit = found
        if status == DETECTED:
            # The motion model failed to predict this frame (or there was none): no motion
            # factor may tie it to the frames before.
            self.graph.break_segment()
        self.rms.append(fit.residual_rms_px)
        sigma = max(fit.sigma_px, self.config.min_pixel_sigma_px)
        back = self.graph.add_frame(k, t, points, ids, fit.T_WC, sigma)
        self.recent = (self.recent + [(k, t, back.T_WC)])[-2:]
        outline = project(self.K, back.T_WC, self.sheet_W)
        if _inside(outline, image.shape):
            self.last_outline = outline
        rms = _rms(project(self.K, back.T_WC, self.Wpts[:, ids]) - points)
        return FrameResult(k, t, status, back.T_WC, back.cov, len(ids), rms, fit.T_WC, points, ids,
                           frontend_s, back.update_s, message if status == DETECTED else "")

    def smoothed(self, results):
        batch = self.graph.smooth()
        for f in results:
            if f.index not in batch:
                yield f
                continue
            b = batch[f.index]
            rms = _rms(project(self.K, b.T_WC, self.Wpts[:, f.ids]) - f.points)
            yield FrameResult(f.index, f.timestamp, f.status, b.T_WC, b.cov, f.junctions, rms, f.single_T_WC,
                              f.points, f.ids, f.frontend_s, f.update_s, f.message)

    # ----------------------------------------------------------------- prediction
    def _predict(self, k, t):
        """Constant-velocity prediction from the last two frames, or None after a loss."""
        if not self.recent or self.recent[-1][0] != k - 1:
            return None
        k1, t1, T1 = self.recent[-1]
        if len(self.recent) < 2:
            return T1
        _, t0, T0 = self.recent[0]
        ratio = (t - t1) / (t1 - t0)
        twist = gtsam.Pose3.Logmap(gtsam.Pose3(np.linalg.inv(T0) @ T1))
        return T1 @ gtsam.Pose3.Expmap(ratio * twist).matrix()

    def _detection_polygons(self, polygon, prediction, shape):
        """Polygons to search, most specific first: the caller's, the predicted outline, the
        last whole outline seen and two enlargements of it, then the whole image."""
        polys = [polygon] if polygon is not None else []
        if prediction is not None:
            polys.append(project(self.K, prediction, self.sheet_W))
        if self.last_outline is not None:
            centre = self.last_outline.mean(axis=1, keepdims=True)
            polys += [centre + f * (self.last_outline - centre) for f in (1.0, 1.4, 2.0)]
        h, w = shape
        if polygon is None or self.last_outline is not None:
            polys.append(np.array([[0.0, w - 1.0, w - 1.0, 0.0], [0.0, 0.0, h - 1.0, h - 1.0]]))
        return [np.clip(P, 0.0, [[w - 1.0], [h - 1.0]]) for P in polys]

    # ----------------------------------------------------------------- junctions
    def _track(self, image, T_pred):
        """Refine predicted junctions; (points, ids, fit) or (None, why)."""
        cfg = self.config
        C = to_camera(T_pred, self.Wpts)
        if np.any(C[2] <= 0):
            return None, "prediction puts the board behind the camera"
        uv = project(self.K, T_pred, self.Wpts)
        side = _square_px(self.K, T_pred, self.Wpts, uv, self.board.square_m)
        speed = np.median(np.hypot(*(uv - project(self.K, self.recent[-1][2], self.Wpts))) / side)
        if speed > cfg.max_speed:
            return None, f"predicted motion {speed:.2f} squares a frame is too fast to track"
        radius = np.clip(cfg.window_fraction * side, *cfg.window_px)
        h, w = image.shape
        inside = (uv[0] - radius >= 0) & (uv[0] + radius <= w - 1) & (uv[1] - radius >= 0) & (uv[1] + radius <= h - 1)
        ids = np.flatnonzero(inside)
        if ids.size < cfg.min_junctions:
            return None, f"only {ids.size} predicted junctions in the image"
        points, trusted, _ = refine_junctions(image, uv[:, ids], radius[ids])
        keep = trusted & (np.hypot(*(points - uv[:, ids])) < cfg.gate_px)
        return self._fit(points[:, keep], ids[keep], T_pred)

    def _detect(self, image, polygon):
        """Full extraction inside a polygon; (points, ids, fit) or (None, why)."""
        try:
            J = extract_junctions(image, polygon, self.board)
        except (BoardNotFoundError, InputError) as exc:
            return None, f"extraction failed: {exc}"
        ids = np.flatnonzero(J.trusted)
        need = max(self.config.min_junctions, int(np.ceil(self.config.min_detected_fraction * self.board.n)))
        if ids.size < need:
            return None, f"extraction trusted only {ids.size} of {self.board.n} junctions (need {need})"
        T0 = pose_from_homography(self.K, J.points[:, ids], self.Wpts[:, ids])
        return self._fit(J.points[:, ids], ids, T0)

    def _fit(self, points, ids, T_guess):
        """Single-frame fit, outlier removal, checks; (points, ids, fit) or (None, why)."""
        cfg = self.config
        for _ in range(3):
            if ids.size < cfg.min_junctions:
                return None, f"only {ids.size} consistent junctions (need {cfg.min_junctions})"
            try:
                fit = gauss_newton(self.K, T_guess, points, self.Wpts[:, ids], huber_px=cfg.outlier_floor_px)
            except InputError as exc:
                return None, f"pose fit failed: {exc}"
            e = np.hypot(*fit.residuals)
            limit = max(cfg.outlier_sigmas * np.median(e) / 1.1774, cfg.outlier_floor_px)  # Rayleigh median
            bad = e > limit
            if not bad.any():
                break
            points, ids, T_guess = points[:, ~bad], ids[~bad], fit.T_WC
        else:
            return None, "outlier removal did not settle"
        if not fit.converged:
            return None, f"pose fit did not converge: {fit.message}"
        limit = cfg.max_rms_px
        if len(self.rms) >= 5:
            limit = min(limit, max(cfg.rms_factor * float(np.median(self.rms)), cfg.rms_floor_px))
        if fit.residual_rms_px > limit:
            return None, f"fit residual {fit.residual_rms_px:.3f} px RMS exceeds {limit:.3f} px"
        return (points, ids, fit), ""


def _attempt(method, *args):
    """``method(*args)`` of the front end; an InputError from the junction or pose code (a
    degenerate frame its own checks did not foresee) fails this attempt, so the frame falls
    back to the next one or is lost, never the sequence."""
    try:
        return method(*args)
    except InputError as exc:
        return None, f"{method.__name__.strip('_')} failed: {exc}"


def _square_px(K, T_WC, Wpts, uv, square_m) -> np.ndarray:
    """Local square side at each junction, pixels: the shorter projected grid step."""
    du = project(K, T_WC, Wpts + [[square_m], [0.0], [0.0]]) - uv
    dv = project(K, T_WC, Wpts + [[0.0], [square_m], [0.0]]) - uv
    return np.minimum(np.hypot(*du), np.hypot(*dv))


def _inside(uv, shape) -> bool:
    h, w = shape
    return bool(np.all((uv[0] >= 0) & (uv[0] <= w - 1) & (uv[1] >= 0) & (uv[1] <= h - 1)))


def _rms(d) -> float:
    return float(np.sqrt(np.mean(d * d))) if d.size else float("nan")

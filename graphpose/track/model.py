"""The tracker's factor model: the keys, the noise models and the factors each frame adds
(:class:`FactorBuilder`), with what a frame gave the back end (:class:`FrameMeasurement`).
The online back ends (:mod:`graphpose.track.backend`) and the batch smoothing
(:mod:`graphpose.track.smoothing`) build their graphs with it, so that all of them minimise
the same cost.

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
    (:func:`graphpose.track.factors.resection_factor`, a ``CustomFactor`` whose error is one
    call of a compiled kernel, GTSAM having no such factor of its own). This is
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
"""

from __future__ import annotations

from dataclasses import dataclass

import gtsam
import numpy as np
from gtsam.symbol_shorthand import L, V, X

from ..board import Board
from ..errors import InputError
from ..pose.graph import projection_factor
from .config import TARGET_FORMS, MotionPrior
from .factors import _resection_factor, constant_velocity_factor


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
        The camera model (already checked, :func:`graphpose.camera_models.as_camera`).
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

    def frame(self, k: int, timestamp: float, points, ids, T_WC_init, pixel_sigma: float) -> tuple:
        """Frame ``k``'s new factors and variables.

        Returns
        -------
        graph : gtsam.NonlinearFactorGraph
            Its target factors, then its motion factor (if any).
        values : gtsam.Values
            Initial values of its new variables: ``X(k)`` at ``T_WC_init``, its landmarks at
            the target points, new velocities at zero.
        stamps : dict
            ``{key: seconds}`` of the new variables (each stamped with its own frame's time).
        """
        graph, values, stamps = gtsam.NonlinearFactorGraph(), gtsam.Values(), {}
        self._target_factors(graph, values, stamps, k, timestamp, points, ids, pixel_sigma)
        velocity = self._motion_factor(graph, values, stamps, k, timestamp)
        values.insert(X(k), gtsam.Pose3(np.asarray(T_WC_init, dtype=float)))
        stamps[X(k)] = timestamp
        self.segment = (self.segment + [(k, timestamp, velocity)])[-2:]
        return graph, values, stamps

    def _target_factors(self, graph, values, stamps, k, timestamp, points, ids, pixel_sigma) -> None:
        if self.target == "resection":
            graph.add(_resection_factor(X(k), points, self._Wpts[:, ids], self.camera, pixel_sigma))
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

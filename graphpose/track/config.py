"""Settings of the tracker: the motion prior between frames and the front end's thresholds.

:class:`MotionPrior` says how the camera may move from one frame to the next (the back end's
motion factors, :mod:`graphpose.track.backend`); :class:`TrackerConfig` holds it with the
front end's thresholds (:mod:`graphpose.track.frontend`) and the form in which the fixed
target enters the back end's graph. Both check their values when made, so a bad setting
fails at once rather than frames into a sequence. No GTSAM here: the noise models are built
by the back end.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._checks import MIN_POSE_POINTS, check_number
from ..errors import InputError

#: Pose models the back end knows (:class:`MotionPrior`).
MOTION_MODELS = ("constant_velocity", "random_walk", "wnoa")

#: How the fixed target enters the back end's graph (:mod:`graphpose.track.backend`).
TARGET_FORMS = ("resection", "landmarks", "frame_landmarks")

#: Default lag of the fixed-lag back end, seconds (9 frames at 30 fps): past the frames
#: whose factors move a new frame's estimate (a 0.3 s lag gives the online poses of a 1 s lag
#: within 0.5 um), and short, to keep each update cheap: the part of the smoother's Bayes
#: tree re-eliminated at each frame grows with the lag (about 13 variables at 1 s, 23 at 2 s)
#: and settles within a few lags.
DEFAULT_LAG_S = 0.3
#: Frames one motion factor ties together, per model (:class:`MotionPrior`): a fixed lag must
#: hold them, or every frame starts a segment of its own (:func:`shortest_lag_s`).
MOTION_SPAN_FRAMES = {"constant_velocity": 3, "random_walk": 2, "wnoa": 2}


def shortest_lag_s(model: str, timestamps) -> float:
    """The shortest lag (seconds) that holds the frames one motion factor ties together.

    Parameters
    ----------
    model : str
        One of :data:`MOTION_MODELS`.
    timestamps : (n,) ndarray
        The frames' seconds, strictly increasing (checked by the caller).

    Returns
    -------
    float
        ``(MOTION_SPAN_FRAMES[model] - 1)`` times the median frame interval; 0 for fewer than
        two frames. A lag shorter than this marginalises a frame before the next motion
        factor can reach it, so the motion prior would never act.
    """
    t = np.asarray(timestamps, dtype=float)
    if t.size < 2:
        return 0.0
    return (MOTION_SPAN_FRAMES[model] - 1) * float(np.median(np.diff(t)))


def default_lag_s(model: str, timestamps) -> float:
    """:data:`DEFAULT_LAG_S`, or for slow sequences (a time-lapse, a few frames a second)
    twice :func:`shortest_lag_s`, whichever is longer, seconds."""
    return max(DEFAULT_LAG_S, 2.0 * shortest_lag_s(model, timestamps))


@dataclass(frozen=True)
class MotionPrior:
    """The motion prior between consecutive frames.

    Attributes
    ----------
    model : {"constant_velocity", "random_walk", "wnoa"}
        Constant body-frame twist (a three-pose factor), a random walk on the pose, or
        constant velocity with velocity variables (GTSAM's white-noise-on-acceleration
        factor); see :mod:`graphpose.track.backend`.
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
    sigmas smooth less.
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


@dataclass(frozen=True)
class TrackerConfig:
    """Settings of :func:`graphpose.track.tracker.track_sequence`.

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
    robust : bool
        The frame's own pose fit (:func:`graphpose.estimate.fit_pose`, the single-image
        pipeline's) down-weights outlying junctions with the Huber kernel at 1.345 robust
        sigmas, as ``estimate_pose(..., robust=True)``. Off by default, as there: the
        junctions reaching the fit already passed the saddle fit's trust test and the gate
        above, the iteratively reweighted fit takes several more iterations, and on clean
        junctions it is slightly less efficient than least squares. The back end's pose is
        the same either way up to the fit's pixel sigma, which sets the junctions' weight.
    max_rms_px : float
        A frame whose fit leaves more RMS residual than this is not believed (lost). The
        RMS is OpenCV's ``sqrt(mean(du^2 + dv^2))``; 2.1 px and the floor's 0.042 px are the
        1.5 and 0.03 px the tracker had when its RMS was taken over the coordinates apart
        (sqrt(2) smaller), so the gate refuses the same frames.
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
        How the fixed target enters the back end's graph (:mod:`graphpose.track.backend`).
    lag_s : float or None
        The online back end keeps the frames of the last ``lag_s`` seconds in a fixed-lag
        smoother and marginalises older ones, so that a frame's cost and memory stay flat
        however long the sequence (:class:`graphpose.track.fixed_lag.FixedLagGraph`; default
        :data:`DEFAULT_LAG_S`). None: one iSAM2 over the whole sequence
        (:class:`graphpose.track.sequence_graph.SequenceGraph`), whose cost grows with it. Either
        way ``smooth=True`` smooths the whole sequence in batch at the end.

    Raises
    ------
    InputError
        If ``motion`` is not a :class:`MotionPrior`, ``target`` is not one of
        :data:`TARGET_FORMS`, ``min_junctions`` is not an integer >= 4 (a pose needs four
        points), ``min_detected_fraction`` is not in [0, 1], ``window_px`` is not
        ``(low, high)`` with ``2 <= low <= high`` (the saddle fit's smallest window),
        ``robust`` is not a bool, ``rms_floor_px`` is negative, ``lag_s`` is neither None nor
        a positive finite number, or another setting is not a positive finite number.
    """

    motion: MotionPrior = field(default_factory=MotionPrior)
    min_junctions: int = 12
    min_detected_fraction: float = 0.9
    window_fraction: float = 0.3
    window_px: tuple = (4.0, 6.0)
    gate_px: float = 4.0
    robust: bool = False
    max_rms_px: float = 2.1
    rms_factor: float = 3.0
    rms_floor_px: float = 0.042
    max_speed: float = 0.5
    min_pixel_sigma_px: float = 0.02
    target: str = "resection"
    lag_s: float | None = DEFAULT_LAG_S

    def __post_init__(self):
        if not isinstance(self.motion, MotionPrior):
            raise InputError(f"motion must be a MotionPrior, got {type(self.motion).__name__}")
        if self.target not in TARGET_FORMS:
            raise InputError(f"target must be one of {TARGET_FORMS}, got {self.target!r}")
        n = self.min_junctions
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < MIN_POSE_POINTS:
            raise InputError(f"min_junctions must be an integer >= {MIN_POSE_POINTS}, got {n!r}")
        check_number("min_detected_fraction", self.min_detected_fraction, 0.0, maximum=1.0)
        if not isinstance(self.robust, (bool, np.bool_)):
            raise InputError(f"robust must be True or False, got {self.robust!r}")
        for name in ("window_fraction", "gate_px", "max_rms_px", "rms_factor", "max_speed", "min_pixel_sigma_px"):
            check_number(name, getattr(self, name), 0.0, strict=True)
        check_number("rms_floor_px", self.rms_floor_px, 0.0)
        if self.lag_s is not None:
            check_number("lag_s", self.lag_s, 0.0, strict=True)
        try:
            low, high = self.window_px
        except (TypeError, ValueError):
            raise InputError(f"window_px must be (low, high) pixels, got {self.window_px!r}") from None
        check_number("window_px[0]", low, 2.0)
        check_number("window_px[1]", high, low)

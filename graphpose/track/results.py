"""What the tracker returns: one :class:`FrameResult` per frame, gathered in a :class:`Track`,
and the back end's :class:`BackendResult` for one frame.

Poses are ``T_WC`` (camera in the target frame) and covariances are those of the pose
parameters ``(x, y, z, roll, pitch, yaw)`` of :mod:`graphpose.geometry` (metres, radians), like
:class:`graphpose.estimate.PoseEstimate`. A lost frame carries no pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..pose.covariance import SIGMA_PIXEL
from .._deprecated import renamed

#: Frame statuses: followed from the previous frame's prediction, found by full extraction,
#: or without a usable board.
TRACKED, DETECTED, LOST = "tracked", "detected", "lost"


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
        frame, fallback, after a loss), or lost (no usable board, or an unreadable frame
        file: no pose).
    T_WC : (4, 4) ndarray or None
        Camera pose in the target frame (the graph's estimate), None when lost.
    cov : (6, 6) ndarray or None
        Marginal covariance of ``(x, y, z, roll, pitch, yaw)``, metres and radians.
    junctions : int
        Junctions whose projection factors entered the graph (0 when lost).
    rms_px : float
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
    cov_pixel : (6, 6) ndarray or None
        The covariance from the pixel noise alone (the intrinsics taken as exact): the same
        as ``cov`` for a camera without a covariance, None when lost.
    sigma_kind : str
        What ``cov`` describes, as :attr:`graphpose.estimate.PoseEstimate.sigma_kind`:
        ``"pixel noise"``, or ``"pixel noise and calibration"`` for a camera that carries
        its intrinsics' covariance (:mod:`graphpose.track.uncertainty`: first order, per
        frame; the calibration's error is common to every frame).
    read_s : float
        Wall time of reading the frame (its file decoded, or the image given in memory
        converted, and its size checked), seconds.
    cpu_s : tuple of float
        Process CPU time of the frame's three parts, seconds: ``(read, front end, back end)``,
        the spans of ``read_s``, ``frontend_s`` and ``update_s`` (the back end's measured
        around its ``add_frame`` call; 0 for a part the frame did not reach). A few clock reads
        a frame (about 1 us each); what is left of the interval between two results (taking
        the back end's pose for the next prediction, the reprojection RMS, the result itself)
        is in none of them.
    """

    index: int
    timestamp: float
    status: str
    T_WC: np.ndarray | None = None
    cov: np.ndarray | None = None
    junctions: int = 0
    rms_px: float = float("nan")
    single_T_WC: np.ndarray | None = None
    points: np.ndarray | None = None
    ids: np.ndarray | None = None
    frontend_s: float = 0.0
    update_s: float = 0.0
    message: str = ""
    cov_pixel: np.ndarray | None = None
    sigma_kind: str = SIGMA_PIXEL
    read_s: float = 0.0
    cpu_s: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        if self.cov_pixel is None and self.sigma_kind == SIGMA_PIXEL:  # the two are one
            object.__setattr__(self, "cov_pixel", self.cov)

    reprojection_rms_px = renamed("reprojection_rms_px", "rms_px")

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
        The settings used (:class:`graphpose.track.config.TrackerConfig`).
    """

    frames: tuple
    smoothed: tuple | None
    config: object

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

        Raises
        ------
        InputError
            If ``which`` is none of these, or is ``"smoothed"`` for a track not smoothed.
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

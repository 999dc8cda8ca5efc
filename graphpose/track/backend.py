"""The tracker's back end: a factor graph over the frames, solved online by a fixed-lag
smoother (default) or by iSAM2 over the whole sequence, and smoothed in batch at the end.

Two online back ends take the same factors (:class:`FixedLagGraph`, :class:`SequenceGraph`):

- :class:`FixedLagGraph` (``TrackerConfig(lag_s=1.0)``, the default): GTSAM's
  ``IncrementalFixedLagSmoother``, iSAM2 over the frames of the last ``lag_s`` seconds. A
  variable older than the newest frame's timestamp minus the lag is marginalised out (its
  factors become one linear prior on the variables it shared them with), so the graph holds
  about ``lag_s * fps`` frames however long the sequence: per-frame time and memory stay
  flat. The online pose of a frame, and its covariance, are the smoother's right after the
  frame was added (filtered: it does not wait for later frames). It keeps each frame's measurements (a few hundred
  bytes) so that :meth:`FixedLagGraph.smooth` can build the whole sequence's graph once, at
  the end, and smooth it in batch.
- :class:`SequenceGraph` (``TrackerConfig(lag_s=None)``): one iSAM2 over the whole
  sequence (no variable is marginalised out); its per-frame cost and memory grow with the sequence.

Both follow one interface, :class:`Backend`, the one the tracker uses (:func:`make_backend`
picks the back end from ``lag_s``). Around them: the factor model each frame adds (:mod:`graphpose.track.model`,
with the custom factors of :mod:`graphpose.track.factors`), the batch smoothing
(:mod:`graphpose.track.smoothing`) and the iSAM2 settings they share
(:mod:`graphpose.track.isam`).

Trade-offs
----------
A Python ``CustomFactor`` linearised inside iSAM2 costs time in proportion to ALL the
variables in the graph (iSAM2's ``Values`` are copied for the call into Python), while a C++
factor does not. Over the whole sequence (:class:`SequenceGraph`) the update therefore grows
with the Python factors (``"resection"``, ``"constant_velocity"``), and its memory grows with
every form. The fixed lag bounds the graph, so every form and prior stays flat; the
figures (``python -m benchmarks tracking``) compare them.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from ..board import Board
from ..camera_models import Camera
from .config import DEFAULT_LAG_S, MotionPrior
from .fixed_lag import FixedLagGraph
from .model import FrameMeasurement
from .results import BackendResult
from .sequence_graph import SequenceGraph


@runtime_checkable
class Backend(Protocol):
    """What an online back end offers the tracker: :class:`~graphpose.track.fixed_lag.FixedLagGraph`
    and :class:`~graphpose.track.sequence_graph.SequenceGraph` both have every attribute and
    method below.

    Attributes
    ----------
    camera : Camera
        The camera model whose raw pixels the junctions are in.
    board : Board
        The target.
    motion : MotionPrior
        Prior between consecutive frames.
    target : str
        How the fixed target enters the graph, one of
        :data:`graphpose.track.config.TARGET_FORMS` (:mod:`graphpose.track.model`).
    lag_s : float or None
        The fixed lag, seconds; None over the whole sequence.
    frames : list of int
        Frame indices given to the back end, in order (a lost frame is never given).
    measurements : tuple of FrameMeasurement
        What each of those frames gave the back end, in order: all that rebuilds its factors
        (empty for a fixed lag made without ``keep_measurements``).
    """

    camera: Camera
    board: Board
    motion: MotionPrior
    target: str
    lag_s: float | None

    @property
    def frames(self) -> list: ...

    @property
    def measurements(self) -> tuple[FrameMeasurement, ...]: ...

    def break_segment(self) -> None:
        """Start a new segment: the next frame gets no motion factor (called after a loss)."""

    def add_frame(self, k: int, timestamp: float, points: np.ndarray, ids: np.ndarray, T_WC_init: np.ndarray,
                  pixel_sigma: float) -> BackendResult:
        """Add frame ``k`` and update the online estimate.

        Parameters
        ----------
        k : int
            Frame index, increasing.
        timestamp : float
            Seconds, increasing.
        points : (2, m) ndarray
            Junction pixels (u, v) seen in the frame.
        ids : (m,) int ndarray
            Which junction (row-major board index) each point is.
        T_WC_init : (4, 4) ndarray
            Initial guess of the pose (the frame's single-frame fit).
        pixel_sigma : float
            Standard deviation of a junction position, pixels.

        Returns
        -------
        BackendResult
            The frame's online (filtered) estimate and its marginal covariance.
        """

    def estimate(self) -> dict:
        """The current estimate, ``{k: (4, 4) T_WC}``: of every frame over the whole sequence,
        of the frames still inside the lag for the fixed lag."""

    def size(self) -> tuple:
        """``(factors, variables)`` the back end holds now."""

    def smooth(self) -> dict:
        """Batch-smooth the whole sequence (:mod:`graphpose.track.smoothing`): ``{k:
        BackendResult}`` for every frame given, covariances from the full graph's marginals."""

    def landmark_key(self, k: int, j: int) -> int:
        """Key of frame ``k``'s copy of target point ``j`` in the ``"frame_landmarks"`` form:
        ``symbol('l', k * stride + j)`` (:func:`graphpose.track.model.landmark_stride`)."""


def make_backend(camera, board: Board, motion: MotionPrior, target: str = "resection",
                 lag_s: float | None = DEFAULT_LAG_S, keep_measurements: bool = True) -> Backend:
    """The online :class:`Backend` for ``lag_s``: :class:`FixedLagGraph` over that many
    seconds (keeping the frames' measurements for :meth:`Backend.smooth` only with
    ``keep_measurements``), or :class:`SequenceGraph` over the whole sequence when ``lag_s``
    is None (which keeps its whole graph whatever ``keep_measurements`` says)."""
    if lag_s is None:
        return SequenceGraph(camera, board, motion, target=target)
    return FixedLagGraph(camera, board, motion, target=target, lag_s=lag_s, keep_measurements=keep_measurements)

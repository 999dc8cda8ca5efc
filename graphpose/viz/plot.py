"""A picture of a tracked trajectory: the ``plot`` extra (matplotlib; :mod:`graphpose._extras`).

Only :func:`plot_track` imports matplotlib, and only its object API (no pyplot, so no global
figure state), so the rest of graphpose never needs it.
"""

from __future__ import annotations

import io

import numpy as np

from .._checks import as_float_array
from ..board import Board
from ..errors import InputError
from ..io.files import atomic_write

#: Colours of the frame statuses, and of the truth.
_COLOURS = {"tracked": "tab:blue", "detected": "tab:green", "lost": "tab:red", "truth": "0.55"}


def plot_track(track, path, *, board: Board = Board(), truth=None, title: str = "") -> None:
    """Save a PNG of a track: its path seen from above and from the side, the position over
    time, and the per-frame reprojection RMS with the lost frames marked.

    Parameters
    ----------
    track : graphpose.track.results.Track
        The tracked sequence; its best poses (smoothed when available) are drawn.
    path : str or Path
        Output PNG, written whole or not at all.
    board : Board
        The target, drawn as a line in the two views of the path.
    truth : (N, 4, 4) array_like, optional
        True poses T_WC of the same N frames (NaN rows where unknown), drawn in grey beneath
        the track; the panels say "truth" only when it is drawn.
    title : str
        A title over the picture.

    Raises
    ------
    InputError
        If matplotlib is not installed, ``truth`` is not an array of numbers with one pose per
        frame, or the file cannot be written.
    """
    from .._extras import require

    FigureCanvasAgg = require("matplotlib.backends.backend_agg", "plot", "the trajectory picture").FigureCanvasAgg
    from matplotlib.figure import Figure
    frames = track.best_frames()
    poses = track.poses("best")
    if truth is not None:
        truth = as_float_array(truth, "truth")
        if truth.shape != poses.shape:
            raise InputError(f"truth must hold one 4 x 4 pose per frame, shape {poses.shape}, got {truth.shape}")
    figure = Figure(figsize=(11, 7.5), layout="constrained")
    FigureCanvasAgg(figure)
    top, side, position, rms = figure.subplots(2, 2).ravel()
    _path_view(top, poses, truth, board, (0, 2), "x (m)", "z (m)", "seen from above")
    _path_view(side, poses, truth, board, (1, 2), "y (m)", "z (m)", "seen from the side")
    _positions(position, track.timestamps, poses, truth)
    _reprojection(rms, frames)
    if title:
        figure.suptitle(title)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=100)
    atomic_write(path, buffer.getvalue())


def _path_view(ax, poses, truth, board, axes, xlabel, ylabel, name):
    """Camera centres projected on two target axes, with the board as a line at z = 0."""
    a, b = axes
    if truth is not None:
        ax.plot(truth[:, a, 3], truth[:, b, 3], color=_COLOURS["truth"], lw=2.5, label="truth")
    ax.plot(poses[:, a, 3], poses[:, b, 3], color=_COLOURS["tracked"], lw=1, label="graphpose")
    extent = (board.cols - 1 if a == 0 else board.rows - 1) * board.square_m
    ax.plot([0.0, extent], [0.0, 0.0], color="k", lw=4, solid_capstyle="butt", label="board")
    ax.set(xlabel=xlabel, ylabel=ylabel, title=f"camera path in the target frame, {name}")
    ax.set_aspect("equal", adjustable="datalim")  # true proportions, filling the panel
    ax.legend(loc="best", fontsize="small")


def _positions(ax, t, poses, truth):
    """x, y, z of the camera over time; gaps where frames are lost."""
    for i, (axis, colour) in enumerate(zip("xyz", ("tab:red", "tab:green", "tab:blue"))):
        if truth is not None:
            ax.plot(t, truth[:, i, 3], color=colour, lw=3, alpha=0.3)
        ax.plot(t, poses[:, i, 3], color=colour, lw=1, label=axis)
    ax.set(xlabel="time (s)", ylabel="position (m)",
           title="camera position" + (" (faint: truth)" if truth is not None else ""))
    ax.legend(loc="best", fontsize="small")


def _reprojection(ax, frames):
    """Per-frame reprojection RMS coloured by status; lost frames as marks on the axis."""
    for status in ("tracked", "detected"):
        chosen = [f for f in frames if f.status == status]
        ax.plot([f.timestamp for f in chosen], [f.rms_px for f in chosen], ".",
                color=_COLOURS[status], label=f"{status} ({len(chosen)})")
    lost = [f.timestamp for f in frames if f.status == "lost"]
    ax.plot(lost, np.zeros(len(lost)), "|", color=_COLOURS["lost"], ms=12, label=f"lost ({len(lost)})")
    ax.set(xlabel="time (s)", ylabel="RMS (px)", title="reprojection RMS per frame", ylim=(0, None))
    ax.legend(loc="best", fontsize="small")

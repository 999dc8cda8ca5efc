"""One tracked frame drawn on its image, for ``graphpose track --overlay-video``.

The marks of :func:`graphpose.viz.overlay.draw_overlay`, for a tracker's frame result: the
measured junctions (cyan rings), the junctions reprojected from the frame's pose (magenta plus
signs) and the board's grid through them, the target's axes, and one line of text (the frame,
its time, its status and reprojection RMS). A lost frame is the dimmed image with its status in
red.
"""

from __future__ import annotations

import numpy as np

from ..board import Board
from ..camera_models import as_camera
from ..image import as_grey
from .overlay import COLOURS, _draw_axes, _grid_lines, _line, _plus, _ring, _text, _visible


def draw_track_frame(image, frame, camera, board: Board = Board(), label: str = "") -> np.ndarray:
    """Draw a tracker's result on its frame.

    Parameters
    ----------
    image : (H, W) array_like
        The frame, raw as the camera took it.
    frame : FrameResult
        The tracker's result for it (:class:`graphpose.track.results.FrameResult`): ``T_WC``
        (None for a lost frame), ``points`` (2, n) pixels, ``status``, ``timestamp``,
        ``reprojection_rms_px``.
    camera : Camera or (3, 3) array_like
        The camera the frame was tracked with.
    board : Board
        The target.
    label : str
        Written before the frame's status (e.g. the frame's index).

    Returns
    -------
    (H, W, 3) ndarray of uint8
        A new RGB image (even height and width are the caller's to ensure for yuv420p).
    """
    camera = as_camera(camera)
    grey = as_grey(image)
    canvas = np.repeat((40.0 + 170.0 * np.clip(grey, 0.0, 1.0))[..., None], 3, axis=2)
    size = max(1.0, min(canvas.shape[:2]) / 480.0)
    scale = max(1, int(round(min(canvas.shape[:2]) / 240.0)))
    if frame.T_WC is not None:
        T = np.asarray(frame.T_WC, dtype=float)
        for curve in _grid_lines(camera, T, board):
            for a, b in zip(curve.T[:-1], curve.T[1:]):
                _line(canvas, a, b, COLOURS["reprojected"], 1.0, alpha=0.55)
        for u, v in _visible(camera, T, board.world_points()).T:
            _plus(canvas, u, v, 3.5 * size, COLOURS["reprojected"], 1.0)
        if frame.points is not None:
            for u, v in np.asarray(frame.points, dtype=float).T:
                if np.isfinite(u) and np.isfinite(v):
                    _ring(canvas, u, v, 6.0 * size, 2.0 * size, COLOURS["trusted"])
        _draw_axes(canvas, camera, T, 2.0 * board.square_m, size)
        text, colour = f"{label} {frame.status}  {frame.rms_px:.2f} px", COLOURS["good"]
    else:
        text, colour = f"{label} {frame.status}", COLOURS["bad"]
    _text(canvas, 6 * scale, 6 * scale, f"t {frame.timestamp:.3f} s  {text}".strip(), colour, scale)
    return np.clip(np.round(canvas), 0, 255).astype(np.uint8)

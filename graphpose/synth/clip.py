"""A calibration clip: a board waved in front of a camera, as people film one to calibrate from.

:func:`calibration_clip` draws key poses spread over the image (as
:func:`graphpose.synth.calibration.calibration_set` does, some pushed partly out of the image),
and moves between them: the hand slows near each key pose (sharp frames) and moves fast between
them, where a frame whose junctions move more than ``blur_threshold_px`` during the exposure
(half a frame interval) is the mean of renders along its exposure (motion blur). Frames are
rendered one at a time (:meth:`CalibrationClip.frames`), so a minute of video never sits in
memory.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from ..board import Board, check_board
from ..camera_models import as_camera
from ..geometry import to_camera
from .calibration import _pose
from .render import render_ideal

#: Share of the time between two key poses the hand spends near them (slow, sharp frames).
DWELL = 0.45


@dataclass(frozen=True)
class CalibrationClip:
    """A rendered clip's truth and how to render its frames.

    Attributes
    ----------
    camera : Camera
        The camera (the truth a calibration is measured against).
    board : Board
        The target.
    timestamps : (N,) ndarray
        Seconds, ``k / fps``.
    T_WC : (N, 4, 4) ndarray
        The camera pose at mid-exposure of each frame.
    subframes : (N,) ndarray of int
        Renders averaged for each frame (1: sharp; more: motion-blurred).
    visible : (N,) ndarray of float
        Share of the board's junctions inside the image.
    """

    camera: object
    board: Board
    timestamps: np.ndarray
    T_WC: np.ndarray
    subframes: np.ndarray
    visible: np.ndarray
    noise_sigma: float
    seed: int

    def __len__(self) -> int:
        return len(self.timestamps)

    def frames(self):
        """The frames, (H, W) uint8 each, rendered in order (noise seeded per clip)."""
        rng = np.random.default_rng(self.seed)
        fps = 1.0 / float(np.median(np.diff(self.timestamps)))
        for k in range(len(self)):
            yield self.frame(k, fps, rng=rng)

    def frame(self, k: int, fps: float, *, rng) -> np.ndarray:
        """Frame ``k``: the mean of its renders over the exposure, with noise, quantised."""
        m = int(self.subframes[k])
        poses = [self.T_WC[k]] if m == 1 else _exposure(self, k, m, fps)
        ideal = np.mean([render_ideal(self.camera, T, self.board, supersample=1) for T in poses], axis=0)
        noisy = ideal + rng.normal(0.0, self.noise_sigma, ideal.shape)
        return np.clip(np.round(noisy), 0, 255).astype(np.uint8)


def calibration_clip(camera, seconds: float = 60.0, fps: float = 30.0, *, rng=0, board: Board = Board(),
                     key_every_s: float = 1.5, partial_share: float = 0.2, blur_threshold_px: float = 1.5,
                     max_subframes: int = 8, noise_sigma: float = 2.0) -> CalibrationClip:
    """Draw a calibration clip (see the module docstring).

    Parameters
    ----------
    camera : Camera
        The camera, with its ``size``.
    seconds, fps : float
        Length and frame rate.
    rng : int
        Seed of the key poses and the noise.
    board : Board
        The target.
    key_every_s : float
        Seconds between key poses.
    partial_share : float
        Share of the key poses with the board partly out of the image.
    blur_threshold_px : float
        Junction motion during the exposure above which a frame is motion-blurred, pixels.
    max_subframes : int
        Most renders averaged for a blurred frame.
    noise_sigma : float
        Pixel noise, grey levels.

    Returns
    -------
    CalibrationClip
    """
    camera = as_camera(camera)
    board = check_board(board)
    gen = np.random.default_rng(rng)
    width, height = camera.size
    extent = (board.cols + 1) * board.square_m
    near_px = 0.75 * min(width, height)
    distance = (camera.fx * extent / near_px, camera.fx * extent / (0.4 * near_px))
    n_keys = int(np.ceil(seconds / key_every_s)) + 1
    keys = []
    W = board.world_points()
    while len(keys) < n_keys:
        near, reach = (gen.uniform(0.1, 0.9) * width, gen.uniform(0.1, 0.9) * height), (0.1 * width, 0.1 * height)
        T = _pose(camera, board, distance, 10.0, 50.0, 30.0, near, reach, rng=gen)
        if T is not None and gen.random() < partial_share:
            T = _push_out(camera, T, W, gen)
        if T is not None:
            keys.append(T)
    t = np.arange(int(round(seconds * fps))) / fps
    poses = _trajectory(np.array(keys), key_every_s, t)
    uv = np.stack([camera.project(to_camera(T, W)) for T in poses])  # (N, 2, n)
    inside = np.all(np.isfinite(uv), axis=1) & (uv[:, 0] >= 0) & (uv[:, 0] <= width - 1) & \
        (uv[:, 1] >= 0) & (uv[:, 1] <= height - 1)
    speed = np.zeros(len(t))  # junction motion during the exposure (half a frame), pixels
    d = np.linalg.norm(np.diff(uv, axis=0), axis=1)
    motion = np.nanmax(np.where(inside[1:] & inside[:-1], d, np.nan), axis=1, initial=0.0) if d.size else d
    speed[1:] = 0.5 * np.nan_to_num(motion)
    subframes = np.clip(np.ceil(speed / blur_threshold_px), 1, max_subframes).astype(int)
    subframes[speed <= blur_threshold_px] = 1
    return CalibrationClip(camera, board, t, poses, subframes, inside.mean(axis=1), float(noise_sigma),
                           int(gen.integers(2**31)))


def _push_out(camera, T, W, gen):
    """``T`` moved sideways (the camera along its own x or y axis) until 20-45 % of the
    junctions are out of the image; None when no such move is found."""
    width, height = camera.size
    axis, sign = gen.integers(2), gen.choice([-1.0, 1.0])
    target = gen.uniform(0.2, 0.45)
    for step in np.linspace(0.01, 0.6, 60):
        S = T.copy()
        S[:3, 3] = T[:3, 3] + sign * step * T[:3, axis]
        uv = camera.project(to_camera(S, W))
        inside = np.all(np.isfinite(uv), axis=0) & (uv[0] >= 0) & (uv[0] <= width - 1) & (uv[1] >= 0) & \
            (uv[1] <= height - 1)
        if 1.0 - inside.mean() >= target:
            return S
    return None


def _trajectory(keys, every, t) -> np.ndarray:
    """Poses at times ``t``: near key ``i`` for the first DWELL of its interval (slowly drifting),
    then an eased move to key ``i + 1``."""
    n = len(keys)
    seg = np.minimum((t // every).astype(int), n - 2)
    s = (t - seg * every) / every
    out = np.empty((len(t), 4, 4))
    rot = Rotation.from_matrix(keys[:, :3, :3])
    for i in np.unique(seg):
        mask = seg == i
        u = s[mask]
        drift = 0.04 * u  # a slow drift while dwelling
        move = np.clip((u - DWELL) / (1 - DWELL), 0, 1)
        w = np.where(u < DWELL, drift, 0.04 * DWELL + (1 - 0.04 * DWELL) * (3 * move**2 - 2 * move**3))
        slerp = Slerp([0.0, 1.0], rot[[i, i + 1]])
        out[mask, :3, :3] = slerp(w).as_matrix()
        out[mask, :3, 3] = (1 - w)[:, None] * keys[i, :3, 3] + w[:, None] * keys[i + 1, :3, 3]
        out[mask, 3] = (0, 0, 0, 1)
    return out


def _exposure(clip, k, m, fps) -> list:
    """``m`` poses over frame ``k``'s exposure (half a frame interval centred on its time)."""
    a = clip.T_WC[max(k - 1, 0)]
    b = clip.T_WC[min(k + 1, len(clip) - 1)]
    rot = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([a[:3, :3], b[:3, :3]])))
    out = []
    for f in np.linspace(0.375, 0.625, m):  # a quarter of [k-1, k+1]: half a frame interval
        T = np.eye(4)
        T[:3, :3] = rot(f).as_matrix()
        T[:3, 3] = (1 - f) * a[:3, 3] + f * b[:3, 3]
        out.append(T)
    return out

"""Synthetic image sequences of the target with their true trajectory, to measure a tracker.

Motion model
------------
A hand-held camera looking at the board, built from smooth signals of time (sums of a few
sinusoids of random frequency and phase, so the pose is defined at any instant):

- the board centre's distance from the camera drifts through ``distance`` (metres);
- the camera moves on a sphere about the board centre, viewing it up to ``max_tilt_deg``
  off its normal;
- the optical axis wanders off the board centre (the board drifts in the image, by as much
  as the free room at that distance allows) and the camera rolls by up to ``max_roll_deg``;
- a small hand tremor (2-4 Hz, about 0.5 mm and 0.05 degrees);
- ``excursions`` whip pans: a smooth bump of 60-75 degrees about the camera's y axis over
  ``excursion_frames`` frames that throws the board out of view and brings it back.

Each frame is rendered by :func:`graphpose.synth.render.render_ideal` at its mid-exposure pose.
When the junctions move more than ``blur_threshold_px`` during the exposure (half a frame
interval), the frame is the average of ideal renders at evenly spaced sub-frame poses
(one per 1.5 pixels of motion, at most ``max_subframes``): motion blur. Then Gaussian
noise is added and the image quantised to 8 bits. The true pose of a frame is its
mid-exposure pose.

Files written by :func:`write_sequence`::

    OUT_DIR/frame_00000.png ...   8-bit grey frames
    OUT_DIR/truth.tum             true T_WC of EVERY frame (TUM format, see graphpose.io.tum)
    OUT_DIR/bounds.json           K, board, fps, size, the first frame's bounding polygon
                                  ("bounds", 2 x 4) and the per-frame labels
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._checks import check_count, check_K, check_number, check_range, check_size
from ..board import check_board
from ..board import Board
from ..geometry import project, rot_x, rot_y, rot_z, to_camera
from ..errors import InputError
from ..io.files import write_json, write_png
from ..io.tum import write_tum
from .poses import loose_polygon
from .render import render, render_ideal

#: Border, pixels, inside which a junction counts as visible.
VISIBLE_BORDER_PX = 8.0


@dataclass(frozen=True)
class Sequence:
    """A rendered sequence and its truth.

    Attributes
    ----------
    images : (N, H, W) ndarray of uint8
        The frames.
    timestamps : (N,) ndarray
        Seconds, ``k / fps``.
    T_WC : (N, 4, 4) ndarray
        True camera pose in the target frame at every frame's mid-exposure.
    visible : (N,) ndarray of int
        Junctions at least :data:`VISIBLE_BORDER_PX` inside the image. 0 means the board is
        out of view: a tracker must report the frame lost.
    subframes : (N,) ndarray of int
        Ideal renders averaged for the frame (1: no motion blur).
    bounds : (2, 4) ndarray
        A loose bounding polygon of the first frame's board (see
        :func:`graphpose.synth.poses.loose_polygon`).
    K : (3, 3) ndarray
        Intrinsics.
    board : Board
        The target.
    fps : float
        Frame rate.
    """

    images: np.ndarray
    timestamps: np.ndarray
    T_WC: np.ndarray
    visible: np.ndarray
    subframes: np.ndarray
    bounds: np.ndarray
    K: np.ndarray
    board: Board
    fps: float

    def __len__(self) -> int:
        return len(self.timestamps)

    @property
    def out_of_view(self) -> np.ndarray:
        """(N,) bool: no junction visible."""
        return self.visible == 0

    @property
    def in_view(self) -> np.ndarray:
        """(N,) bool: every junction visible."""
        return self.visible == self.board.n


class HandHeldMotion:
    """A smooth random camera trajectory about the board (see the module docstring).

    Parameters
    ----------
    K : (3, 3) ndarray
        Intrinsics.
    board : Board
        The target.
    size : (int, int)
        Image ``(width, height)``, pixels.
    duration : float
        Seconds the trajectory must cover.
    rng : numpy.random.Generator, int or None, keyword
        Source of randomness (None: fresh entropy).
    distance : (float, float)
        Range of the board centre's distance, metres.
    max_tilt_deg, max_roll_deg : float
        Largest view angle off the board normal and roll of the camera, degrees.
    excursions : int
        Whip pans that throw the board out of view.
    excursion_s : float
        Duration of one whip pan, seconds.
    """

    def __init__(self, K, board, size, duration, *, rng=None, distance=(0.6, 1.3), max_tilt_deg=30.0,
                 max_roll_deg=20.0, excursions=2, excursion_s=0.6):
        rng = np.random.default_rng(rng)
        self.K, self.board, self.size = K, board, size
        self.distance = distance
        self.centre_W = np.array([(board.cols - 1) / 2, (board.rows - 1) / 2, 0.0]) * board.square_m
        self._half_px = 0.5 * np.array([board.cols + 2, board.rows + 2]) * board.square_m * K[0, 0]
        self._span = max(duration, 10.0)  # normalise over at least 10 s: short clips move as slowly
        self._slow = [_Wave((0.02, 0.1), rng=rng) for _ in range(6)]
        self._tremor = [_Wave((2.0, 4.0), parts=2, rng=rng) for _ in range(6)]
        self._tilt = np.deg2rad(max_tilt_deg)
        self._roll = np.deg2rad(max_roll_deg)
        self.start, self._pans = 0.0, []
        self.start = self._first_full_view(rng=rng)
        slots = np.linspace(0.0, duration, excursions + 2)[1:-1] + self.start
        self._pans = [(t0 + rng.uniform(-0.1, 0.1) * duration / (excursions + 1), excursion_s,
                       np.deg2rad(rng.uniform(60.0, 75.0)) * rng.choice([-1.0, 1.0])) for t0 in slots]

    def __call__(self, t: float) -> np.ndarray:
        """Camera pose ``T_WC`` (4, 4) at time ``t`` seconds (from the clip's start)."""
        t = t + self.start
        s = [w(t) for w in self._slow]
        lo, hi = self.distance
        d = 0.5 * (lo + hi) + 0.5 * (hi - lo) * s[0]
        tilt_dir = rot_y(self._tilt * s[1] / np.sqrt(2)) @ rot_x(self._tilt * s[2] / np.sqrt(2))
        position = self.centre_W + d * (tilt_dir @ np.array([0.0, 0.0, -1.0]))
        position += 5e-4 * np.array([w(t) for w in self._tremor[:3]])
        C = _look_at(position, self.centre_W)
        # Off-centre aim: only as far as the board still fits in the image at this distance.
        room = np.maximum(0.0, 0.5 * np.array(self.size) - self._half_px / d - 10.0) / self.K[0, 0]
        pan = np.arctan(room[0] * s[3]) + sum(_bump(t, *p) for p in self._pans)
        nod = np.arctan(room[1] * s[4])
        shake = np.deg2rad(0.05) * np.array([w(t) for w in self._tremor[3:]])
        C = C @ rot_z(self._roll * s[5] + shake[0]) @ rot_y(pan + shake[1]) @ rot_x(nod + shake[2])
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = C, position
        return T


    def _first_full_view(self, tries: int = 200, *, rng) -> float:
        """A start time whose frame shows the whole sheet, 10 px inside the image."""
        sheet = self.board.sheet_corners()
        for _ in range(tries):
            start = rng.uniform(0.0, 30.0)
            for wave in self._slow:
                wave.normalise(start, start + self._span)
            T = self(start)
            uv = project(self.K, T, sheet)
            if np.all(to_camera(T, sheet)[2] > 0) and np.all((uv >= 10) & (uv.T <= np.array(self.size) - 11).T):
                return start
        raise InputError("no start time shows the whole board; use a larger distance range")


class _Wave:
    """Sum of sinusoids of random frequency (Hz) and phase, scaled into [-1, 1].

    :meth:`normalise` makes it span exactly [-1, 1] over a stretch of time.
    """

    def __init__(self, band, parts=3, *, rng):
        self.f = rng.uniform(*band, parts)
        self.phase = rng.uniform(0.0, 2 * np.pi, parts)
        self.a = rng.uniform(0.5, 1.0, parts)
        self.a /= self.a.sum()
        self.shift, self.scale = 0.0, 1.0

    def normalise(self, t0: float, t1: float) -> None:
        """Scale so that the wave spans exactly [-1, 1] over [t0, t1]."""
        self.shift, self.scale = 0.0, 1.0
        values = [self(t) for t in np.linspace(t0, t1, 400)]
        self.shift = 0.5 * (max(values) + min(values))
        self.scale = 2.0 / max(max(values) - min(values), 1e-9)

    def __call__(self, t):
        value = np.sum(self.a * np.sin(2 * np.pi * self.f * t + self.phase))
        return float((value - self.shift) * self.scale)


def _bump(t, start, duration, amplitude):
    """Raised-cosine bump: 0 outside [start, start + duration], ``amplitude`` at its middle."""
    x = (t - start) / duration
    return 0.5 * amplitude * (1.0 - np.cos(2 * np.pi * x)) if 0.0 <= x <= 1.0 else 0.0


def _look_at(position, target) -> np.ndarray:
    """Rotation of a camera at ``position`` looking at ``target``, image x along target x."""
    z = target - position
    z /= np.linalg.norm(z)
    x = np.array([1.0, 0.0, 0.0]) - z[0] * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def render_sequence(K, n_frames: int = 300, *, rng=None, board: Board = Board(), size=(640, 480),
                    fps: float = 30.0, noise_sigma: float = 2.0, blur_sigma: float = 1.0,
                    distance=(0.6, 1.3), excursions: int = 2, blur_threshold_px: float = 2.0,
                    max_subframes: int = 16, supersample: int = 2, progress=None) -> Sequence:
    """Render a synthetic hand-held sequence of the board (model in the module docstring).

    Parameters
    ----------
    K : (3, 3) array_like
        Intrinsics, pixels.
    n_frames : int
        Frames to render, >= 2.
    rng : numpy.random.Generator, int or None
        Source of randomness (motion, noise, first polygon); an int (>= 0) seeds a new
        generator, None draws fresh entropy.
    board : Board
        The target.
    size : (int, int)
        Image ``(width, height)``, pixels.
    fps : float
        Frame rate; the exposure is half a frame interval.
    noise_sigma : float
        Gaussian noise, grey levels of 255.
    blur_sigma : float
        Optical blur, pixels.
    distance : (float, float)
        Range of the board centre's distance, metres.
    excursions : int
        Whip pans throwing the board out of view (0 for none).
    blur_threshold_px : float
        Junction motion during the exposure above which a frame gets motion blur, pixels.
    max_subframes : int
        Most ideal renders averaged for one frame, >= 1.
    supersample : int
        Passed to :func:`graphpose.synth.render.render_ideal`, >= 1 (2 keeps junctions within
        ~0.002 px of finer grids at a fraction of the cost).
    progress : callable, optional
        Called as ``progress(k, n_frames)`` after each frame.

    Returns
    -------
    Sequence

    Raises
    ------
    InputError
        Before any rendering: if K is invalid, ``board`` is not a :class:`Board`, ``size``
        is not two positive integers, ``n_frames`` is not an integer >= 2, ``fps`` is not a
        positive finite number, ``noise_sigma``, ``blur_sigma`` or ``blur_threshold_px`` is
        negative or not finite, ``distance`` is not ``(near, far)`` with
        ``0 < near <= far``, ``excursions`` is not an integer >= 0, ``max_subframes`` or
        ``supersample`` is not an integer >= 1, or ``rng`` is neither a Generator, a seed
        >= 0 nor None. Also if no start time of the drawn motion shows the whole board.
    """
    K = check_K(K)
    check_board(board)
    size = check_size(size)
    check_count("n_frames", n_frames, 2)
    check_count("excursions", excursions, 0)
    check_count("max_subframes", max_subframes, 1)
    check_count("supersample", supersample, 1)
    fps = check_number("fps", fps, 0.0, strict=True)
    for name, value in (("noise_sigma", noise_sigma), ("blur_sigma", blur_sigma),
                        ("blur_threshold_px", blur_threshold_px)):
        check_number(name, value, 0.0)
    distance = check_range("distance", distance, "(near, far) metres", minimum=0.0, strict=True)
    rng = _generator(rng)
    motion = HandHeldMotion(K, board, size, n_frames / fps, rng=rng, distance=distance, excursions=excursions)
    times = np.arange(n_frames) / fps
    ideal = dict(blur_sigma=blur_sigma, supersample=supersample, background=60.0, white=215.0, black=35.0)
    # The background alone: the board drawn in the background's own grey.
    background = render_ideal(K, motion(0.0), board, size, **{**ideal, "white": 60.0, "black": 60.0})
    images, poses, visible, subframes = [], [], [], []
    W = board.world_points()
    sheet = board.sheet_corners()
    exposure = 0.5 / fps
    for k, t in enumerate(times):
        T = motion(t)
        travel = np.max(np.linalg.norm(project(K, motion(t + exposure / 2), W) - project(K, motion(t - exposure / 2), W), axis=0))
        m = 1 if travel < blur_threshold_px else int(min(max_subframes, np.ceil(travel / 1.5) + 1))
        sub = [T] if m == 1 else [motion(t + ((i + 0.5) / m - 0.5) * exposure) for i in range(m)]
        image = np.mean([_ideal(K, S, board, size, ideal, background, sheet) for S in sub], axis=0)
        image += rng.normal(0.0, noise_sigma, image.shape)
        images.append(np.clip(np.rint(image), 0, 255).astype(np.uint8))
        poses.append(T)
        visible.append(visible_junctions(K, T, W, size))
        subframes.append(m)
        if progress is not None:
            progress(k, n_frames)
    first = render(K, poses[0], board, size, noise_sigma=0.0, **ideal)  # for its outline
    return Sequence(np.array(images), times, np.array(poses), np.array(visible), np.array(subframes),
                    loose_polygon(first, rng=rng), K, board, float(fps))


def _generator(rng) -> np.random.Generator:
    try:
        return np.random.default_rng(rng)
    except (TypeError, ValueError):
        raise InputError(f"rng must be a numpy Generator, an integer seed >= 0 or None, got {rng!r}") from None


def _ideal(K, T, board, size, ideal, background, sheet) -> np.ndarray:
    """Ideal render, or the plain background when a whip pan turns the sheet (``sheet``,
    its corners in the target frame) behind the camera (which the renderer rightly refuses)."""
    if np.any(to_camera(T, sheet)[2] <= 1e-3):
        return background
    return render_ideal(K, T, board, size, **ideal)


def visible_junctions(K, T_WC, W, size) -> int:
    """How many junctions a camera sees at least :data:`VISIBLE_BORDER_PX` inside its image.

    Parameters
    ----------
    K : (3, 3) ndarray
        Intrinsics, pixels (trusted).
    T_WC : (4, 4) ndarray
        Camera pose in the target frame (trusted).
    W : (3, n) ndarray
        The junctions' target points, metres.
    size : (int, int)
        Image ``(width, height)``, pixels.

    Returns
    -------
    int
        Junctions in front of the camera and inside the image's border.
    """
    uv = project(K, T_WC, W)
    ok = to_camera(T_WC, W)[2] > 0
    ok &= (uv[0] >= VISIBLE_BORDER_PX) & (uv[0] <= size[0] - 1 - VISIBLE_BORDER_PX)
    ok &= (uv[1] >= VISIBLE_BORDER_PX) & (uv[1] <= size[1] - 1 - VISIBLE_BORDER_PX)
    return int(np.count_nonzero(ok))


def write_sequence(sequence: Sequence, out_dir) -> Path:
    """Write a sequence's frames, true trajectory and first bounds (layout in the module docstring).

    Parameters
    ----------
    sequence : Sequence
        What :func:`render_sequence` returned.
    out_dir : str or Path
        Folder; created if missing.

    Returns
    -------
    Path
        The folder.

    Raises
    ------
    InputError
        If the folder cannot be created (a file in the way, no permission) or a file cannot
        be written; each file is written whole or not at all
        (:func:`graphpose.io.files.atomic_write`), files written before the failure stay.
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create folder {out}: {exc.strerror or exc}") from None
    for k, image in enumerate(sequence.images):
        write_png(out / f"frame_{k:05d}.png", image)
    write_tum(out / "truth.tum", sequence.timestamps, sequence.T_WC,
              header="true camera pose T_WC in the target frame, every frame (graphpose render-sequence)")
    b = sequence.board
    meta = {
        "K": sequence.K.tolist(),
        "board": f"{b.cols}x{b.rows}x{b.square_m}",
        "fps": sequence.fps,
        "size": [int(sequence.images.shape[2]), int(sequence.images.shape[1])],
        "bounds": sequence.bounds.tolist(),
        "visible_junctions": sequence.visible.tolist(),
        "out_of_view": np.flatnonzero(sequence.out_of_view).tolist(),
        "subframes": sequence.subframes.tolist(),
    }
    write_json(out / "bounds.json", meta)
    return out

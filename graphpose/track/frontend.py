"""The tracker's front end: one frame's junctions and its own pose, before the back end.

Per frame (:class:`FrontEnd`; thresholds in :class:`graphpose.track.config.TrackerConfig`; every
projection through the sequence's camera, :mod:`graphpose.camera_models`, on the raw frames):

1. **Predict** the pose from the last two frames with a constant body-frame twist
   (:func:`constant_velocity_prediction`), and every junction's pixel position from it.
2. **Refine** the predictions with the saddle fit (:func:`graphpose.detect.refine_junctions`,
   ``check=False``: the frame was checked at the tracker's edge),
   its smoothing set from the image's noise over the board's contrast as measured at the
   last detection (:func:`graphpose.detect.board_smoothing`: as on single images,
   more smoothing on noisy frames, so that the fits converge and pass the ring test there);
   drop the untrusted fits and the fits that wandered more than ``gate_px`` from their
   prediction. A prediction about a square off refines onto the neighbouring junctions:
   the fitted pose's squares must show the colours the last detection measured
   (:func:`graphpose.track.pattern.board_contrast`), or the frame is realigned (step 4).
3. **Fit** the frame's own pose with the single-image pipeline's fit,
   :func:`graphpose.estimate.fit_pose`: from the prediction, Gauss-Newton and, with
   ``robust``, its Huber gate on outlying junctions. Its input checks are not repeated: the
   junctions are the refinement's (finite), the start the prediction (rigid), and the frame
   itself was checked once, at the tracker's edge.
4. **Realign** a prediction the refinement could not follow (a whip pan):
   :func:`graphpose.track.pattern.pattern_shift` moves it onto the board's squares, the
   junctions are refined there (wider windows and more smoothing on a smeared frame) and fitted,
   and the result is kept only when the board's visible edges leave no other labelling nearly
   as good (:func:`graphpose.track.pattern.labelling_gap`): a wrong label is worse than a
   lost frame.
5. **Fall back** to full extraction (:func:`graphpose.detect.extract_junctions`, with
   its noise-aware search on noisy frames, then
   ``fit_pose`` from the homography) when too few junctions survive, when the motion is too
   fast to predict and realigning fails, or after a loss. Polygons are tried in turn: the caller's polygon for the
   frame, the predicted outline, the outline of the last frame whose junctions were all in
   the image and two enlargements of it, then no polygon (the whole image is searched). A
   detection must trust most of the junctions (a mostly untrusted grid can be labelled one
   square off, and no residual shows it). A polygon names junction 0's corner; without one,
   a board whose pattern is unchanged by a half turn (or a quarter turn, square boards)
   comes back labelled by the image's upper-left rule, and the front end keeps the
   orientation continuous instead: of the labellings the symmetry allows
   (:func:`board_symmetries`), it takes the one nearest the prediction (or, after a loss,
   the last pose). When extraction finds nothing, the board is **re-acquired** by realigning
   each of the last distinct views in turn (a pan that took the board away often brings it
   back), with the same test of the labels.
6. **Refuse** a frame whose fit does not converge or leaves much more residual than the
   sequence's usual (heavy motion blur, a grid labelled one square off): such a frame, and
   one where nothing is found, is lost. No pose is guessed.

The back end (:mod:`graphpose.track.backend`) then takes the frame's junctions with the fit
as its starting pose, and its estimate comes back through :meth:`FrontEnd.accept` to
predict the next frame.
"""

from __future__ import annotations

import re

import heapq
from dataclasses import dataclass

import gtsam
import numpy as np

from ..board import Board
from ..geometry import to_camera
from ..camera_models import as_camera
from ..detect import MAX_RADIUS, SMOOTH_SIGMA, WINDOW_FRACTION, board_smoothing, extract_junctions, refine_junctions
from ..errors import BoardNotFoundError, DegenerateGeometryError, InputError
# fit_pose without its input checks: the front end's junctions and poses are its own, made
# finite and rigid here (the public fit's checks were a tenth of a tracked frame's front end).
from ..estimate import fit_pose
from .config import TrackerConfig
from .pattern import (MAX_PATTERN_SPREAD, MIN_LABEL_GAP, BoardCells, board_contrast, cell_values, labelling_gap,
                      pattern_contrast, pattern_shift)
from .results import DETECTED, LOST, TRACKED


@dataclass(frozen=True)
class Measurement:
    """What the front end found in one frame.

    Attributes
    ----------
    status : {"tracked", "detected", "lost"}
        Followed from the prediction, found by full extraction, or nothing usable.
    points : (2, m) ndarray or None
        The junctions kept, pixels (u, v); None when lost.
    ids : (m,) ndarray of int or None
        Their board indices (row-major).
    fit : GNResult or None
        The frame's own pose fit of those junctions (:func:`graphpose.estimate.fit_pose`).
    message : str
        Why the frame was lost, or why it fell back to extraction; empty otherwise.
    """

    status: str
    points: np.ndarray | None = None
    ids: np.ndarray | None = None
    fit: object = None
    message: str = ""


class FrontEnd:
    """Per-frame junction work of the tracker, with the state it keeps between frames.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`; the frames are raw), or pinhole
        intrinsics ``K``, pixels.
    board : Board
        The target.
    config : TrackerConfig
        Thresholds.
    """

    def __init__(self, camera, board: Board, config: TrackerConfig):
        self.camera, self.board, self.config = as_camera(camera), board, config
        self._W = board.world_points()
        self._sheet = board.sheet_corners()
        sq = board.square_m
        # One projection a prediction: the junctions, then each moved one square along x and
        # along y (the local square side, _square_px); one an accepted pose: the junctions, then
        # the sheet's corners.
        self._W_steps = np.hstack([self._W, self._W + [[sq], [0.0], [0.0]], self._W + [[0.0], [sq], [0.0]]])
        self._W_sheet = np.hstack([self._W, self._sheet])
        self._symmetries = board_symmetries(board)
        self._recent = []  # (k, timestamp, T_WC) of the last two frames with a pose, consecutive
        self._last = None  # the newest pose, kept through losses: it orients re-detections
        self._views = []  # (T_WC, junction pixels) of the last distinct views: re-acquisition's starts
        self._seen = None  # the junctions' pixels at the newest pose (its accept's projection)
        self._reference = None  # the pose a fresh detection is oriented by (this frame's)
        self._outline = None  # sheet outline of the last frame whose junctions were all in view
        self._rms = RunningMedian()  # fit RMS of every frame with a pose
        # Smoothing of the tracked refinement, from the noise over the board's contrast as
        # measured at the last detection (noise changes slowly; measuring it costs a
        # detection's time, not a tracked frame's).
        self._smooth = SMOOTH_SIGMA
        self._cells = BoardCells(board)
        self._contrast = 0.0  # the board's signed contrast in the cells' pattern, at the last detection

    def project(self, T_WC, P_W) -> np.ndarray:
        """Pixels (2, N) of target points ``P_W`` (3, N) seen from ``T_WC``, through the camera."""
        return self.camera.project(to_camera(T_WC, P_W))

    def measure(self, k: int, timestamp: float, image: np.ndarray, polygon=None) -> Measurement:
        """Junctions and single-frame fit of frame ``k``.

        Parameters
        ----------
        k : int
            Frame index.
        timestamp : float
            Seconds.
        image : (H, W) ndarray
            The frame, grey (:meth:`graphpose.track.frames.FrameSource.load`).
        polygon : (2, 4) ndarray, optional
            The caller's bounding polygon for this frame (checked), tried first when the
            frame needs full extraction.

        Returns
        -------
        Measurement
            Lost when nothing usable was found; an error of the junction or pose code on a
            degenerate frame fails that attempt only, never the sequence.
        """
        prediction = self._predict(k, timestamp)
        self._reference = prediction if prediction is not None else self._last
        found, status, message = None, LOST, ""
        if prediction is not None:
            found, message = _attempt(self._track, image, prediction)
            if found is None and self._contrast:
                found, why = _attempt(self._realign, image, prediction)
                message = "; ".join(m for m in (message, why) if m)
            status = TRACKED if found is not None else LOST
        if found is None:
            whys = []
            for poly in self._detection_polygons(polygon, prediction, image.shape[:2]):
                found, why = _attempt(self._detect, image, poly)
                if found is not None:
                    status = DETECTED
                    break
                whys.append(why)
            message = "; ".join(m for m in (message, _detection_message(whys)) if m)
        if found is None and self._contrast:
            found = self._reacquire(image, prediction)
            if found is not None:
                status, message = DETECTED, f"{message}; re-acquired from a recent view"
        if found is None:
            return Measurement(LOST, message=message or "no polygon to search")
        points, ids, fit = found
        self._rms.add(fit.rms_px)
        return Measurement(status, points, ids, fit, message if status == DETECTED else "")

    def accept(self, k: int, timestamp: float, T_WC, shape) -> np.ndarray:
        """Take the back end's pose of frame ``k`` (image ``shape`` (H, W)) for the next
        predictions; returns where that pose sees every junction, pixels (2, n) (the tracker's
        reprojection RMS reads it)."""
        self._recent = (self._recent + [(k, timestamp, T_WC)])[-2:]
        self._last = T_WC
        n = self.board.n
        uv = self.project(T_WC, self._W_sheet)
        self._seen = uv[:, :n]
        if not self._views or _moved_squares(self._views[-1][1], self._seen, self.board.cols) > VIEW_STEP:
            self._views = (self._views + [(T_WC, self._seen)])[-RECENT_VIEWS:]
        # The anchor of re-detection after a loss: the newest frame with the whole grid of
        # junctions in the image, whether or not the sheet's margin was cut by the border
        # (the detection polygons are clipped to the image).
        if _inside(self._seen, shape):
            self._outline = uv[:, n:]
        return self._seen

    def lose(self) -> None:
        """Frame without a pose: the next one cannot be predicted."""
        self._recent = []

    # ----------------------------------------------------------------- prediction
    def _predict(self, k, t):
        """Constant-velocity prediction from the last two frames, or None after a loss."""
        if not self._recent or self._recent[-1][0] != k - 1:
            return None
        _, t1, T1 = self._recent[-1]
        if len(self._recent) < 2:
            return T1
        _, t0, T0 = self._recent[0]
        return constant_velocity_prediction(T0, T1, (t - t1) / (t1 - t0))

    def _detection_polygons(self, polygon, prediction, shape):
        """Polygons to search, most specific first: the caller's, the predicted outline, the
        last whole grid's outline and two enlargements of it, then None (the whole image)."""
        polys = [polygon] if polygon is not None else []
        if prediction is not None and np.all(to_camera(prediction, self._sheet)[2] > 0):
            polys.append(self.project(prediction, self._sheet))
        if self._outline is not None:
            centre = self._outline.mean(axis=1, keepdims=True)
            polys += [centre + f * (self._outline - centre) for f in (1.0, 1.4, 2.0)]
        h, w = shape
        polys = [np.clip(P, 0.0, [[w - 1.0], [h - 1.0]]) for P in polys if np.all(np.isfinite(P))]
        if polygon is None or self._outline is not None:
            polys.append(None)
        return polys

    # ----------------------------------------------------------------- junctions
    def _track(self, image, T_pred):
        """Refine predicted junctions; ((points, ids, fit), "") or (None, why)."""
        uv, side, why = self._predicted(T_pred)
        if uv is None:
            return None, why
        speed = float(np.median(np.hypot(*(uv - self._seen)) / side))
        if speed > self.config.max_speed:
            return None, f"predicted motion {speed:.2f} squares a frame is too fast to track"
        found, why = self._refine(image, uv, side, T_pred)
        if found is not None and self._contrast:
            # A prediction about a square off refines onto the neighbouring junctions, and
            # nothing in the fit shows it: the board's squares then show inverted colours.
            c = board_contrast(image, self._cells, self.camera, found[2].T_WC)
            if c * self._contrast <= 0:
                return None, "the tracked junctions put the board's squares on squares of the other colour"
        return found, why

    def _realign(self, image, T_pred):
        """The prediction missed by more than the refinement reaches (a whip pan): move it by
        the translation that puts the predicted squares on squares of their colour
        (:func:`graphpose.track.pattern.pattern_shift`), refine there, and keep the result
        only when the board's visible edges leave no other labelling nearly as good
        (:func:`graphpose.track.pattern.labelling_gap`); ((points, ids, fit), "") or (None, why)."""
        uv, side, why = self._predicted(T_pred)
        if uv is None:
            return None, why
        cells = self._cells
        sign = np.sign(self._contrast)
        shift = pattern_shift(image, cells, self.camera, T_pred, sign, float(np.median(side)),
                              min_score=MIN_PATTERN_SHARE * abs(self._contrast))
        if shift is None:
            return None, "realign: the board's squares are not near the prediction"
        # Frames of a whip pan are smeared along the motion: when the usual windows trust too
        # few junctions, wider windows on a smoother image, whose saddles the smear leaves.
        smeared = (REALIGN_WINDOW * side, max(self._smooth, REALIGN_SMOOTH * float(np.median(side))))
        for radius, smooth in ((None, None), smeared):
            found, why = self._refine(image, uv + shift[:, None], side, T_pred, gate=REALIGN_GATE * side,
                                      relative=False, radius=radius, smooth=smooth,
                                      need=int(np.ceil(REALIGN_MIN_SHARE * self.board.n)), kept=REALIGN_MIN_KEPT)
            if found is not None:
                break
        if found is None:
            return None, f"realign by ({shift[0]:.0f}, {shift[1]:.0f}) px: {why}"
        fit = found[2]
        gap, spread = labelling_gap(cells, cell_values(image, cells.pixels(self.camera, fit.T_WC)), sign)
        if gap < MIN_LABEL_GAP or spread > MAX_PATTERN_SPREAD:
            return None, (f"realign by ({shift[0]:.0f}, {shift[1]:.0f}) px: the visible board's edges do not fix "
                          f"its labels (another placement within {gap:.1f} squares' evidence)")
        return found, ""

    def _reacquire(self, image, prediction):
        """After a loss (or a prediction neither tracked nor realigned): the board often
        comes back where it was before a pan took it away. Realign from each of the last
        distinct views in turn, newest first; (points, ids, fit) or None."""
        for T_WC, _ in reversed(self._views):
            if prediction is not None and T_WC is self._recent[-1][2]:
                continue
            found, _ = _attempt(self._realign, image, T_WC)
            if found is not None:
                return found
        return None

    def _predicted(self, T_pred):
        """Predicted junction pixels (2, n) and local square sides (n,) at ``T_pred``, or
        (None, None, why)."""
        n = self.board.n
        P = to_camera(T_pred, self._W_steps)
        if (P[2, :n] <= 0).any():
            return None, None, "prediction puts the board behind the camera"
        steps = self.camera.project(P)
        uv = steps[:, :n]
        side = _square_px(uv, steps[:, n:2 * n], steps[:, 2 * n:])
        if not np.isfinite(side).all():
            return None, None, "prediction puts the board where the lens model has no image"
        return uv, side, ""

    def _refine(self, image, uv, side, T_pred, gate=None, relative=True, radius=None, smooth=None, need=None,
                kept=0.0):
        """Refine the junctions near ``uv`` (2, n) (square sides ``side``) and fit from
        ``T_pred``, keeping the fits within ``gate`` (pixels, scalar or (n,); the config's
        ``gate_px`` by default) of their start, with windows of ``radius`` pixels (n,) and
        smoothing ``smooth`` pixels (the tracked frame's by default); ((points, ids, fit), "")
        or (None, why). At least ``need`` junctions (the config's ``min_junctions`` by default),
        and the share ``kept`` of those in the image, must be kept."""
        cfg = self.config
        need = cfg.min_junctions if need is None else max(need, cfg.min_junctions)
        gate = np.broadcast_to(cfg.gate_px if gate is None else gate, side.shape)
        smooth = self._smooth if smooth is None else smooth
        if radius is None:
            radius = np.clip(cfg.window_fraction * side, *cfg.window_px)
            if self._smooth > SMOOTH_SIGMA:
                # A noisy frame: the single image's window, whose longer edges average the noise.
                radius = np.maximum(radius, np.clip(WINDOW_FRACTION * side, cfg.window_px[0], MAX_RADIUS))
        h, w = image.shape
        inside = (uv[0] - radius >= 0) & (uv[0] + radius <= w - 1) & (uv[1] - radius >= 0) & (uv[1] + radius <= h - 1)
        ids = np.flatnonzero(inside)
        if ids.size < need:
            return None, f"only {ids.size} predicted junctions in the image (need {need})"
        # Unchecked: the frame was checked once, at the tracker's edge (a float frame's
        # finiteness check alone is a pass over every pixel), the windows are >= 2 px.
        points, trusted, _ = refine_junctions(image, uv[:, ids], radius[ids], smooth_sigma=smooth,
                                              camera=self.camera, check=False)
        keep = trusted & (np.hypot(*(points - uv[:, ids])) < gate[ids])
        need = max(need, int(np.ceil(kept * ids.size)))
        if np.count_nonzero(keep) < need:
            return None, (f"only {np.count_nonzero(keep)} of {ids.size} junctions refined within "
                          f"{np.median(gate):.3g} px of their prediction (need {need})")
        return self._fit(points[:, keep], ids[keep], T_pred, relative=relative)

    def _detect(self, image, polygon):
        """Full extraction inside a polygon (the whole image for None); ((points, ids, fit), "")
        or (None, why)."""
        try:
            J = extract_junctions(image, bounds=polygon, board=self.board, camera=self.camera)
        except (BoardNotFoundError, InputError) as exc:
            return None, f"extraction failed: {exc}"
        points, trusted = J.points, J.trusted
        if J.orientation_ambiguous and self._reference is not None:
            points, trusted = self._orient(points, trusted, self._reference)
        ids = np.flatnonzero(trusted)
        need = max(self.config.min_junctions, int(np.ceil(self.config.min_detected_fraction * self.board.n)))
        if ids.size < need:
            return None, f"extraction trusted only {ids.size} of {self.board.n} junctions (need {need})"
        found, why = self._fit(points[:, ids], ids, None)
        if found is not None:
            cells = self._cells
            contrast = pattern_contrast(cells, cell_values(image, cells.pixels(self.camera, found[2].T_WC)))
            if contrast * self._contrast < 0:
                # The board's squares keep their colours through a sequence: a detection that
                # puts them the other way round from the last one is labelled one square off
                # (and taking its sign would let the colour check pass what follows it).
                return None, "the detected board's squares show the other colours than the sequence's"
            self._smooth = board_smoothing(image, J.points[:, J.seen], J.square_px[J.seen])
            self._contrast = contrast
        return found, why

    def _orient(self, points, trusted, T_ref):
        """The labelling of a symmetric board's junctions nearest the pose ``T_ref``'s.

        Of the relabellings the board's symmetry allows (:func:`board_symmetries`), the one
        whose trusted junctions lie nearest (median pixel distance) to where ``T_ref`` sees
        the same junctions; returns the relabelled (points, trusted).
        """
        with np.errstate(invalid="ignore"):
            expected = self.project(T_ref, self._W)
        best, best_d = (points, trusted), np.inf
        for perm in self._symmetries:
            p, t = np.empty_like(points), np.empty_like(trusted)
            p[:, perm], t[perm] = points, trusted
            d = np.hypot(*(p[:, t] - expected[:, t]))
            d = float(np.nanmedian(d)) if np.any(np.isfinite(d)) else np.inf
            if d < best_d:
                best, best_d = (p, t), d
        return best

    def _fit(self, points, ids, guess, relative=True):
        """The single-image fit (from ``guess``, or the homography when None) and the frame's
        checks; ((points, ids, fit), "") or (None, why). Without ``relative``, the residual is
        held to ``max_rms_px`` only, not to the sequence's usual (whose other task,
        catching a grid labelled one square off, the caller does otherwise)."""
        cfg = self.config
        try:
            fit, _ = fit_pose(points, self._W[:, ids], self.camera, guess=guess, mask=np.ones(ids.size, dtype=bool),
                              robust=cfg.robust, check=False)
        except (InputError, DegenerateGeometryError) as exc:
            return None, f"pose fit failed: {exc}"
        if not fit.converged:
            return None, f"pose fit did not converge: {fit.message}"
        limit = cfg.max_rms_px
        if relative and len(self._rms) >= 5:
            limit = min(limit, max(cfg.rms_factor * self._rms.median(), cfg.rms_floor_px))
        if fit.rms_px > limit:
            return None, f"fit residual {fit.rms_px:.3f} px RMS exceeds {limit:.3f} px"
        return (points, ids, fit), ""


def constant_velocity_prediction(T_WC_0, T_WC_1, ratio: float) -> np.ndarray:
    """The pose one interval after ``T_WC_1`` if the body-frame twist from ``T_WC_0`` to ``T_WC_1`` holds.

    Parameters
    ----------
    T_WC_0, T_WC_1 : (4, 4) ndarray
        Poses T_WC of two consecutive frames (trusted: rigid transforms).
    ratio : float
        The next frame interval over the one from ``T_WC_0`` to ``T_WC_1``.

    Returns
    -------
    (4, 4) ndarray
        ``T_WC_1 Exp(ratio Log(T_WC_0^-1 T_WC_1))``, with GTSAM's exact SE(3) exponential and
        logarithm (``Pose3.Expmap``/``Logmap``, the twist rotation first; the maps of
        :func:`graphpose.geometry.se3_exp` / :func:`~graphpose.geometry.se3_log`, in C++:
        a sixth of their time).
    """
    P1 = gtsam.Pose3(T_WC_1)
    twist = gtsam.Pose3.Logmap(gtsam.Pose3(T_WC_0).between(P1))
    return P1.compose(gtsam.Pose3.Expmap(ratio * twist)).matrix()


def _detection_message(whys) -> str:
    """One message for the failed detection attempts of a frame, each phrase said once.

    Reasons that differ only in their numbers and in where they looked ("inside the bounds",
    "in the image") are one phrase, the numbers as ranges and how many search areas gave it:
    ``extraction failed in 5 search areas: no checkerboard: 224-239 junction-like points but
    no grid of cross-junctions among them`` rather than the same words five times.
    """
    prefix = "extraction failed: "
    groups = {}  # the reason with its numbers and area blanked -> the reasons
    for why in whys:
        why = why[len(prefix):] if why.startswith(prefix) else why
        groups.setdefault(_NUMBER.sub("#", _AREA.sub("", why)), []).append(why)
    parts = []
    for key, members in groups.items():
        areas = {m.group(0) for why in members for m in _AREA.finditer(why)}
        text = members[0] if len(areas) <= 1 else _AREA.sub("", members[0])
        columns = zip(*(_NUMBER.findall(why) for why in members))
        spans = iter([min(c, key=float) if len(set(c)) == 1 else f"{min(c, key=float)}-{max(c, key=float)}"
                      for c in columns])
        text = _NUMBER.sub(lambda _: next(spans), text)
        parts.append(text + (f" ({len(members)} search areas)" if 1 < len(members) < len(whys) else ""))
    if not parts:
        return ""
    head = f"extraction failed in {len(whys)} search areas: " if len(whys) > 1 else prefix
    return head + "; ".join(parts)


#: The realigned refinement's gate, squares: a fit that wandered further from its start has
#: left the square around its junction.
REALIGN_GATE = 0.3
#: Least share of the board's junctions a realigned frame must keep: a smeared frame's pose
#: from a few junctions at the image's edge is biased by the smear far more than a tracked
#: frame's (15 mm from 14 junctions in a whip pan, against 0.1 mm).
REALIGN_MIN_SHARE = 0.5
#: Least share of the junctions in the image a realigned frame's refinement must keep: a frame
#: where more fail is smeared beyond what the saddle fit follows, and the junctions that
#: pass are biased by the smear too (15 mm of pose error with 35 of 48 kept in a whip pan,
#: 1-3 mm with 26 of 28 to 45 of 45).
REALIGN_MIN_KEPT = 0.85
#: The realigned refinement's second try on a smeared frame: window radius and Gaussian
#: smoothing, squares.
REALIGN_WINDOW = 0.45
REALIGN_SMOOTH = 0.08

#: Least share of the last detection's contrast the realigned squares must show (motion blur
#: lowers it; a board elsewhere or absent leaves about 0).
MIN_PATTERN_SHARE = 0.3

#: Re-acquisition's starts: the last RECENT_VIEWS views, each more than VIEW_STEP squares
#: from the one before.
RECENT_VIEWS = 8
VIEW_STEP = 0.5

#: Where a detection looked, in its reason; and a number in a reason.
_AREA = re.compile(r" (?:inside the bounds|in the image)")
_NUMBER = re.compile(r"\d+(?:\.\d+)?")


def _attempt(method, *args):
    """``method(*args)`` of the front end; an InputError from the junction or pose code (a
    degenerate frame its own checks did not foresee) fails this attempt, so the frame falls
    back to the next one or is lost, never the sequence."""
    try:
        return method(*args)
    except (InputError, DegenerateGeometryError) as exc:
        return None, f"{method.__name__.strip('_')} failed: {exc}"


def board_symmetries(board: Board) -> list:
    """The relabellings of a board's junctions under the turns that leave its grid unchanged.

    Parameters
    ----------
    board : Board
        The target.

    Returns
    -------
    list of (n,) ndarray of int
        ``perm[k]`` is the label junction ``k`` gets when the board is turned: the identity
        and the half turn (``k -> n - 1 - k``) for every board, and the two quarter turns for
        a square one (``cols == rows``). Whether the board's colours share the symmetry is
        the detector's to say (``Junctions.orientation_ambiguous``).
    """
    n = board.n
    perms = [np.arange(n), n - 1 - np.arange(n)]
    if board.cols == board.rows:
        c, r = board.grid_indices()
        m = board.cols - 1
        perms += [c * board.cols + (m - r), (m - c) * board.cols + r]  # (c, r) -> (m - r, c), (r, m - c)
    return perms


def _moved_squares(uv_a, uv_b, cols: int) -> float:
    """Median displacement between two views' junction pixels (2, n), in the median
    square side along the rows of ``uv_b``."""
    steps = np.hypot(*(uv_b[:, 1:] - uv_b[:, :-1]))[np.arange(1, uv_b.shape[1]) % cols != 0]
    return float(np.median(np.hypot(*(uv_b - uv_a))) / np.median(steps))


def _square_px(uv, uv_x, uv_y) -> np.ndarray:
    """Local square side at each junction, pixels: the shorter projected grid step, from the
    junctions' pixels ``uv`` and those of the points one square along x and along y (2, n)."""
    return np.minimum(np.hypot(*(uv_x - uv)), np.hypot(*(uv_y - uv)))


class RunningMedian:
    """The median of every value added so far, ``np.median``'s to the bit, each addition and
    median in O(log n) (two heaps: the lower half as a max-heap, the upper as a min-heap),
    where ``np.median`` of the growing list cost O(n) a frame (a millisecond at 10,000)."""

    def __init__(self):
        self._low, self._high = [], []  # -values of the lower half; values of the upper half

    def __len__(self) -> int:
        return len(self._low) + len(self._high)

    def add(self, value) -> None:
        """Add a finite number."""
        value = float(value)
        if self._low and value > -self._low[0]:
            heapq.heappush(self._high, value)
        else:
            heapq.heappush(self._low, -value)
        if len(self._low) > len(self._high) + 1:
            heapq.heappush(self._high, -heapq.heappop(self._low))
        elif len(self._high) > len(self._low):
            heapq.heappush(self._low, -heapq.heappop(self._high))

    def median(self) -> float:
        """The median (NaN before any value): the middle value, the mean of the middle two."""
        if not self._low:
            return float("nan")
        if len(self._low) > len(self._high):
            return -self._low[0]
        return (-self._low[0] + self._high[0]) / 2


def _inside(uv, shape) -> bool:
    h, w = shape
    return bool(np.all((uv[0] >= 0) & (uv[0] <= w - 1) & (uv[1] >= 0) & (uv[1] <= h - 1)))

"""``calibrate_rig(sources, model, *, board)``: a rig of cameras from images of the board.

The steps (``docs/rigs.md``):

1. **Frames.** Each camera's images (:mod:`.frames`: files, a folder, a glob), grouped into
   views by the number in their file names (``left07.jpg`` with ``right07.jpg``), or the
   views given as tuples (``frames=[(left, right), ...]``, None where a camera has none).
2. **Each camera alone.** :func:`graphpose.calibrate` on its own images: the junctions, the
   intrinsics, each view's pose ``T_WCc``, and the images it rejects (named). A camera
   needs three views with the board, as a calibration does.
3. **Start.** Each further camera's pose in camera 0's frame is the median of
   ``T_WC0^-1 T_WCc`` over the views both saw (the median of the translations, and of the
   rotation vectors about the first); a camera that shares no view with camera 0 is reached
   through another camera (the pair that shares most views first). A camera no chain of
   shared views reaches is unconstrained: an error says so. Each view's rig pose ``T_WC0`` is
   camera 0's, or another camera's carried to camera 0 when camera 0 did not see the board.
4. **Solve.** As :func:`graphpose.calibrate` does, on the whole rig: a plain solve, two Huber
   screening solves, and an observation (one camera in one view) whose RMS exceeds
   :data:`~graphpose.calibrate.run.REJECT_RATIO` times the median's is rejected (named) and the
   rest solved again. Then the robust solve twice, from the screening's fit, as
   :func:`graphpose.calibrate` does: GTSAM's graph (:mod:`.rig_graph`) and the hand-written
   Levenberg-Marquardt (:mod:`.rig_lm`), each on its own path; they must land on the same
   parameters, every one within :data:`~graphpose.calibrate.run.CROSS_CHECK_TOL` of
   ``max(|p|, sigma_p)``, or the calibration is not ok.

The covariance is GTSAM's joint marginal of every camera's intrinsics and every extrinsic,
scaled by the pixel noise the final residuals give, ``sqrt(sum w r^2 / (2M - N - 6n))``
(N the rig's parameters, n the views), and by the Huber estimate's variance factor
(:func:`huber_variance_factor`: the inverse weighted normal matrix alone understates the spread
where junctions are down-weighted).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._checks import check_number
from ..board import Board, check_board
from ..camera_models import model_class
from ..errors import InputError
from ..geometry import T_from_params, invert_transform, params_from_T, relative_pose, so3_exp, so3_log
from ..rig import Rig, rig_parameter_names
from .frames import file_number, match_frames, source_files
from .._deprecated import ignored_rng
from ..robust import HUBER_K, mad_sigma
from .run import CROSS_CHECK_TOL, MIN_IMAGES, REJECT_FLOOR_PX, REJECT_RATIO, SIGMA_FLOOR_PX, _rms
from .result import SolverCrossCheck

#: Per (view, camera) statuses.
STATUSES = ("used", "rejected", "no board", "no image")
#: Steps of each screening solve (the rejection's fit).
SCREENING_ITERATIONS = 10


@dataclass(frozen=True)
class RigCalibration:
    """A rig of cameras calibrated from images of the board.

    Attributes
    ----------
    rig : Rig
        The cameras (each carrying its intrinsics' covariance), ``T_C0_C``, and the joint
        covariance with its parameter names.
    cov : (N, N) ndarray
        Joint covariance of the rig's parameters (``parameter_names``): every camera's
        intrinsics (pixels, unitless), then every further camera's ``T_C0_C`` as ``(x, y, z,
        roll, pitch, yaw)`` (metres, radians).
    parameter_names : tuple of str
        ``cam0.fx`` ... ``cam1.x`` ... ``cam1.yaw`` (:func:`graphpose.rig.rig_parameter_names`).
    views : tuple of str
        Each view's name: its frame number, or ``view k`` for views given as tuples.
    images : tuple of tuple
        Per view, per camera: the image's name, or None where the camera has no image.
    status : tuple of tuple
        Per view, per camera: ``"used"``, ``"rejected"`` (see ``message``), ``"no board"`` or
        ``"no image"``.
    message : tuple of tuple
        Per view, per camera: why it was rejected or has no board ("" when used).
    poses : tuple
        Per view the rig's pose ``T_WC0`` (4, 4) (camera 0 in the board's frame, also when
        camera 0 did not see the board), None for a view no camera used.
    view_rms_px : (n_views, n_cameras) ndarray
        ``sqrt(mean(du^2 + dv^2))`` of each used observation, pixels; NaN otherwise.
    camera_rms_px : (n_cameras,) ndarray
        Each camera's RMS over its used junctions, pixels.
    rms_px : float
        RMS over every junction used, pixels.
    sigma_px : float
        The pixel noise behind ``cov``.
    calibrations : tuple of Calibration
        Each camera's own calibration (step 2), the start.
    ok : bool
        Both solvers converged and agree.
    cross_check : SolverCrossCheck
        The two solvers' parameters, their largest difference, its tolerance and whether
        each converged (as :class:`~graphpose.calibrate.result.Calibration`'s).
    summary : str
    """

    rig: Rig
    cov: np.ndarray
    parameter_names: tuple
    views: tuple
    images: tuple
    status: tuple
    message: tuple
    poses: tuple
    view_rms_px: np.ndarray
    camera_rms_px: np.ndarray
    rms_px: float
    sigma_px: float
    calibrations: tuple
    ok: bool
    cross_check: SolverCrossCheck
    summary: str

    @property
    def cameras(self) -> tuple:
        """The calibrated cameras."""
        return self.rig.cameras

    @property
    def T_C0_C(self) -> tuple:
        """Camera i's pose in camera 0's frame, (4, 4) each; the first the identity."""
        return self.rig.T_C0_C

    @property
    def parameters(self) -> np.ndarray:
        """The rig's parameters (N,), in ``parameter_names`` order."""
        return _vector(self.rig.cameras, self.rig.T_C0_C)

    @property
    def sigmas(self) -> np.ndarray:
        """1-sigma of each parameter (N,)."""
        return np.sqrt(np.abs(np.diag(self.cov)))

    def extrinsics(self) -> list:
        """Each further camera's baseline and rotation relative to camera 0, with 1-sigma.

        Returns
        -------
        list of dict
            Per camera i >= 1: ``camera`` (i), ``baseline_m`` and ``baseline_sigma_m``
            (``||t||`` of ``T_C0_C[i]``), ``rotation_deg`` and ``rotation_sigma_deg`` (the
            angle of its rotation), first-order from ``cov``.
        """
        out = []
        for i in range(1, len(self.rig)):
            s = self.parameter_names.index(f"cam{i}.x")
            C = self.cov[s: s + 6, s: s + 6]
            q = params_from_T(self.T_C0_C[i])
            t = q[:3]
            b = float(np.linalg.norm(t))
            u = t / b if b > 0 else np.zeros(3)
            omega = so3_log(self.T_C0_C[i][:3, :3])
            J = np.empty((3, 3))
            for k in range(3):
                d = np.zeros(6)
                d[3 + k] = 1e-7
                J[:, k] = (so3_log(T_from_params(q + d)[:3, :3]) - so3_log(T_from_params(q - d)[:3, :3])) / 2e-7
            S = J @ C[3:, 3:] @ J.T
            theta = float(np.linalg.norm(omega))
            a = omega / theta if theta > 0 else np.ones(3) / np.sqrt(3.0)
            out.append({"camera": i, "baseline_m": b, "baseline_sigma_m": float(np.sqrt(u @ C[:3, :3] @ u)),
                        "rotation_deg": float(np.degrees(theta)),
                        "rotation_sigma_deg": float(np.degrees(np.sqrt(max(a @ S @ a, 0.0))))})
        return out


def _vector(cameras, T_C0_C) -> np.ndarray:
    return np.concatenate([c.parameters for c in cameras] + [params_from_T(T) for T in T_C0_C[1:]])


def _views(sources, frames):
    """Per view, per camera: (image or path, name) or None; the views' names."""
    if frames is not None:
        frames = [tuple(f) for f in frames]
        n = len(frames[0]) if frames else 0
        if n < 2 or any(len(f) != n for f in frames):
            raise InputError(f"frames must be tuples of one image per camera (at least two cameras), all of "
                             f"one length; got lengths {sorted({len(f) for f in frames})}")
        views = [[None if x is None else (x, Path(x).name if isinstance(x, (str, Path)) else f"view {k} camera {c}")
                  for c, x in enumerate(f)] for k, f in enumerate(frames)]
        return views, [f"view {k}" for k in range(len(frames))]
    if isinstance(sources, (str, Path)) or len(sources) < 2:
        raise InputError("sources must give one source per camera (a list of files, a folder or a glob each), "
                         "at least two cameras")
    files = [source_files(s, f"camera {c}") for c, s in enumerate(sources)]
    numbers = [[file_number(f) for f in fs] for fs in files]
    views, names = [], []
    for group in match_frames(numbers):
        views.append([None if i is None else (files[c][i], files[c][i].name) for c, i in enumerate(group)])
        c = next(c for c, i in enumerate(group) if i is not None)
        names.append(f"{numbers[c][group[c]]:02d}")
    return views, names


def _labelled(calibration, i, board):
    """The used junctions of image i of a camera's calibration as (uv (2, m), W (3, m)):
    each junction's board point is the board junction whose projection through the
    calibration's pose lies nearest (a tenth of the junction spacing at most)."""
    uv = calibration.points[i]
    W_all = board.world_points()
    T = calibration.poses[i]
    pred = calibration.camera.project(T[:3, :3].T @ (W_all - T[:3, 3:4]))
    d = np.hypot(uv[0][:, None] - pred[0][None], uv[1][:, None] - pred[1][None])
    j = np.argmin(d, axis=1)
    spacing = np.min(np.hypot(*np.diff(pred.reshape(2, board.rows, board.cols), axis=2).reshape(2, -1)))
    if np.unique(j).size != j.size or np.any(d[np.arange(j.size), j] > 0.4 * spacing):
        raise InputError(f"{calibration.images[i]}: its junctions do not match the board under the calibration's "
                         "pose (report this: it should not happen)")
    return uv, W_all[:, j]


def _median_pose(Ts):
    """The median of rigid transforms: of the translations, and of the rotation vectors about
    the first rotation."""
    R0 = Ts[0][:3, :3]
    omega = np.median([so3_log(R0.T @ T[:3, :3]) for T in Ts], axis=0)
    out = np.eye(4)
    out[:3, :3] = R0 @ so3_exp(omega)
    out[:3, 3] = np.median([T[:3, 3] for T in Ts], axis=0)
    return out


def _shared(keys, n_cameras) -> dict:
    """{(a, b): the views cameras a and b both saw} over the (view, camera) keys."""
    keys = set(keys)
    out = {}
    for a in range(n_cameras):
        for b in range(n_cameras):
            vs = sorted(v for (v, c) in keys if c == a and (v, b) in keys) if a != b else []
            if vs:
                out[a, b] = vs
    return out


def _unreached(keys, n_cameras) -> list:
    """The cameras no chain of shared views ties to camera 0."""
    shared = _shared(keys, n_cameras)
    seen, todo = {0}, [0]
    while todo:
        a = todo.pop()
        for (x, b) in shared:
            if x == a and b not in seen:
                seen.add(b)
                todo.append(b)
    return [c for c in range(n_cameras) if c not in seen]


def _start_extrinsics(poses, n_cameras, camera_names):
    """T_C0_C from the per-camera poses {(v, c): T_WCc}: medians over shared views, chained
    from camera 0 through the pairs that share most views."""
    shared = _shared(poses, n_cameras)
    T = {0: np.eye(4)}
    while len(T) < n_cameras:
        edges = [(len(vs), a, b) for (a, b), vs in shared.items() if a in T and b not in T]
        if not edges:
            missing = [c for c in range(n_cameras) if c not in T]
            raise InputError(
                f"no view in which {', '.join(camera_names[c] for c in missing)} and camera 0 (or a camera tied to it) "
                "both see the board: the extrinsics are unconstrained. Take images in which the board is seen by "
                "two cameras at once (matched by the number in their names, left07 with right07)")
        _, a, b = max(edges)
        T_ab = _median_pose([relative_pose(poses[v, a], poses[v, b]) for v in shared[a, b]])
        T[b] = T[a] @ T_ab
    return [T[c] for c in range(n_cameras)]


def calibrate_rig(sources=None, model="radtan", *, board: Board = Board(), frames=None, huber_k: float = HUBER_K,
                  rng=None, progress=None) -> RigCalibration:
    """Calibrate a rig of cameras from images of the board taken together.

    Parameters
    ----------
    sources : sequence
        One entry per camera: a list of image files, a folder, or a glob pattern. Images are
        matched across cameras by the number in their file names (``left07.jpg`` with
        ``right07.jpg``); a camera may miss a view.
    model : str or sequence of str
        One model (``"pinhole"``, ``"radtan"``, ``"fisheye"``) for every camera, or one per
        camera (a radtan camera beside a fisheye).
    board : Board
        The board in the images.
    frames : sequence of tuple, optional
        Instead of ``sources``: the views, each a tuple of one image per camera (a file or
        an array; None where that camera has none).
    huber_k : float
        Huber threshold, in sigmas of the pixel noise.
    rng : None
        Deprecated and ignored (a DeprecationWarning when given): the calibration draws
        nothing, it is deterministic. It goes in the next release.
    progress : callable, optional
        Called as ``progress(stage, done, total)``.

    Returns
    -------
    RigCalibration
        ``ok`` False (with ``summary``) when a solver did not converge or the two disagree.

    Raises
    ------
    InputError
        If fewer than two cameras are given, a model is unknown, a camera's calibration fails
        (fewer than three views with the board, images of different sizes: the message names
        the camera), or no view ties a camera to camera 0 (the extrinsics are unconstrained).
    """
    check_board(board)
    huber_k = check_number("huber_k", huber_k, 0.0, strict=True)
    ignored_rng("calibrate_rig", rng=rng)
    views, view_names = _views(sources, frames)
    C, V = len(views[0]), len(views)
    models = [model] * C if isinstance(model, str) else list(model)
    if len(models) != C:
        raise InputError(f"model must be one name or one per camera: {C} cameras, {len(models)} models")
    for m in models:
        model_class(m)
    camera_names = [f"camera {c}" for c in range(C)]
    report = progress or (lambda stage, done, total: None)

    # 2. Each camera alone.
    from .run import calibrate

    calibrations, obs, poses_c, status, message = [], {}, {}, {}, {}
    for c in range(C):
        vs = [v for v in range(V) if views[v][c] is not None]
        if len(vs) < MIN_IMAGES:
            raise InputError(f"{camera_names[c]} has {len(vs)} images; a camera of a rig needs at least {MIN_IMAGES} "
                             "views with the board, as a calibration does")
        try:
            cal = calibrate([views[v][c][0] for v in vs], models[c], board=board, names=[views[v][c][1] for v in vs],
                            huber_k=huber_k,
                            progress=lambda s, d, t, c=c: report(f"camera {c}: {s}", d, t))
        except InputError as exc:
            raise InputError(f"{camera_names[c]}: {exc}") from None
        calibrations.append(cal)
        for k, v in enumerate(vs):
            status[v, c], message[v, c] = cal.status[k], "" if cal.status[k] == "used" else cal.message[k]
            if cal.status[k] == "used":
                obs[v, c] = _labelled(cal, k, board)
                poses_c[v, c] = cal.poses[k]

    # 3. Start.
    Ts = _start_extrinsics(poses_c, C, camera_names)
    cameras = [cal.camera for cal in calibrations]
    poses = {}
    for (v, c), T in sorted(poses_c.items()):
        if v not in poses:
            poses[v] = T @ invert_transform(Ts[c])

    # 4. Solve, reject, solve twice.
    from .rig_graph import solve_rig_graph
    from .rig_lm import solve_rig_lm

    rejected = {}
    start = (cameras, Ts, poses)
    while True:
        keys, active, packed = _pack(obs)
        # The start is each camera's own robust calibration: its residuals (no iterations)
        # set the first Huber threshold; the screening needs the majority's fit, not its
        # last digits (the final solves below converge in full).
        fit = solve_rig_lm(start[0], start[1], [start[2][v] for v in active], packed, max_iterations=0)
        for _ in range(2):
            huber_px = huber_k * mad_sigma(fit.residuals, floor=SIGMA_FLOOR_PX)
            fit = solve_rig_lm(fit.cameras, fit.T_C0_C, fit.poses, packed, huber_px,
                               max_iterations=SCREENING_ITERATIONS, exact_curvature=False)
        rms = np.array([_rms(r) for r in fit.residuals])
        limit = max(REJECT_RATIO * float(np.median(rms)), REJECT_FLOOR_PX)
        order = np.argsort(-rms)
        per_camera = {c: sum(1 for (_, cc) in keys if cc == c) for c in range(C)}
        worst = next((int(k) for k in order if rms[k] > limit and per_camera[keys[k][1]] > MIN_IMAGES), None)
        if worst is None:
            break
        v, c = keys[worst]
        rejected[v, c] = (f"rejected: RMS {rms[worst]:.3f} px in the rig, more than {REJECT_RATIO:g} times the "
                          f"median observation's {np.median(rms):.3f} px (a moved board, an image not taken "
                          "together with the others?)")
        saved = obs.pop((v, c))
        if _unreached(obs, C):
            obs[v, c] = saved  # keep it: without it the rig falls apart
            del rejected[v, c]
            break
        start = (fit.cameras, fit.T_C0_C, {**start[2], **dict(zip(active, fit.poses))})
    keys, active, packed = _pack(obs)
    sigma0 = mad_sigma(fit.residuals, floor=SIGMA_FLOOR_PX)
    report("solve", 1, 2)
    # Both solvers from the screening's fit, each on its own path (as graphpose.calibrate's):
    # they must land on the same parameters.
    graph = solve_rig_graph(fit.cameras, fit.T_C0_C, fit.poses, packed, sigma0, huber_k)
    lm = solve_rig_lm(fit.cameras, fit.T_C0_C, fit.poses, packed, huber_k * sigma0)
    report("solve", 2, 2)
    return _result(view_names, views, keys, active, lm, graph, sigma0, status, message, rejected, calibrations)


def huber_variance_factor(w, r2) -> float:
    """The M-estimator's variance factor of the Huber kernel (Huber 1981, section 7.6):
    ``(sum psi^2 / sum w r^2) / mean(psi')^2`` over the junctions, with ``psi = w r`` and
    ``psi'`` the kernel's slope, 1 inside the threshold and, beyond it, 0 along the residual and
    ``w`` across it (``w / 2`` per coordinate). It is 1 without down-weighted junctions; the
    inverse weighted normal matrix times ``sigma^2`` alone understates the spread of a Huber
    estimate where junctions are down-weighted.

    Parameters
    ----------
    w : (M,) ndarray
        Each junction's Huber weight.
    r2 : (M,) ndarray
        Each junction's squared residual norm, pixels^2.
    """
    wr2 = float(np.sum(w * r2))
    if wr2 <= 0:
        return 1.0
    slope = float(np.mean(np.where(w >= 1.0, 1.0, 0.5 * w)))
    return float(np.sum(w * w * r2) / wr2) / slope ** 2


def _pack(obs):
    """The observations in the solvers' form: keys [(v, c)], the active views, and
    [(view index among the active, c, uv, W)]."""
    keys = sorted(obs)
    active = sorted({v for v, _ in keys})
    at = {v: k for k, v in enumerate(active)}
    return keys, active, [(at[v], c, obs[v, c][0], obs[v, c][1]) for v, c in keys]


def _result(view_names, views, keys, active, lm, graph, sigma0, status, message, rejected, calibrations):
    C, V = len(views[0]), len(views)
    p_lm, p_g = _vector(lm.cameras, lm.T_C0_C), _vector(graph.cameras, graph.T_C0_C)
    r_all = np.hstack(lm.residuals)
    w_all = np.concatenate(lm.weights)
    M = r_all.shape[1]
    dof = 2 * M - p_lm.size - 6 * len(active)
    r2 = np.sum(r_all * r_all, axis=0)
    sigma = float(np.sqrt(np.sum(w_all * r2) / max(dof, 1)))
    factor = huber_variance_factor(w_all, r2)
    cov = graph.cov * (sigma / sigma0) ** 2 * factor
    if not np.all(np.isfinite(cov)):
        cov = lm.cov * sigma ** 2 * factor
    sd = np.sqrt(np.abs(np.diag(cov)))
    difference = float(np.max(np.abs(p_g - p_lm) / np.maximum(np.abs(p_lm), sd)))
    converged = bool(graph.converged and lm.converged)
    ok = bool(converged and difference <= CROSS_CHECK_TOL and np.all(np.isfinite(cov)))
    best = graph if ok else lm
    names = rig_parameter_names(best.cameras)
    starts = np.concatenate([[0], np.cumsum([c.parameters.size for c in best.cameras])]).astype(int)
    cameras = [cam.with_parameters(cam.parameters, cov[starts[c]: starts[c + 1], starts[c]: starts[c + 1]])
               for c, cam in enumerate(best.cameras)]
    rig = Rig(cameras, best.T_C0_C, cov=cov, parameter_names=names)
    solved = dict(zip(keys, lm.residuals))
    rms = np.full((V, C), np.nan)
    st, msg = [], []
    for v in range(V):
        row_s, row_m = [], []
        for c in range(C):
            if views[v][c] is None:
                row_s.append("no image"), row_m.append("")
            elif (v, c) in solved:
                row_s.append("used"), row_m.append("")
                rms[v, c] = _rms(solved[v, c])
            elif (v, c) in rejected:
                row_s.append("rejected"), row_m.append(rejected[v, c])
            else:
                row_s.append(status.get((v, c), "no board")), row_m.append(message.get((v, c), ""))
        st.append(tuple(row_s)), msg.append(tuple(row_m))
    camera_rms = np.array([_rms(np.hstack([r for (v, cc), r in solved.items() if cc == c]) if any(
        cc == c for (_, cc) in solved) else np.zeros((2, 0))) for c in range(C)])
    poses = [None] * V
    for v, T in zip(active, lm.poses):
        poses[v] = T
    used = sum(1 for v in range(V) if any(s == "used" for s in st[v]))
    if ok:
        summary = (f"calibrated a rig of {C} cameras from {used} of {V} views, {M} junctions: RMS {_rms(r_all):.3f} px, "
                   f"the solvers agree to {difference:.1e}")
    elif not converged:
        summary = (f"rig calibration failed: GTSAM {'converged' if graph.converged else 'did not converge'} "
                   f"({graph.message or graph.iterations}), the hand-written LM "
                   f"{'converged' if lm.converged else 'did not converge'} ({lm.message})")
    else:
        summary = (f"rig calibration failed: the two solvers disagree by {difference:.2e} of a parameter "
                   f"(tolerance {CROSS_CHECK_TOL:g})")
    return RigCalibration(
        rig=rig, cov=cov, parameter_names=names, views=tuple(view_names),
        images=tuple(tuple(None if x is None else x[1] for x in row) for row in views),
        status=tuple(st), message=tuple(msg), poses=tuple(poses), view_rms_px=rms, camera_rms_px=camera_rms,
        rms_px=_rms(r_all), sigma_px=sigma, calibrations=tuple(calibrations), ok=ok,
        cross_check=SolverCrossCheck(gtsam=p_g.tolist(), lm=p_lm.tolist(), max_difference=difference,
                                     tolerance=CROSS_CHECK_TOL, gtsam_converged=graph.converged,
                                     lm_converged=lm.converged),
        summary=summary)

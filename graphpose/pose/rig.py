"""The pose of a rig of cameras from every camera's junctions at once.

:func:`graphpose.pipeline_rig.estimate_rig_pose` finds each camera's junctions (through that
camera's lens) and calls :func:`estimate_rig_pose_from_points` here, which solves for camera 0's
pose in the target frame, ``T_WC0``, from every camera's junctions at once: a junction seen by camera c is predicted at
``project_c(T_C0_C[c]^-1 T_WC0^-1 P_W)`` with the rig's cameras and extrinsics held fixed.
A camera that does not see the board (a blank image, or None) gives nothing and the others go
on; at least one must see it.

Two solvers, as for one camera (:mod:`graphpose.estimate`): Gauss-Newton on
``(x, y, z, roll, pitch, yaw)`` with the analytic Jacobian (:func:`rig_points`), then GTSAM's
Levenberg-Marquardt over one ``Pose3`` with one custom factor per camera, started from
Gauss-Newton's answer; they must agree to
:data:`~graphpose.pose.cross_check.AGREE_TRANSLATION_M` and
:data:`~graphpose.pose.cross_check.AGREE_ROTATION_DEG`. The start is the homography pose of the
camera that sees most junctions, carried to camera 0.

Each camera is weighed by its own pixel noise (:func:`camera_noise`, from its residuals):
Gauss-Newton with every camera alike first, then twice with each camera's rows divided by its
noise (relative to the pooled noise, so that the residuals stay in pixels); the cameras of a
rig need not see the board equally sharply (a fisheye's junctions, on smaller squares, are
noisier than a radtan camera's beside it), and the maximum-likelihood pose weighs each by
its own noise. The covariance is ``(J^T W J)^-1`` with ``W`` each junction's ``w /
sigma_c^2`` (Huber weight, its camera's noise), the noises scaled together so that the
weighted residuals' ``sum / (2M - 6)`` is one (GTSAM's marginal with those sigmas is the same
to the cross-check's precision); with one camera it is ``sigma^2 (J^T W J)^-1``, ``sigma``
from the residuals. The rig's own calibration is taken as exact.

A board whose pattern is unchanged by a half turn may be labelled from opposite corners in
two cameras (each camera names junction 0 by the image's upper left): a camera whose pose
disagrees with the first camera's by the half turn is relabelled, and ``message`` says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..board import Board, check_board
from ..errors import BoardNotFoundError, InputError
from ..geometry import T_from_params, hat, hats, invert_transform, params_from_T, pose_difference, rot_x, rot_y, rot_z
from .cross_check import AGREE_ROTATION_DEG, AGREE_TRANSLATION_M, CrossCheck
from .gauss_newton import stacked_huber_weights
from ..robust import HUBER_K, mad_sigma
from .graph import params_cov_from_tangent
from .._deprecated import renamed

_E = np.eye(3)
MAX_ITERATIONS = 50
#: Gauss-Newton stops when every step is below this many of its parameter's sigma.
STEP_SIGMAS = 1e-10


@dataclass(frozen=True)
class RigPoseEstimate:
    """The rig's pose (camera 0's) with its uncertainty.

    Attributes
    ----------
    T_WC : (4, 4) ndarray
        Camera 0's pose in the target frame (Gauss-Newton's solution), also when camera 0
        did not see the board.
    params : (6,) ndarray
        ``(x, y, z, roll, pitch, yaw)``, metres and radians.
    cov : (6, 6) ndarray
        Covariance of ``params`` from the pixel noise (m, rad).
    sigma_xyz_m, sigma_rpy_rad : (3,) ndarray
        1-sigmas from ``cov``.
    sigma_px : float
        The pixel noise of every junction used, pooled: ``sqrt(sum w r^2 / (2M - 6))``.
    camera_sigma_px : tuple of float
        Per camera the pixel noise its junctions were weighed by in the pose and ``cov``
        (from its own residuals), NaN where it saw no board.
    converged : bool
    iterations : int
    rms_px : float
        RMS over every junction used, pixels.
    junctions : tuple
        Per camera its :class:`~graphpose.detect.junctions.Junctions`, None where it saw no
        board.
    residuals : tuple
        Per camera measured minus predicted pixels (2, m) of its trusted junctions (empty
        where none).
    status : tuple of str
        Per camera ``"used"`` or ``"no board"`` (``messages`` says why).
    messages : tuple of str
    cross_check : CrossCheck
        Gauss-Newton against GTSAM.
    message : str
        "ok", or what went wrong.
    """

    T_WC: np.ndarray
    params: np.ndarray
    cov: np.ndarray
    sigma_xyz_m: np.ndarray
    sigma_rpy_rad: np.ndarray
    sigma_px: float
    camera_sigma_px: tuple
    converged: bool
    iterations: int
    rms_px: float
    junctions: tuple
    residuals: tuple
    status: tuple
    messages: tuple
    cross_check: CrossCheck
    message: str

    @property
    def ok(self) -> bool:
        """Converged and cross-checked."""
        return self.converged and self.cross_check.agree

    reprojection_rms_px = renamed("reprojection_rms_px", "rms_px")


def rotation_and_partials(rpy):
    """``C = Cz(yaw) Cy(pitch) Cx(roll)`` (3, 3) and ``dC / d(roll, pitch, yaw)`` (3, 3, 3):
    ``C [e_x]``, ``Cz Cy [e_y] Cx``, ``[e_z] C``."""
    Cx, Cy, Cz = rot_x(rpy[0]), rot_y(rpy[1]), rot_z(rpy[2])
    C = Cz @ Cy @ Cx
    return C, np.stack([C @ hat(_E[0]), Cz @ Cy @ hat(_E[1]) @ Cx, hat(_E[2]) @ C])


def rig_points(q, W, T_C0_C=None, e=None):
    """Board points in a rig camera's frame and their derivatives.

    Parameters
    ----------
    q : (6,) ndarray
        ``T_WC0`` as ``(x, y, z, roll, pitch, yaw)``.
    W : (3, m) ndarray
        Board points, metres.
    T_C0_C : (4, 4) ndarray, optional
        The camera's pose in camera 0's frame (None: camera 0).
    e : (6,) ndarray, optional
        Instead of ``T_C0_C``, its parameters, whose derivative is then returned too.

    Returns
    -------
    p : (3, m) ndarray
        The points in the camera's frame.
    Jq : (m, 3, 6) ndarray
        ``dp / dq``.
    Je : (m, 3, 6) ndarray or None
        ``dp / de`` (with ``e`` only).
    """
    C, dC = rotation_and_partials(q[3:])
    D = W - q[:3, None]
    p0 = C.T @ D
    m = W.shape[1]
    Jq = np.empty((m, 3, 6))
    Jq[:, :, :3] = -C.T
    for k in range(3):
        Jq[:, :, 3 + k] = (dC[k].T @ D).T
    if e is not None:
        Ce, dCe = rotation_and_partials(e[3:])
        De = p0 - e[:3, None]
        Je = np.empty((m, 3, 6))
        Je[:, :, :3] = -Ce.T
        for k in range(3):
            Je[:, :, 3 + k] = (dCe[k].T @ De).T
        return Ce.T @ De, Ce.T @ Jq, Je
    if T_C0_C is None:
        return p0, Jq, None
    R, t = T_C0_C[:3, :3], T_C0_C[:3, 3]
    return R.T @ (p0 - t[:, None]), R.T @ Jq, None


def huber(r, jacobians, k):
    """Each junction's error ``r`` (2, m) and Jacobians [(m, 2, n)] under Huber's kernel of
    threshold ``k``, as one factor per junction would have them: ``e = s r``, ``s = sqrt(2
    rho(a)) / a`` beyond ``k`` (``a = ||r||``), so that ``||e||^2 / 2 = rho(a)``."""
    a = np.hypot(r[0], r[1])
    far = a > k
    safe = np.where(far, a, 1.0)
    root = np.sqrt(np.where(far, 2.0 * (k * a - 0.5 * k * k), 1.0))
    s = np.where(far, root / safe, 1.0)
    ds = np.where(far, (k * k - k * a) / (safe ** 3 * root), 0.0)
    outer = (r.T[:, :, None] * r.T[:, None, :]) * ds[:, None, None]
    return r * s, [s[:, None, None] * J + outer @ J for J in jacobians]


def _start(rig, obs, board):
    """The homography start of the camera with most junctions, carried to camera 0; the
    observations, relabelled by the half turn where a symmetric board's labels disagree."""
    from .homography import pose_from_homography

    used = [o for o in obs if o is not None]
    best = max(used, key=lambda o: o[1].shape[1])
    c, uv, W = best
    T0 = pose_from_homography(uv, W, rig.cameras[c]) @ invert_transform(rig.T_C0_C[c])
    notes = []
    out = list(obs)
    if _half_turn_symmetric(board):
        turned = _half_turn(board)
        for k, o in enumerate(obs):
            if o is None or o[0] == c:
                continue
            Tk = pose_from_homography(o[1], o[2], rig.cameras[k]) @ invert_transform(rig.T_C0_C[k])
            if pose_difference(Tk, T0)[1] > 90.0:
                out[k] = (k, o[1], turned[:, _indices(board, o[2])])
                notes.append(f"camera {k}'s junctions relabelled by the board's half turn (its labels disagreed "
                             f"with camera {c}'s)")
    return T0, out, notes


def _half_turn_symmetric(board) -> bool:
    """A board whose squares' colours repeat under a half turn (an even number of inner
    junctions in one direction and odd in the other never do)."""
    return (board.cols + board.rows) % 2 == 0


def _indices(board, W):
    s = board.square_m
    return (np.rint(W[1] / s) * board.cols + np.rint(W[0] / s)).astype(int)


def _half_turn(board):
    """The board's points under the half turn: junction j takes junction n-1-j's point."""
    return board.world_points()[:, ::-1]


def _gauss_newton(rig, q, obs, huber_px, scale=None):
    """Gauss-Newton on q = T_WC0's parameters; returns q, residuals, weights, H, converged,
    iterations. ``scale``: per stacked residual, 1 / its camera's pixel noise (the residuals,
    the Jacobian and ``huber_px`` are then in sigmas); None: pixels, every camera alike."""
    it, converged = 0, False
    H = np.full((6, 6), np.nan)
    while it < MAX_ITERATIONS:
        it += 1
        r, J = _linearise(rig, q, obs, scale)
        w = stacked_huber_weights(r, huber_px)
        Jw = J if w is None else J * w[:, None]
        H = Jw.T @ J
        g = Jw.T @ r
        try:
            Hi = np.linalg.inv(H)
        except np.linalg.LinAlgError:
            break
        delta = Hi @ g
        q = q + delta
        if np.all(np.abs(delta) <= STEP_SIGMAS * np.sqrt(np.abs(np.diag(Hi)))) or np.max(np.abs(delta)) < 1e-15:
            converged = True
            break
    r, J = _linearise(rig, q, obs, scale)
    w = stacked_huber_weights(r, huber_px)
    Jw = J if w is None else J * w[:, None]
    return q, r, w, Jw.T @ J, converged, it


def _linearise(rig, q, obs, scale=None):
    rs, Js = [], []
    for c, uv, W in obs:
        p, Jq, _ = rig_points(q, W, rig.T_C0_C[c])
        with np.errstate(divide="ignore", invalid="ignore"):
            pred, G = rig.cameras[c].project_jacobian(p)
        rs.append((uv - pred).T.ravel())
        Js.append((G @ Jq).reshape(-1, 6))
    r, J = np.concatenate(rs), np.vstack(Js)
    return (r, J) if scale is None else (r * scale, J * scale[:, None])


def _positions(obs):
    """Per camera its place among the cameras that saw the board, None where it saw none."""
    out, k = [], 0
    for o in obs:
        out.append(None if o is None else k)
        k += o is not None
    return out


def camera_noise(r, w, counts, robust, floor=1e-12):
    """Each camera's pixel noise from its residuals of a joint fit.

    Parameters
    ----------
    r : (2M,) ndarray
        The stacked residuals, camera after camera, pixels.
    w : (2M,) ndarray or None
        Their Huber weights (None: all one).
    counts : sequence of int
        Each camera's junctions, in order (summing to M).
    robust : bool
        1.4826 x the median absolute residual (outliers do not inflate it), else
        ``sqrt(sum w r^2 / d_c)``: ``d_c = 2 m_c (1 - 6 / 2M)``, the camera's share of the
        ``2M - 6`` degrees of freedom, so that the whitened residuals sum to ``2M - 6``.

    floor : float
        The smallest noise returned, pixels (rendered points fit to almost nothing).

    Returns
    -------
    (n,) ndarray
        Pixels.
    """
    M = sum(counts)
    out, at = [], 0
    for m in counts:
        rc = r[at: at + 2 * m]
        if robust:
            out.append(mad_sigma(rc.reshape(m, 2).T, floor=floor))
        else:
            wc = 1.0 if w is None else w[at: at + 2 * m]
            dof = 2 * m * (1.0 - 6.0 / (2 * M)) if M > 3 else 1.0
            out.append(max(float(np.sqrt(np.sum(wc * rc * rc) / dof)), floor))
        at += 2 * m
    return np.array(out)


def _graph(rig, T_WC0, obs, sigma, huber_k):
    """GTSAM's Levenberg-Marquardt over one Pose3 (``T_WC0``), one custom factor per camera
    (``sigma``: one pixel noise, or one per camera of ``obs``); returns (T, cov in params,
    converged)."""
    import gtsam
    from gtsam.symbol_shorthand import X

    graph = gtsam.NonlinearFactorGraph()
    for (c, uv, W), s in zip(obs, np.broadcast_to(sigma, (len(obs),))):
        graph.add(_camera_factor(rig.cameras[c], rig.T_C0_C[c], uv, W, X(0), float(s), huber_k))
    initial = gtsam.Values()
    initial.insert(X(0), gtsam.Pose3(T_WC0))
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(1e-12)
    params.setAbsoluteErrorTol(1e-16)
    params.setMaxIterations(100)
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    try:
        result = optimizer.optimize()
        for _ in range(20):  # undamped steps polish what LM's cost test cannot see
            delta = graph.linearize(result).optimize()
            result = result.retract(delta)
            if np.max(np.abs(delta.at(X(0)))) < 1e-13:
                break
        T = result.atPose3(X(0)).matrix()
        cov = params_cov_from_tangent(T, gtsam.Marginals(graph, result).marginalCovariance(X(0)))
    except RuntimeError:
        return T_WC0, np.full((6, 6), np.nan), False
    return T, cov, bool(optimizer.iterations() < 100)


def _camera_factor(camera, T_C0_C, uv, W, key, sigma, huber_k):
    import gtsam

    m = uv.shape[1]
    Re, te = T_C0_C[:3, :3], T_C0_C[:3, 3]

    def error(factor, values, jacobians):
        T = values.atPose3(factor.keys()[0])
        R, t = T.rotation().matrix(), T.translation()
        p0 = R.T @ (W - t[:, None])
        dX = np.concatenate([hats(p0), np.broadcast_to(-np.eye(3), (m, 3, 3))], axis=2)
        p = Re.T @ (p0 - te[:, None])
        with np.errstate(divide="ignore", invalid="ignore"):
            pred, G = camera.project_jacobian(p)
        r = (pred - uv) / sigma
        Js = [G @ (Re.T @ dX) / sigma]
        if huber_k is not None:
            r, Js = huber(r, Js, huber_k)
        if jacobians is not None:
            jacobians[0] = np.ascontiguousarray(Js[0].reshape(2 * m, 6))
        return r.T.ravel()

    return gtsam.CustomFactor(gtsam.noiseModel.Unit.Create(2 * m), [key], error)


def estimate_rig_pose_from_points(rig, observations, board, *, robust: bool = False, junctions=None,
                                  messages=None) -> RigPoseEstimate:
    """The rig's pose from each camera's trusted junctions (no extraction).

    Parameters
    ----------
    rig : Rig
    observations : sequence
        Per camera ``(uv (2, m), W (3, m))`` of its trusted junctions, or None where it saw no
        board; at least one not None.
    board : Board
        The board (its half-turn symmetry decides whether labels may be relabelled).
    robust : bool
        A Huber kernel in both solvers.
    junctions, messages : sequence, optional
        Per camera, for the result: its Junctions and why it has none.

    Returns
    -------
    RigPoseEstimate
    """
    obs = [None if o is None else (c, np.asarray(o[0], float), np.asarray(o[1], float))
           for c, o in enumerate(observations)]
    status = ["no board" if o is None else "used" for o in obs]
    messages = list(messages) if messages is not None else ["" if o else "no junctions" for o in obs]
    found = list(junctions) if junctions is not None else [None] * len(obs)
    return _solve(rig, obs, found, status, messages, robust, board)


def _solve(rig, obs, found, status, messages, robust, board):
    T0, obs_all, notes = _start(rig, obs, board)
    used = [o for o in obs_all if o is not None]
    counts = [o[1].shape[1] for o in used]
    q0 = params_from_T(T0)
    # 1. Every camera alike (pixels), from the homography start.
    q, r, w, H, converged, it = _gauss_newton(rig, q0, used, None)
    # 2. Each camera weighed by its own pixel noise (from its residuals of step 1), twice
    # (step 1 spreads a noisier camera's misfit over every camera): a camera whose junctions
    # are noisier (a fisheye's, a blurred image's) counts for less, as the maximum-likelihood
    # pose has it. The weights are relative (1 for a camera as noisy as the junctions pooled),
    # so that the residuals stay in pixels of that pooled noise; the Huber kernel, if any, at
    # HUBER_K of it (in each camera's own sigmas).
    huber_px, scale = None, np.ones(r.size)
    for _ in range(2):
        noise = camera_noise(r / scale, w, counts, robust, floor=1e-6 if robust else 1e-12)
        pooled = float(np.sqrt(np.sum(np.array(counts) * noise ** 2) / sum(counts)))
        relative = pooled / noise  # each camera's weight's square root
        scale = np.repeat(relative, [2 * m for m in counts])
        if robust:
            huber_px = HUBER_K * pooled
        q, r, w, H, converged_w, it_w = _gauss_newton(rig, q, used, huber_px, scale)
        converged, it = converged and converged_w, it + it_w
    M = r.size // 2
    wr2 = r * r if w is None else w * r * r
    sigma_w = float(np.sqrt(np.sum(wr2) / max(2 * M - 6, 1)))  # the pooled noise the weighted fit leaves
    try:
        cov = np.linalg.inv(H) * sigma_w ** 2
    except np.linalg.LinAlgError:
        cov = np.full((6, 6), np.nan)
    noise = sigma_w / relative  # each camera's noise behind cov, pixels
    r = r / scale  # pixels of each camera again
    wr2 = r * r if w is None else w * r * r
    sigma = float(np.sqrt(np.sum(wr2) / max(2 * M - 6, 1)))
    T = T_from_params(q)
    s_w = max(sigma_w, 1e-9)
    T_g, _, g_converged = _graph(rig, T, used, s_w / relative, None if huber_px is None else huber_px / s_w)
    dt, dr = pose_difference(T, T_g)
    agree = bool(converged and g_converged and dt <= AGREE_TRANSLATION_M and dr <= AGREE_ROTATION_DEG)
    residuals, at = [], 0
    for o in obs_all:
        if o is None:
            residuals.append(np.zeros((2, 0)))
            continue
        m = o[1].shape[1]
        residuals.append(r[2 * at: 2 * at + 2 * m].reshape(m, 2).T)
        at += m
    rms = float(np.sqrt(np.mean(np.sum(r.reshape(-1, 2) ** 2, axis=1))))
    message = "ok" if converged and agree else (
        "Gauss-Newton did not converge" if not converged else
        f"the solvers disagree by {dt:.2e} m, {dr:.2e} deg")
    if notes:
        message += "; " + "; ".join(notes)
    sd = np.sqrt(np.abs(np.diag(cov)))
    return RigPoseEstimate(
        T_WC=T, params=q, cov=cov, sigma_xyz_m=sd[:3], sigma_rpy_rad=sd[3:], sigma_px=sigma,
        camera_sigma_px=tuple(float(noise[k]) if k is not None else float("nan") for k in _positions(obs_all)),
        converged=bool(converged), iterations=it, rms_px=rms, junctions=tuple(found),
        residuals=tuple(residuals), status=tuple(status), messages=tuple(messages),
        cross_check=CrossCheck(translation_m=float(dt), rotation_deg=float(dr), agree=agree), message=message)

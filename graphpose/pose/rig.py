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
camera that sees most junctions, carried to camera 0. The covariance is ``sigma^2 (J^T W
J)^-1`` with the pixel noise ``sigma`` from the residuals, ``sqrt(sum w r^2 / (2M - 6))``
(GTSAM's marginal at that sigma is the same to the cross-check's precision); the rig's own
calibration is taken as exact.

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
        The pixel noise behind ``cov``, from the residuals.
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


def _gauss_newton(rig, q, obs, huber_px):
    """Gauss-Newton on q = T_WC0's parameters; returns q, residuals per camera, weights, H,
    converged, iterations."""
    it, converged = 0, False
    H = np.full((6, 6), np.nan)
    while it < MAX_ITERATIONS:
        it += 1
        r, J = _linearise(rig, q, obs)
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
    r, J = _linearise(rig, q, obs)
    w = stacked_huber_weights(r, huber_px)
    Jw = J if w is None else J * w[:, None]
    return q, r, w, Jw.T @ J, converged, it


def _linearise(rig, q, obs):
    rs, Js = [], []
    for c, uv, W in obs:
        p, Jq, _ = rig_points(q, W, rig.T_C0_C[c])
        with np.errstate(divide="ignore", invalid="ignore"):
            pred, G = rig.cameras[c].project_jacobian(p)
        rs.append((uv - pred).T.ravel())
        Js.append((G @ Jq).reshape(-1, 6))
    return np.concatenate(rs), np.vstack(Js)


def _graph(rig, T_WC0, obs, sigma, huber_k):
    """GTSAM's Levenberg-Marquardt over one Pose3 (``T_WC0``), one custom factor per camera;
    returns (T, cov in params, converged)."""
    import gtsam
    from gtsam.symbol_shorthand import X

    graph = gtsam.NonlinearFactorGraph()
    for c, uv, W in obs:
        graph.add(_camera_factor(rig.cameras[c], rig.T_C0_C[c], uv, W, X(0), sigma, huber_k))
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
    q0 = params_from_T(T0)
    q, r, w, H, converged, it = _gauss_newton(rig, q0, used, None)
    huber_px = None
    if robust:
        sigma_r = mad_sigma(r, floor=1e-6)
        huber_px = HUBER_K * sigma_r
        q, r, w, H, converged, it2 = _gauss_newton(rig, q, used, huber_px)
        it += it2
    M = r.size // 2
    wr2 = r * r if w is None else w * r * r
    sigma = float(np.sqrt(np.sum(wr2) / max(2 * M - 6, 1)))
    try:
        cov = np.linalg.inv(H) * sigma ** 2
    except np.linalg.LinAlgError:
        cov = np.full((6, 6), np.nan)
    T = T_from_params(q)
    T_g, _, g_converged = _graph(rig, T, used, max(sigma, 1e-9), None if huber_px is None else huber_px / max(sigma, 1e-9))
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
        converged=bool(converged), iterations=it, rms_px=rms, junctions=tuple(found),
        residuals=tuple(residuals), status=tuple(status), messages=tuple(messages),
        cross_check=CrossCheck(translation_m=float(dt), rotation_deg=float(dr), agree=agree), message=message)

"""A cross-checked camera pose with uncertainty: from an image, or from correspondences.

:func:`estimate_pose` is the one function that knows both steps: the junctions
(:func:`graphpose.detect.junctions.extract_junctions`: the board found, labelled and refined)
and the pose from the trusted ones. The detector knows nothing of poses and the solvers nothing
of images; this module, above both, joins them, and checks its inputs once, at its edge, before
the slow step.

:func:`estimate_pose_from_points`, beside it, runs the pose's chain from 2-D/3-D
correspondences (the image's cross-junctions, for :func:`estimate_pose`): a
start (the caller's guess, or the homography initialiser of :mod:`graphpose.pose.homography`),
Gauss-Newton (:mod:`graphpose.pose.gauss_newton`) and then the GTSAM factor graph
(:mod:`graphpose.pose.graph`), started from Gauss-Newton's answer. The two solvers minimise the
same cost, so GTSAM must stay at that answer: their poses must agree to
:data:`~graphpose.pose.cross_check.AGREE_TRANSLATION_M` and
:data:`~graphpose.pose.cross_check.AGREE_ROTATION_DEG`; the difference is always reported
in :class:`~graphpose.pose.cross_check.CrossCheck`, and a larger one makes ``agree`` False.

The camera is a :mod:`graphpose.camera_models` object (or a pinhole ``K``): with lens distortion the
junctions are found on the raw image and both solvers fit the raw pixels through the lens
model; the homography start works on the undistorted junctions. A partial board (junctions
hidden or off the image are NaN) gives its pose from the trusted junctions alone, at least
six and not all on one line; the covariance then shows the weaker geometry.

A guess far off can lead Gauss-Newton to another local minimum. When a guess is given and
the target is planar, Gauss-Newton is also run from the homography start; if that reaches
a clearly lower cost, the estimate is marked not converged and says so in ``message``
rather than returning the worse pose as if it were right.

A camera that carries the covariance of its intrinsics (a calibration file written by
``graphpose calibrate``) adds that uncertainty to the pose's covariance
(:mod:`graphpose.pose.covariance`); the pixel-noise-only covariance stays in ``cov_pixel``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ._checks import check_transform
from .board import Board, check_board
from .camera_models import as_camera
from .detect import extract_junctions
from .errors import BoardNotFoundError, DegenerateGeometryError, InputError
from .geometry import apply_homography, pose_difference, so3_exp, to_camera  # pose_difference: re-exported, public here too
from .observations import MIN_JUNCTIONS, check_observations
from .pose.covariance import SIGMA_CALIBRATION, SIGMA_PIXEL, pose_cov_with_intrinsics
from .pose.cross_check import AGREE_ROTATION_DEG, AGREE_TRANSLATION_M, CrossCheck, cross_check  # noqa: F401  (re-exported)
from .pose.gauss_newton import GNResult, gauss_newton, huber_weights, reprojection_cost
from .pose.graph import POLISH_STEP, GraphResult, graph_pose
from .robust import HUBER_K, mad_sigma
from .pose.homography import on_target_plane, pose_from_homography
from ._deprecated import renamed

#: A minimum counts as clearly worse when its cost exceeds the other's by this fraction.
_COST_MARGIN = 1e-6
#: A planar target's pose is refused when the pose with the target tilted the other way about
#: the line of sight to it (the second minimum of a small or distant board's weak perspective)
#: fits within this chi-square of it (5 sigma of the residuals' own noise): the view cannot tell
#: the two tilts apart, and the covariance of either describes only its own minimum.
FLIP_CHI2 = 25.0


@dataclasses.dataclass(frozen=True)
class PoseEstimate:
    """A camera pose with its uncertainty and the evidence behind it.

    Attributes
    ----------
    T_WC : (4, 4) ndarray
        Camera pose in the target frame (the Gauss-Newton solution).
    params : (6,) ndarray
        ``(x, y, z, roll, pitch, yaw)``, metres and radians.
    cov : (6, 6) ndarray
        Covariance of ``params`` (m, rad): ``cov_pixel``, plus, when the camera carries the
        covariance of its intrinsics (a calibration's), that covariance carried into the
        pose to first order (:mod:`graphpose.pose.covariance`); ``sigma_kind`` says which.
    sigma_xyz_m : (3,) ndarray
        1-sigma of x, y, z, metres (from ``cov``).
    sigma_rpy_rad : (3,) ndarray
        1-sigma of roll, pitch, yaw, radians (from ``cov``).
    sigma_px : float
        Pixel noise behind ``cov`` (estimated; robustly when ``robust``).
    converged : bool
        Gauss-Newton converged and, when a guess was given, no clearly better minimum was
        found from the homography start.
    iterations : int
        Gauss-Newton iterations.
    rms_px : float
        ``sqrt(mean(du^2 + dv^2))`` over the points used, pixels: OpenCV's definition
        (:func:`graphpose.pose.gauss_newton.reprojection_rms`).
    residuals : (2, n) ndarray
        Measured minus predicted pixels for every point, used or not (see ``mask``); NaN
        where a junction was not measured.
    mask : (n,) ndarray of bool
        The points used (the trusted junctions).
    junctions : Junctions or None
        The extracted junctions; None from :func:`estimate_pose_from_points`.
    cross_check : CrossCheck
        Gauss-Newton against GTSAM.
    start_T_WC : (4, 4) ndarray
        Where Gauss-Newton started (the guess, or the homography pose); GTSAM starts at
        Gauss-Newton's answer, or here when Gauss-Newton did not converge.
    message : str
        "ok", or what went wrong.
    gn : GNResult
        The Gauss-Newton result in full.
    graph : GraphResult
        The GTSAM result in full.
    orientation_ambiguous : bool
        The board's pattern is unchanged by a half (or quarter) turn and no bounds named
        junction 0's corner: junction 0 is then the corner nearest the image's upper left
        (``docs/conventions.md``), and the board turned by the symmetry fits as well (its
        pose differs by that turn about the board's centre). False for estimates from
        points.
    cov_pixel : (6, 6) ndarray
        Covariance of ``params`` from the pixel noise alone: the GTSAM marginals, pixel
        noise estimated from the residuals, the intrinsics taken as exact. The same as
        ``cov`` for a camera without a covariance.
    sigma_kind : str
        What ``cov`` and the sigmas describe: ``"pixel noise"``
        (:data:`~graphpose.pose.covariance.SIGMA_PIXEL`) or ``"pixel noise and
        calibration"`` (:data:`~graphpose.pose.covariance.SIGMA_CALIBRATION`).
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
    residuals: np.ndarray
    mask: np.ndarray
    junctions: object
    cross_check: CrossCheck
    start_T_WC: np.ndarray
    message: str
    gn: GNResult
    graph: GraphResult
    orientation_ambiguous: bool = False
    cov_pixel: np.ndarray | None = None
    sigma_kind: str = SIGMA_PIXEL

    def __post_init__(self):
        if self.cov_pixel is None:  # no calibration covariance: the two are one
            object.__setattr__(self, "cov_pixel", self.cov)

    @property
    def ok(self) -> bool:
        """Converged and cross-checked: the estimate can be used."""
        return self.converged and self.cross_check.agree

    reprojection_rms_px = renamed("reprojection_rms_px", "rms_px")


def estimate_pose_from_points(Ipts, Wpts, camera, *, guess=None, mask=None, robust: bool = False,
                              check: bool = True) -> PoseEstimate:
    """Cross-checked camera pose from 2-D/3-D correspondences (no extraction).

    Parameters
    ----------
    Ipts : (2, n) array_like
        Image points (u, v), pixels; NaN allowed where ``mask`` is False.
    Wpts : (3, n) array_like
        Matching target points, metres (on z = 0 when ``guess`` is None).
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`; raw, distorted pixels), or pinhole
        intrinsics ``K``, pixels.
    guess : (4, 4) array_like, optional
        Starting pose T_WC; the homography initialiser when None.
    mask : (n,) array_like of bool, optional
        Points to use; all by default. At least 4.
    robust : bool
        Use a Huber kernel in both solvers.

    check : bool
        False skips the input checks, for a caller that checked the inputs at its own edge (a
        camera object, float arrays of the right shapes, a boolean mask, a checked guess or
        None): pytransform3d's ``check=False``.

    Returns
    -------
    PoseEstimate
        With ``junctions`` None.

    Raises
    ------
    InputError
        On malformed input, fewer than 4 used points, a guess with used points behind the
        camera, or (without a guess) target points off z = 0 or degenerate.
    """
    if check:
        camera, Ipts, Wpts, mask = check_observations(camera, Ipts, Wpts, mask)
        guess = None if guess is None else check_transform(guess, "guess")
    return _estimate_pose_from_points(camera, Ipts, Wpts, guess, mask, robust)


def fit_pose(Ipts, Wpts, camera, *, guess=None, mask=None, robust: bool = False, check: bool = True):
    """The single-image pose fit: a start, Gauss-Newton and, with ``robust``, the outlier gate.

    The pose path of :func:`estimate_pose` without its GTSAM cross-check, shared with the
    tracker's front end (:mod:`graphpose.track.frontend`): start from ``guess``, or from the
    homography initialiser when None; Gauss-Newton on the used points, until its step is below
    :data:`graphpose.pose.graph.POLISH_STEP` (GTSAM's, 1e-10 m and rad); with ``robust``, the
    pixel sigma estimated robustly (1.4826 x the median absolute residual) and Gauss-Newton
    again from the same start with a Huber kernel at :data:`graphpose.robust.HUBER_K` of
    those sigmas, so that outlying points are down-weighted.

    Parameters
    ----------
    Ipts : (2, n) array_like
        Image points (u, v), pixels; NaN allowed where ``mask`` is False.
    Wpts : (3, n) array_like
        Matching target points, metres (on z = 0 when ``guess`` is None).
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`), or pinhole intrinsics ``K``, pixels.
    guess : (4, 4) array_like, optional
        Starting pose T_WC; the homography initialiser when None.
    mask : (n,) array_like of bool, optional
        Points to use; all by default. At least 4.
    robust : bool
        Down-weight outlying points (Huber kernel at 1.345 robust sigmas).

    check : bool
        False skips the input checks, for a caller that checked the inputs at its own edge (a
        camera object, float arrays of the right shapes, a boolean mask, a checked guess or
        None): pytransform3d's ``check=False``.

    Returns
    -------
    fit : GNResult
        The Gauss-Newton solution (check ``converged``); with ``robust``, its ``sigma_px``
        is the robust pixel sigma the kernel was scaled by.
    start_T_WC : (4, 4) ndarray
        Where it started (the guess, or the homography pose).

    Raises
    ------
    InputError
        As :func:`estimate_pose_from_points`.
    """
    if check:
        camera, Ipts, Wpts, mask = check_observations(camera, Ipts, Wpts, mask)
        guess = None if guess is None else check_transform(guess, "guess")
    return _fit_pose(camera, Ipts, Wpts, guess, mask, robust)


def _fit_pose(camera, Ipts, Wpts, guess, mask, robust):
    """:func:`fit_pose` on checked inputs: the pipeline's core and (through ``check=False``) the
    tracker's front end call it on what they checked or made themselves."""
    start = pose_from_homography(Ipts[:, mask], Wpts[:, mask], camera, check=False) if guess is None else guess
    # Gauss-Newton runs until its step is below GTSAM's (POLISH_STEP): one more compiled
    # iteration where its default (1e-9) would stop, and GTSAM, started at its answer,
    # confirms it in one linearisation instead of two.
    gn = gauss_newton(Ipts, Wpts, camera, guess=start, mask=mask, tol=POLISH_STEP, check=False)
    if robust:
        pixel_sigma = mad_sigma(gn.residuals[:, mask], floor=1e-12)
        gn = gauss_newton(Ipts, Wpts, camera, guess=start, mask=mask, huber_px=HUBER_K * pixel_sigma,
                          pixel_sigma=pixel_sigma, tol=POLISH_STEP, check=False)
    return gn, start


def _estimate_pose_from_points(camera, Ipts, Wpts, guess, mask, robust, start=None) -> PoseEstimate:
    """The core of :func:`estimate_pose_from_points`, on checked inputs: :func:`estimate_pose`
    calls it after its own checks, so nothing is checked twice. ``start`` (without a
    ``guess``) stands for the homography start, where the caller has it already."""
    gn, start = _fit_pose(camera, Ipts, Wpts, guess if start is None else start, mask, robust)
    pixel_sigma = gn.sigma_px if robust else None  # the robust fit's own sigma (fit_pose)
    huber_px = None if pixel_sigma is None else HUBER_K * pixel_sigma
    # GTSAM starts where Gauss-Newton ended (from the shared start if it failed): the same
    # cost, so a converged GN answer must already be GTSAM's minimum. A wrong projection or
    # Jacobian in either solver moves GTSAM off it and fails the cross-check, as a solve
    # from the shared start would; the basin question (a guess far off) is settled by
    # _compare_with_linear_start. It spares GTSAM's own descent: from a converged answer the
    # undamped steps alone confirm it (from_minimum), where they fail GTSAM descends from it.
    graph = graph_pose(Ipts, Wpts, camera, guess=gn.T_WC if gn.converged else start, mask=mask,
                       pixel_sigma=pixel_sigma, robust=robust, from_minimum=gn.converged, check=False)
    converged, message = gn.converged, "ok" if gn.converged else f"Gauss-Newton: {gn.message}"
    if guess is not None and gn.converged and on_target_plane(Wpts):
        converged, message = _compare_with_linear_start(camera, Ipts, Wpts, mask, huber_px, gn)
    if converged and on_target_plane(Wpts):
        converged, message = _compare_with_flip(camera, Ipts, Wpts, mask, huber_px, gn)
    check = cross_check(gn, graph)
    cov, kind = graph.cov, SIGMA_PIXEL
    if getattr(camera, "covariance", None) is not None:
        kind = SIGMA_CALIBRATION
        weights = None if huber_px is None else huber_weights(gn.residuals[:, mask], huber_px)
        try:
            cov = pose_cov_with_intrinsics(camera, gn.T_WC, Wpts[:, mask], graph.cov, weights)
        except (np.linalg.LinAlgError, InputError):  # singular normal equations; a point behind
            cov = np.full((6, 6), np.nan)
    if not check.agree:
        message = ("" if message == "ok" else message + "; ") + (
            f"Gauss-Newton and GTSAM disagree by {check.translation_m:.3g} m and "
            f"{check.rotation_deg:.3g} deg (GN converged: {gn.converged}, GTSAM converged: {graph.converged}"
            + (f": {graph.message}" if graph.message else "") + ")")
    return PoseEstimate(
        T_WC=gn.T_WC,
        params=gn.params,
        cov=cov,
        sigma_xyz_m=np.sqrt(np.diag(cov)[:3]),
        sigma_rpy_rad=np.sqrt(np.diag(cov)[3:]),
        sigma_px=graph.sigma_px,
        converged=converged,
        iterations=gn.iterations,
        rms_px=gn.rms_px,
        residuals=_all_residuals(camera, gn, Ipts, Wpts),
        mask=mask,
        junctions=None,
        cross_check=check,
        start_T_WC=start,
        message=message,
        gn=gn,
        graph=graph,
        cov_pixel=graph.cov,
        sigma_kind=kind,
    )


def _all_residuals(camera, gn, Ipts, Wpts):
    """Measured minus predicted pixels at Gauss-Newton's pose for every point (2, n): its own
    residuals for the points it used, projected here only for the measured points it did not
    use; NaN where a point was not measured."""
    residuals = gn.residuals.copy()
    rest = np.flatnonzero(~gn.mask & np.all(np.isfinite(Ipts), axis=0))
    if rest.size:
        residuals[:, rest] = Ipts[:, rest] - camera.project(to_camera(gn.T_WC, Wpts[:, rest]))
    return residuals


def _compare_with_linear_start(camera, Ipts, Wpts, mask, huber_px, gn):
    """Whether GN from the homography start finds a clearly lower cost than from the guess."""
    try:
        linear = pose_from_homography(Ipts[:, mask], Wpts[:, mask], camera, check=False)
        other = gauss_newton(Ipts, Wpts, camera, guess=linear, mask=mask, huber_px=huber_px, check=False)
    except (InputError, DegenerateGeometryError):
        return True, "ok"  # no usable homography start: nothing to compare with
    mine = reprojection_cost(gn.residuals[:, mask], huber_px)
    theirs = reprojection_cost(other.residuals[:, mask], huber_px)
    dt, dr = pose_difference(gn.T_WC, other.T_WC)
    elsewhere = dt > AGREE_TRANSLATION_M or dr > AGREE_ROTATION_DEG  # not the same minimum
    if other.converged and elsewhere and theirs < mine * (1 - _COST_MARGIN):
        return False, (
            f"Gauss-Newton from the guess stopped in a local minimum (cost {mine:.6g}) "
            f"{dt:.3g} m and {dr:.3g} deg from a better one (cost {theirs:.6g}) found from "
            f"the homography start: the guess is too far off; retry with guess=None")
    return True, "ok"


def _compare_with_flip(camera, Ipts, Wpts, mask, huber_px, gn):
    """Whether the pose with the target tilted the other way (:func:`_flipped`) fits clearly
    worse (:data:`FLIP_CHI2`) once Gauss-Newton has refined it; (ok, message)."""
    start = _flipped(gn.T_WC, Wpts[:, mask])
    if start is None:
        return True, "ok"  # seen face-on: the two tilts are one
    try:
        other = gauss_newton(Ipts, Wpts, camera, guess=start, mask=mask, huber_px=huber_px, check=False)
    except (InputError, DegenerateGeometryError):
        return True, "ok"  # the other tilt puts points behind the camera
    if not other.converged:
        return True, "ok"
    mine = reprojection_cost(gn.residuals[:, mask], huber_px)
    theirs = reprojection_cost(other.residuals[:, mask], huber_px)
    dof = 2 * int(mask.sum()) - 6
    dt, dr = pose_difference(gn.T_WC, other.T_WC)
    if dof <= 0 or (dt <= AGREE_TRANSLATION_M and dr <= AGREE_ROTATION_DEG):
        return True, "ok"
    chi2 = (theirs - mine) / max(mine / dof, 1e-300)  # in the residuals' own variance
    if chi2 < FLIP_CHI2:
        return False, (
            f"the board's tilt is ambiguous: a pose {dr:.3g} deg and {dt:.3g} m away, the board tilted the "
            f"other way, fits the {int(mask.sum())} junctions almost as well (chi-square {chi2:.3g} more, "
            f"need {FLIP_CHI2:g}); show more of the board, or from nearer")
    return True, "ok"


def _flipped(T_WC, Wpts):
    """The pose (4, 4) with the target plane's normal reflected about the line of sight to the
    centre of the points ``Wpts`` (3, n) (turned about that centre), or None when the target is
    seen face-on there."""
    C = T_WC[:3, :3]
    centre = to_camera(T_WC, Wpts.mean(axis=1, keepdims=True))[:, 0]
    sight = centre / np.linalg.norm(centre)
    normal = C.T[:, 2]  # the target's z axis in the camera frame
    other = 2.0 * (normal @ sight) * sight - normal
    axis = np.cross(normal, other)
    sin = float(np.linalg.norm(axis))
    if sin < 1e-9:
        return None
    turn = so3_exp(axis / sin * np.arctan2(sin, float(normal @ other)))  # normal onto other
    R_CW = turn @ C.T
    t_CW = turn @ (-C.T @ T_WC[:3, 3] - centre) + centre
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R_CW.T, -R_CW.T @ t_CW
    return T


def estimate_pose(image, camera, *, board: Board = Board(), bounds=None, guess=None,
                  robust: bool = False) -> PoseEstimate:
    """Camera pose from an image of the checkerboard.

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) array_like
        The image as the camera took it (see :func:`graphpose.image.as_grey`): raw, with the
        lens distortion ``camera`` describes.
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`, e.g. from
        :func:`graphpose.io.cameras.read_camera`), or pinhole intrinsics ``K``, pixels,
        for an image without distortion.
    board : Board
        The target.
    bounds : (2, 4) array_like, optional
        Bounding polygon of the board, pixels, clockwise from the corner nearest junction 0
        (see :func:`graphpose.detect.junctions.extract_junctions`): it only narrows the
        search and names junction 0's corner. None searches the whole image.
    guess : (4, 4) array_like, optional
        Starting pose T_WC; the homography initialiser when None.
    robust : bool
        Use a Huber kernel (threshold 1.345 robust sigmas) in both solvers.

    Returns
    -------
    PoseEstimate
        Check ``ok`` (or ``converged`` and ``cross_check.agree``) before using the pose, and
        ``orientation_ambiguous`` for a symmetric board found without bounds.

    Raises
    ------
    InputError
        On a malformed image, polygon, camera or guess, an image of another size than the
        camera's calibration (:func:`graphpose.camera_models.check_image_size`), or a guess with
        junctions behind the camera.
    BoardNotFoundError
        If the junction grid is not found, or fewer than six junctions not all on one line
        are trusted.
    """
    # The camera and the guess are checked before the extraction, so bad ones fail before
    # the slow step.
    camera = as_camera(camera)
    board = check_board(board)
    guess = None if guess is None else check_transform(guess, "guess")
    junctions = extract_junctions(image, bounds=bounds, board=board, camera=camera)
    _check_geometry(junctions.trusted, board)
    # Unseen junctions are NaN and untrusted: the solvers use the trusted ones only.
    start = None if guess is not None else _start_through_lens(junctions, board, camera)
    estimate = _estimate_pose_from_points(camera, junctions.points, board.world_points(), guess, junctions.trusted,
                                          robust, start)
    return dataclasses.replace(estimate, junctions=junctions,
                               orientation_ambiguous=bool(junctions.orientation_ambiguous))


def _start_through_lens(junctions, board, camera):
    """For a camera with lens distortion, the homography start (:func:`pose_from_homography`)
    from the junctions' own grid homography, which maps the board's grid to the lens's
    distortion-free pixels (:attr:`graphpose.detect.Junctions.homography`, fitted to the
    trusted junctions' undistorted positions as their fits gave them, before the blur's shift
    of a few thousandths of a pixel is taken off, :mod:`graphpose.detect.blur_shift`): the
    start, without inverting the lens at every junction again; the fit from it ends at the same
    minimum. None for a pinhole (its start is cheap) or where
    that homography gives no start (then the usual one is tried, and reports why)."""
    if not np.any(camera.distortion):
        return None
    trusted = junctions.trusted
    flat = apply_homography(junctions.homography, board.grid_indices()[:, trusted].astype(float))
    try:
        return pose_from_homography(flat, board.world_points()[:, trusted], as_camera(camera.K), check=False)
    except (InputError, DegenerateGeometryError):
        return None


def _check_geometry(trusted, board) -> None:
    """Refuse fewer than :data:`graphpose.observations.MIN_JUNCTIONS` trusted junctions, or ones all on one line."""
    m = int(np.count_nonzero(trusted))
    if m < MIN_JUNCTIONS:
        raise BoardNotFoundError(f"only {m} junctions are trusted; a pose needs {MIN_JUNCTIONS}, not all on one line")
    grid = board.grid_indices()[:, trusted].astype(float)
    grid -= grid.mean(axis=1, keepdims=True)
    if np.linalg.matrix_rank(grid) < 2:
        raise BoardNotFoundError(
            f"the {m} trusted junctions all lie on one line of the board; a pose needs junctions "
            "off that line (more of the board in view)")

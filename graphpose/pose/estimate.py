"""From correspondences to a cross-checked camera pose with uncertainty.

:func:`estimate_pose_from_points` runs the chain from 2-D/3-D correspondences (the image's
cross-junctions, for :func:`graphpose.pipeline.estimate_pose`): a
start (the caller's guess, or the homography initialiser of :mod:`graphpose.pose.homography`),
Gauss-Newton (:mod:`graphpose.pose.gauss_newton`) and then the GTSAM factor graph
(:mod:`graphpose.pose.graph`), started from Gauss-Newton's answer. The two solvers minimise the
same cost, so GTSAM must stay at that answer: their poses must agree to
:data:`AGREE_TRANSLATION_M` and :data:`AGREE_ROTATION_DEG`; the difference is always reported
in :class:`CrossCheck`, and a larger one makes ``agree`` False.

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
(:mod:`graphpose.pose.intrinsics`); the pixel-noise-only covariance stays in ``cov_pixel``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import check_transform
from ..errors import DegenerateGeometryError, InputError
from ..geometry import pose_difference, to_camera  # pose_difference: re-exported, public here too
from ..observations import check_observations
from .gauss_newton import GNResult, gauss_newton_unchecked, huber_weights, reprojection_cost
from .graph import HUBER_K, GraphResult, graph_pose_unchecked
from .homography import on_target_plane, pose_from_homography_unchecked
from .intrinsics import SIGMA_CALIBRATION, SIGMA_PIXEL, pose_cov_with_intrinsics

#: GN and the graph must agree this closely (metres, degrees): the same cost, two solvers.
AGREE_TRANSLATION_M = 1e-6
AGREE_ROTATION_DEG = 1e-5
#: A minimum counts as clearly worse when its cost exceeds the other's by this fraction.
_COST_MARGIN = 1e-6
#: A planar target's pose is refused when the pose with the target tilted the other way about
#: the line of sight to it (the second minimum of a small or distant board's weak perspective)
#: fits within this chi-square of it (5 sigma of the residuals' own noise): the view cannot tell
#: the two tilts apart, and the covariance of either describes only its own minimum.
FLIP_CHI2 = 25.0


@dataclass(frozen=True)
class CrossCheck:
    """Difference between the Gauss-Newton and the GTSAM poses.

    Attributes
    ----------
    translation_m : float
        Distance between the two camera positions, metres.
    rotation_deg : float
        Angle of the relative rotation, degrees.
    agree : bool
        Both solvers converged and the differences are within :data:`AGREE_TRANSLATION_M`
        and :data:`AGREE_ROTATION_DEG`.
    """

    translation_m: float
    rotation_deg: float
    agree: bool


@dataclass(frozen=True)
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
        pose to first order (:mod:`graphpose.pose.intrinsics`); ``sigma_kind`` says which.
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
    reprojection_rms_px : float
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
        (:data:`~graphpose.pose.intrinsics.SIGMA_PIXEL`) or ``"pixel noise and
        calibration"`` (:data:`~graphpose.pose.intrinsics.SIGMA_CALIBRATION`).
    """

    T_WC: np.ndarray
    params: np.ndarray
    cov: np.ndarray
    sigma_xyz_m: np.ndarray
    sigma_rpy_rad: np.ndarray
    sigma_px: float
    converged: bool
    iterations: int
    reprojection_rms_px: float
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


def estimate_pose_from_points(camera, Ipts, Wpts, guess=None, mask=None, *, robust: bool = False) -> PoseEstimate:
    """Cross-checked camera pose from 2-D/3-D correspondences (no extraction).

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`; raw, distorted pixels), or pinhole
        intrinsics ``K``, pixels.
    Ipts : (2, n) array_like
        Image points (u, v), pixels; NaN allowed where ``mask`` is False.
    Wpts : (3, n) array_like
        Matching target points, metres (on z = 0 when ``guess`` is None).
    guess : (4, 4) array_like, optional
        Starting pose T_WC; the homography initialiser when None.
    mask : (n,) array_like of bool, optional
        Points to use; all by default. At least 4.
    robust : bool
        Use a Huber kernel in both solvers.

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
    camera, Ipts, Wpts, mask = check_observations(camera, Ipts, Wpts, mask)
    guess = None if guess is None else check_transform(guess, "guess")
    return estimate_pose_unchecked(camera, Ipts, Wpts, guess, mask, robust)


def fit_pose(camera, Ipts, Wpts, guess=None, mask=None, *, robust: bool = False):
    """The single-image pose fit: a start, Gauss-Newton and, with ``robust``, the outlier gate.

    The pose path of :func:`estimate_pose` without its GTSAM cross-check, shared with the
    tracker's front end (:mod:`graphpose.track.frontend`): start from ``guess``, or from the
    homography initialiser when None; Gauss-Newton on the used points; with ``robust``, the
    pixel sigma estimated robustly (1.4826 x the median absolute residual) and Gauss-Newton
    again from the same start with a Huber kernel at :data:`graphpose.pose.graph.HUBER_K` of
    those sigmas, so that outlying points are down-weighted.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        The camera model (:mod:`graphpose.camera_models`), or pinhole intrinsics ``K``, pixels.
    Ipts : (2, n) array_like
        Image points (u, v), pixels; NaN allowed where ``mask`` is False.
    Wpts : (3, n) array_like
        Matching target points, metres (on z = 0 when ``guess`` is None).
    guess : (4, 4) array_like, optional
        Starting pose T_WC; the homography initialiser when None.
    mask : (n,) array_like of bool, optional
        Points to use; all by default. At least 4.
    robust : bool
        Down-weight outlying points (Huber kernel at 1.345 robust sigmas).

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
    camera, Ipts, Wpts, mask = check_observations(camera, Ipts, Wpts, mask)
    guess = None if guess is None else check_transform(guess, "guess")
    return fit_pose_unchecked(camera, Ipts, Wpts, guess, mask, robust)


def fit_pose_unchecked(camera, Ipts, Wpts, guess, mask, robust):
    """:func:`fit_pose` on inputs already checked at a public edge (a camera object, float
    arrays of the right shapes, a boolean mask, a checked guess or None): the pipeline's core
    and the tracker's front end call it on what they checked or made themselves."""
    start = pose_from_homography_unchecked(camera, Ipts[:, mask], Wpts[:, mask]) if guess is None else guess
    gn = gauss_newton_unchecked(camera, start, Ipts, Wpts, mask)
    if robust:
        pixel_sigma = max(1.4826 * float(np.nanmedian(np.abs(gn.residuals[:, mask]))), 1e-12)
        gn = gauss_newton_unchecked(camera, start, Ipts, Wpts, mask, huber_px=HUBER_K * pixel_sigma,
                                    pixel_sigma=pixel_sigma)
    return gn, start


def estimate_pose_unchecked(camera, Ipts, Wpts, guess, mask, robust) -> PoseEstimate:
    """The core of :func:`estimate_pose_from_points`, on inputs already checked at a public edge
    (a camera object, float arrays of the right shapes, a boolean mask, a checked guess or None):
    the pipeline calls it after its own checks, so nothing is checked twice."""
    gn, start = fit_pose_unchecked(camera, Ipts, Wpts, guess, mask, robust)
    pixel_sigma = gn.sigma_px if robust else None  # the robust fit's own sigma (fit_pose)
    huber_px = None if pixel_sigma is None else HUBER_K * pixel_sigma
    # GTSAM starts where Gauss-Newton ended (from the shared start if it failed): the same
    # cost, so a converged GN answer must already be GTSAM's minimum. A wrong projection or
    # Jacobian in either solver moves GTSAM off it and fails the cross-check, as a solve
    # from the shared start would; the basin question (a guess far off) is settled by
    # _compare_with_linear_start. It spares GTSAM's own descent: from a converged answer the
    # undamped steps alone confirm it (from_minimum), where they fail GTSAM descends from it.
    graph = graph_pose_unchecked(camera, gn.T_WC if gn.converged else start, Ipts, Wpts, mask,
                                 pixel_sigma=pixel_sigma, robust=robust, from_minimum=gn.converged)
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
        reprojection_rms_px=gn.residual_rms_px,
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
        linear = pose_from_homography_unchecked(camera, Ipts[:, mask], Wpts[:, mask])
        other = gauss_newton_unchecked(camera, linear, Ipts, Wpts, mask, huber_px=huber_px)
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
        other = gauss_newton_unchecked(camera, start, Ipts, Wpts, mask, huber_px=huber_px)
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
    sin, cos = float(np.linalg.norm(axis)), float(normal @ other)
    if sin < 1e-9:
        return None
    k = axis / sin
    Kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    turn = np.eye(3) + sin * Kx + (1.0 - cos) * (Kx @ Kx)  # Rodrigues: normal onto other
    R_CW = turn @ C.T
    t_CW = turn @ (-C.T @ T_WC[:3, 3] - centre) + centre
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R_CW.T, -R_CW.T @ t_CW
    return T


def cross_check(gn: GNResult, graph: GraphResult) -> CrossCheck:
    """Compare the Gauss-Newton and GTSAM poses.

    Parameters
    ----------
    gn : GNResult
        The Gauss-Newton solution.
    graph : GraphResult
        The GTSAM solution (started at Gauss-Newton's answer in :func:`estimate_pose`).

    Returns
    -------
    CrossCheck
        Their difference; ``agree`` needs both converged and the difference within
        :data:`AGREE_TRANSLATION_M` and :data:`AGREE_ROTATION_DEG`.
    """
    dt, dr = pose_difference(gn.T_WC, graph.T_WC)
    agree = gn.converged and graph.converged and dt <= AGREE_TRANSLATION_M and dr <= AGREE_ROTATION_DEG
    return CrossCheck(translation_m=dt, rotation_deg=dr, agree=bool(agree))

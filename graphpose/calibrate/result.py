"""What a calibration returns: :class:`Calibration`, and where over the image it holds.

Two uncertainty figures. :meth:`Calibration.projection_uncertainty` (and its map,
:meth:`Calibration.projection_uncertainty_map`) is mrcal's: the camera frame tied to the
board poses the calibration saw, evaluated at a distance or at infinity
(:mod:`graphpose.calibrate.uncertainty`); it is the one that says where over the image the
calibration projects well. :meth:`Calibration.uncertainty_map` is the intrinsics' alone,
what a pose estimated later through this camera inherits (the camera file's covariance): for the ray ``q`` that the calibrated camera
sees at pixel ``(u, v)``, the pixel covariance of projecting ``q`` under the intrinsics'
uncertainty is ``Sigma_uv = J cov J^T`` with ``J = d uv / d p`` at ``q``
(the camera's ``parameter_jacobian``), and the map is the
1-sigma along the worst direction, ``sqrt(largest eigenvalue of Sigma_uv)``, pixels. In the
camera's own frame a ray projects to the same pixel at every distance, so this plain form
does not depend on the distance; mrcal's full form also carries the uncertainty of the camera
frame (through the board poses), which makes near points differ from far ones:
:meth:`Calibration.projection_uncertainty`. Where no junction was seen the map grows with the extrapolation of the
lens model (the corners of a radial-tangential camera, say): the map says so, and
:meth:`Calibration.coverage` shows where junctions were.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from .._checks import check_number

#: Per-image statuses.
STATUSES = ("used", "rejected", "no board", "unreadable")


def sag_mm(warp_m, warp_cov) -> tuple:
    """The sag at the board's centre, ``w_x + w_y``, and its 1-sigma, millimetres, from the
    board warp (2,) and its covariance (2, 2) (metres)."""
    w = np.asarray(warp_m, dtype=float)
    C = np.asarray(warp_cov, dtype=float)
    return 1000.0 * float(w[0] + w[1]), 1000.0 * float(np.sqrt(max(np.sum(C), 0.0)))


@dataclass(frozen=True)
class SolverCrossCheck:
    """GTSAM's calibration against the hand-written Levenberg-Marquardt's, over the same cost.

    Attributes
    ----------
    gtsam, lm : list of float
        The two solvers' parameters (the calibration's ``parameter_names`` order).
    max_difference : float
        The largest ``|p_gtsam - p_lm| / max(|p|, sigma_p)`` over the parameters.
    tolerance : float
        The bound ``max_difference`` must meet (1e-6).
    gtsam_converged, lm_converged : bool
        Whether each solver converged.
    """

    gtsam: list
    lm: list
    max_difference: float
    tolerance: float
    gtsam_converged: bool
    lm_converged: bool

    def __getitem__(self, key):
        """Deprecated: the mapping this used to be (``check["max_difference"]``, ...)."""
        warnings.warn(f"cross_check[{key!r}] is deprecated: cross_check is a SolverCrossCheck, use its "
                      "attributes", DeprecationWarning, stacklevel=2)
        old = {"gtsam": self.gtsam, "lm": self.lm, "max_difference": self.max_difference,
               "tolerance": self.tolerance, "converged": {"gtsam": self.gtsam_converged, "lm": self.lm_converged}}
        return old[key]


@dataclass(frozen=True)
class Calibration:
    """A camera calibrated from images of the board.

    Attributes
    ----------
    camera : Camera
        The calibrated camera (:mod:`graphpose.camera_models`), its ``size`` the images', carrying
        ``covariance`` (= ``cov``).
    cov : (P, P) ndarray
        Covariance of the intrinsic parameters, in ``parameter_names`` order (pixels,
        unitless): the intrinsics' block of ``joint_cov``.
    parameter_names : tuple of str
        The camera model's own ``parameter_names``.
    images : tuple of str
        The images' names (file names, or ``image 0``, ``image 1``, ...).
    status : tuple of str
        Per image: ``"used"``, ``"rejected"`` (its residuals do not fit the others': see
        ``message``), ``"no board"`` or ``"unreadable"`` (a file that could not be read: the
        others go on).
    message : tuple of str
        Per image: in which pass its board was found, why it was rejected, why no board
        was found, or why the file could not be read.
    poses : tuple
        Per image ``T_WC`` (4, 4) (the camera in the board's frame) for used images, None
        for the others.
    image_rms_px : (n_images,) ndarray
        Per image ``sqrt(mean(du^2 + dv^2))`` over its junctions, pixels (a rejected image's
        against the calibration; NaN where there is no board).
    points : tuple
        Per image the junctions (2, m) it contributed (raw pixels; empty for no board).
    residuals : tuple
        Per image measured minus predicted pixels (2, m) of those junctions.
    rms_px : float
        ``sqrt(mean(du^2 + dv^2))`` over every junction used (OpenCV's definition), pixels.
    sigma_px : float
        The junctions' pixel noise per coordinate, ``sqrt(sum r^2 / (2M - P - 6n))`` over the
        used junctions (for the report: ``cov`` carries the noise through the residuals
        themselves).
    ok : bool
        True when both solvers converged and agree (``cross_check``).
    cross_check : SolverCrossCheck
        The two solvers' parameters, their largest difference, its tolerance (1e-6) and
        whether each converged.
    summary : str
        One line: what was found, or why the calibration failed.
    joint_cov : (P + 6 n, P + 6 n) ndarray or None
        The joint covariance of the intrinsics and the n used views' poses (each ``(x, y, z,
        roll, pitch, yaw)`` of ``T_WC``, in the order of the used images): the Huber
        estimate's covariance by the sandwich rule
        (:func:`graphpose.calibrate.uncertainty.huber_covariance`), what
        :meth:`projection_uncertainty` propagates.
    detections : tuple
        Per image None (no board) or ``(uv (2, m), index (m,))``: every junction the
        detector gave (outliers included), with its board number; what ``--corners-out``
        writes.
    outliers : tuple
        Per image the board indices (``Board.world_points`` columns) of the junctions left out
        as single outliers (:data:`graphpose.calibrate.run.OUTLIER_SIGMAS`), (k,) int; empty
        for an image without any and for images not used. ``message`` names them too.
    board_distance_m : float
        The median distance from the camera to the board's centre over the used views,
        metres (the default distance of :meth:`projection_uncertainty_map`).
    warp_m : (2,) ndarray or None
        The board warp ``(w_x, w_y)`` estimated with the camera, metres: mrcal's
        two-parameter board deflection (:meth:`graphpose.board.Board.warp_basis`; the
        board's points move by ``w_x (1 - d_x^2) + w_y (1 - d_y^2)`` along its z). None
        where the board was taken as flat (``warp=False``, or ``"auto"`` where the views
        did not constrain it or disagreed on it).
    warp_cov : (2, 2) ndarray or None
        Its covariance (the Huber estimate's, as ``cov``), metres squared.
    warp_note : str or None
        Why ``warp="auto"`` took the board as flat: the views do not constrain its bending, or
        disagree on it (with the chi-square); None where the warp was kept or not asked for.
    """

    camera: object
    cov: np.ndarray
    parameter_names: tuple
    images: tuple
    status: tuple
    message: tuple
    poses: tuple
    image_rms_px: np.ndarray
    points: tuple
    residuals: tuple
    rms_px: float
    sigma_px: float
    ok: bool
    cross_check: SolverCrossCheck
    summary: str
    joint_cov: np.ndarray | None = None
    outliers: tuple = ()
    detections: tuple = ()
    board_distance_m: float = float("nan")
    warp_m: np.ndarray | None = None
    warp_cov: np.ndarray | None = None
    warp_note: str | None = None

    @property
    def sag_mm(self):
        """The board's sag at its centre against its corners, ``w_x + w_y``, millimetres
        (None for a flat board): positive along the board's z (away from a camera that sees
        its front)."""
        return None if self.warp_m is None else sag_mm(self.warp_m, self.warp_cov)[0]

    @property
    def sag_sigma_mm(self):
        """The sag's 1-sigma, millimetres (None for a flat board)."""
        return None if self.warp_m is None else sag_mm(self.warp_m, self.warp_cov)[1]

    @property
    def parameters(self) -> np.ndarray:
        """The intrinsic parameters, (P,), in ``parameter_names`` order."""

        return self.camera.parameters

    @property
    def sigmas(self) -> np.ndarray:
        """1-sigma of each parameter, (P,)."""
        return np.sqrt(np.diag(self.cov))

    def _grid(self, step):
        step = check_number("step (pixels)", step, 1.0)
        width, height = self.camera.size
        us = np.arange(0.0, width, step)
        vs = np.arange(0.0, height, step)
        return us, vs

    def uncertainty_map(self, step: float = 16.0):
        """The 1-sigma pixel uncertainty of projecting each pixel's ray, over the image.

        Parameters
        ----------
        step : float
            Grid spacing, pixels (>= 1); the grid starts at pixel (0, 0).

        Returns
        -------
        us : (W',) ndarray
            The grid's columns u, pixels.
        vs : (H',) ndarray
            The grid's rows v, pixels.
        sigma : (H', W') ndarray
            ``sqrt(largest eigenvalue of J cov J^T)`` at each grid pixel, pixels: the plain
            form of mrcal's projection uncertainty, from ``cov`` alone (see the module
            docstring; independent of the distance); NaN where the camera has no ray.
        """
        us, vs = self._grid(step)
        u, v = np.meshgrid(us, vs)
        rays = self.camera.unproject(np.stack([u.ravel(), v.ravel()]))
        good = np.all(np.isfinite(rays), axis=0)
        out = np.full(u.size, np.nan)
        if good.any():
            J = self.camera.parameter_jacobian(rays[:, good])
            S = J @ self.cov @ J.transpose(0, 2, 1)  # (N, 2, 2)
            tr, det = S[:, 0, 0] + S[:, 1, 1], S[:, 0, 0] * S[:, 1, 1] - S[:, 0, 1] * S[:, 1, 0]
            out[good] = np.sqrt(np.maximum(0.5 * tr + np.sqrt(np.maximum(0.25 * tr * tr - det, 0.0)), 0.0))
        return us, vs, out.reshape(u.shape)

    def projection_uncertainty(self, points_px, distance_m=None):
        """mrcal's projection uncertainty at pixels: the camera frame tied to the boards.

        Parameters
        ----------
        points_px : (2, N) array_like
            Pixels (u, v).
        distance_m : float, optional
            Distance along each pixel's ray, metres; None (default): at infinity.

        Returns
        -------
        graphpose.calibrate.uncertainty.ProjectionUncertainty
            ``cov`` (N, 2, 2) pixels squared and ``sigma_px`` (N,) the worst direction's
            1-sigma: how far the pixel of a point at that distance along the ray moves with
            the calibration's noise (intrinsics and board poses jointly,
            :mod:`graphpose.calibrate.uncertainty`).

        Raises
        ------
        InputError
            If the calibration has no joint covariance (it failed), or an argument is bad.
        """
        from ..errors import InputError
        from .uncertainty import projection_uncertainty

        if self.joint_cov is None or not np.all(np.isfinite(self.joint_cov)):
            raise InputError("this calibration has no joint covariance (it failed): no projection uncertainty")
        poses = [T for T, s in zip(self.poses, self.status) if s == "used"]
        return projection_uncertainty(self.camera, poses, self.joint_cov, points_px, distance_m)

    def projection_uncertainty_map(self, step: float = 16.0, distance_m="boards"):
        """:meth:`projection_uncertainty` over a grid of the image.

        Parameters
        ----------
        step : float
            Grid spacing, pixels (>= 1); the grid starts at pixel (0, 0).
        distance_m : float, "boards" or None
            Metres along each ray; ``"boards"`` (default): :attr:`board_distance_m`; None:
            at infinity.

        Returns
        -------
        us : (W',) ndarray
        vs : (H',) ndarray
        sigma : (H', W') ndarray
            The worst direction's 1-sigma at each grid pixel, pixels; NaN where the camera
            has no ray.
        """
        if isinstance(distance_m, str):
            if distance_m != "boards":
                from ..errors import InputError

                raise InputError(f"distance_m must be metres, 'boards' or None, got {distance_m!r}")
            distance_m = self.board_distance_m
        us, vs = self._grid(step)
        u, v = np.meshgrid(us, vs)
        out = self.projection_uncertainty(np.stack([u.ravel(), v.ravel()]), distance_m)
        return us, vs, out.sigma_px.reshape(u.shape)

    def coverage(self, step: float = 32.0):
        """How many used junctions fell in each cell of a grid over the image.

        Parameters
        ----------
        step : float
            Cell side, pixels (>= 1).

        Returns
        -------
        us : (W',) ndarray
            The cells' left edges u, pixels (cell ``[u - 0.5, u - 0.5 + step)``).
        vs : (H',) ndarray
            The cells' top edges v, pixels.
        counts : (H', W') ndarray of int
            Junctions of the used images per cell.
        """
        us, vs = self._grid(step)
        used = [p for p, s in zip(self.points, self.status) if s == "used" and p.size]
        pts = np.hstack(used) if used else np.zeros((2, 0))
        width, height = self.camera.size
        counts, _, _ = np.histogram2d(pts[1], pts[0], bins=[np.r_[vs, height] - 0.5, np.r_[us, width] - 0.5])
        return us, vs, counts.astype(int)

"""What a calibration returns: :class:`Calibration`, and where over the image it holds.

The projection uncertainty map (:meth:`Calibration.uncertainty_map`) follows mrcal's idea
(how well does the calibration project a ray it has not seen, at each pixel?) in its plain
form, from the intrinsics' covariance alone: for the ray ``q`` that the calibrated camera
sees at pixel ``(u, v)``, the pixel covariance of projecting ``q`` under the intrinsics'
uncertainty is ``Sigma_uv = J cov J^T`` with ``J = d uv / d p`` at ``q``
(:func:`graphpose.camera_params.projection_jacobian_intrinsics`), and the map is the
1-sigma along the worst direction, ``sqrt(largest eigenvalue of Sigma_uv)``, pixels. In the
camera's own frame a ray projects to the same pixel at every distance, so this plain form
does not depend on the distance; mrcal's full form also carries the uncertainty of the camera
frame (through the board poses), which makes near points differ from far ones: that part is
not computed here. Where no junction was seen the map grows with the extrapolation of the
lens model (the corners of a radial-tangential camera, say): the map says so, and
:meth:`Calibration.coverage` shows where junctions were.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import check_number
from ..camera_params import projection_jacobian_intrinsics

#: Per-image statuses.
STATUSES = ("used", "rejected", "no board", "unreadable")


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
        unitless): GTSAM's marginal, scaled by the pixel noise estimated from the residuals.
    parameter_names : tuple of str
        :func:`graphpose.calibrate.parameter_names` of the model.
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
        Pixel noise behind ``cov``, estimated from the Huber-weighted residuals.
    ok : bool
        True when both solvers converged and agree (``cross_check``).
    cross_check : dict
        ``gtsam`` and ``lm``: the two solvers' parameters (lists); ``max_difference``: the
        largest ``|p_gtsam - p_lm| / max(|p|, sigma_p)`` over the parameters; ``tolerance``
        (1e-6); ``converged``: both solvers'.
    summary : str
        One line: what was found, or why the calibration failed.
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
    cross_check: dict
    summary: str

    @property
    def parameters(self) -> np.ndarray:
        """The intrinsic parameters, (P,), in ``parameter_names`` order."""
        from ..camera_params import camera_parameters

        return camera_parameters(self.camera)

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
            J = projection_jacobian_intrinsics(self.camera, rays[:, good])
            S = J @ self.cov @ J.transpose(0, 2, 1)  # (N, 2, 2)
            tr, det = S[:, 0, 0] + S[:, 1, 1], S[:, 0, 0] * S[:, 1, 1] - S[:, 0, 1] * S[:, 1, 0]
            out[good] = np.sqrt(np.maximum(0.5 * tr + np.sqrt(np.maximum(0.25 * tr * tr - det, 0.0)), 0.0))
        return us, vs, out.reshape(u.shape)

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

"""Cross-validation: two calibrations of one camera from disjoint halves of the views, and
how far their projections differ, beside what their covariances predict.

:func:`projection_diff` compares two cameras as mrcal's ``projection_diff`` does at infinity:
grid the image, unproject every grid pixel through both cameras, fit the rotation that best
maps the first camera's rays onto the second's over a focus region around the image's centre
(the two calibrations' frames are each tied to their own boards, so only their rays'
directions are comparable, up to that rotation; the fit is the closed-form orthogonal
Procrustes on the unit rays), and report ``|camera1.project(R ray0) - q|`` at every grid pixel.

:func:`cross_validate` calibrates the odd and the even views of a calibration from its own
junctions (:func:`graphpose.calibrate.calibrate_corners`), differences the two, and sets the
difference beside what the two covariances predict for it: to first order the difference at
``q`` is ``J(q) (p_1 - p_0)`` (``J`` the projection's derivative in the intrinsics for the ray
held fixed) less the part the fitted rotation takes up (``G(q) omega``, ``G`` the derivative
in a small rotation of the ray, ``omega`` the least-squares fit over the focus region, linear
in ``p_1 - p_0``), so its covariance is ``L(q) (C_0 + C_1) L(q)^T`` with ``L = J - G M``; the
prediction is its RMS length ``sqrt(trace)`` (the halves are independent). A difference far above its prediction says the model or the noise is not
all the covariance assumes (a bent board, a lens the model cannot follow, correlated
junction errors).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..geometry import hats

#: mrcal's default focus region: a radius of min(width, height) / 6 around the image's centre.
FOCUS_FRACTION = 1.0 / 6.0


@dataclass(frozen=True)
class ProjectionDiff:
    """Two cameras' projection difference over the image (:func:`projection_diff`).

    Attributes
    ----------
    us, vs : ndarray
        The grid's columns and rows, pixels.
    diff_px : (H', W') ndarray
        ``|camera1.project(R camera0.unproject(q)) - q|``, pixels; NaN where a camera has no ray.
    R : (3, 3) ndarray
        The fitted rotation from the first camera's frame to the second's.
    median_px : float
        The median of ``diff_px`` over the grid.
    """

    us: np.ndarray
    vs: np.ndarray
    diff_px: np.ndarray
    R: np.ndarray
    median_px: float


@dataclass(frozen=True)
class CrossValidation:
    """:func:`cross_validate`'s result.

    Attributes
    ----------
    halves : tuple of Calibration
        The calibrations of the even-numbered (0, 2, ...) and odd-numbered used views.
    diff : ProjectionDiff
        Their projection difference after the fitted rotation.
    predicted_px : (H', W') ndarray
        ``sqrt(trace(Sigma_0 + Sigma_1))`` of the two halves' projection uncertainties at
        infinity, pixels: the RMS length the difference would have from the noise alone.
    median_px, predicted_median_px : float
        Medians of the difference and of its prediction over the grid.
    """

    halves: tuple
    diff: ProjectionDiff
    predicted_px: np.ndarray
    median_px: float
    predicted_median_px: float


def _grid(camera, step):
    width, height = camera.size
    us, vs = np.arange(0.0, width, step), np.arange(0.0, height, step)
    u, v = np.meshgrid(us, vs)
    return us, vs, np.stack([u.ravel(), v.ravel()])


def projection_diff(camera0, camera1, step: float = 16.0, focus_radius_px=None) -> ProjectionDiff:
    """Two cameras' projection difference at infinity after the best-fitting rotation.

    Parameters
    ----------
    camera0, camera1 : Camera
        Two calibrations of one camera (same image size).
    step : float
        Grid spacing, pixels.
    focus_radius_px : float, optional
        The rotation is fitted on the grid pixels within this radius of the image's centre;
        default ``min(width, height) / 6`` (mrcal's); 0 or more than the diagonal: the whole
        image.

    Returns
    -------
    ProjectionDiff

    Raises
    ------
    InputError
        If the cameras' sizes differ or are unknown, or the focus region holds fewer than
        three grid pixels with rays in both cameras.
    """
    if camera0.size is None or tuple(camera0.size) != tuple(camera1.size or ()):
        raise InputError(f"projection_diff needs two cameras of one known image size, got {camera0.size} and "
                         f"{camera1.size}")
    us, vs, q = _grid(camera0, step)
    width, height = camera0.size
    radius = min(width, height) * FOCUS_FRACTION if focus_radius_px is None else float(focus_radius_px)
    v0, v1 = camera0.unproject(q), camera1.unproject(q)
    good = np.all(np.isfinite(v0), axis=0) & np.all(np.isfinite(v1), axis=0)
    centre = np.array([[(width - 1) / 2.0], [(height - 1) / 2.0]])
    near = np.hypot(*(q - centre)) <= radius if radius > 0 else np.ones(q.shape[1], bool)
    fit = good & near
    if fit.sum() < 3:
        raise InputError(f"the focus region (radius {radius:g} px) holds {int(fit.sum())} grid pixels with rays "
                         "in both cameras; at least 3 are needed (a larger focus_radius_px or a finer step)")
    # Orthogonal Procrustes: R minimising sum |v1 - R v0|^2.
    U, _, Vt = np.linalg.svd(v1[:, fit] @ v0[:, fit].T)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    R = U @ D @ Vt
    diff = np.full(q.shape[1], np.nan)
    with np.errstate(invalid="ignore"):
        p = camera1.project(R @ v0[:, good])
    diff[good] = np.hypot(*(p - q[:, good]))
    diff = diff.reshape(vs.size, us.size)
    return ProjectionDiff(us, vs, diff, R, float(np.nanmedian(diff)))


def predicted_diff(camera, cov, step: float = 16.0, focus_radius_px=None) -> np.ndarray:
    """The RMS length of the projection difference that the intrinsics' covariance ``cov``
    of the difference ``p_1 - p_0`` predicts after the rotation fit (module docstring), at
    :func:`projection_diff`'s grid pixels (flattened, row by row); NaN where no ray."""

    _, _, q = _grid(camera, step)
    width, height = camera.size
    radius = min(width, height) * FOCUS_FRACTION if focus_radius_px is None else float(focus_radius_px)
    v = camera.unproject(q)
    good = np.all(np.isfinite(v), axis=0)
    vg = v[:, good]
    J = camera.parameter_jacobian(vg)  # (N, 2, P)
    _, Gp = camera.project_jacobian(vg)  # (N, 2, 3)
    # d (R v) / d omega at R = I is -[v]_x.
    G = -Gp @ hats(vg)  # (N, 2, 3)
    centre = np.array([[(width - 1) / 2.0], [(height - 1) / 2.0]])
    qg = q[:, good]
    near = np.hypot(*(qg - centre)) <= radius if radius > 0 else np.ones(qg.shape[1], bool)
    GtG = np.einsum("nik,nil->kl", G[near], G[near])
    GtJ = np.einsum("nik,nil->kl", G[near], J[near])
    M = np.linalg.solve(GtG, GtJ)  # (3, P)
    L = J - G @ M
    S = L @ cov @ L.transpose(0, 2, 1)
    out = np.full(q.shape[1], np.nan)
    out[good] = np.sqrt(np.maximum(S[:, 0, 0] + S[:, 1, 1], 0.0))
    return out


def cross_validate(calibration, *, board, step: float = 16.0, progress=None, warp="auto") -> CrossValidation:
    """Calibrate the even and odd used views apart and difference the two (module docstring).

    Parameters
    ----------
    calibration : Calibration
        A calibration with its ``detections`` (from :func:`graphpose.calibrate` or
        :func:`graphpose.calibrate.calibrate_corners`).
    board : Board
        Its board.
    step : float
        Grid spacing of the difference, pixels.
    progress : callable, optional
        Passed to each half's calibration.
    warp : bool or "auto"
        Each half's board warp (:func:`graphpose.calibrate.calibrate`'s ``warp``).

    Returns
    -------
    CrossValidation

    Raises
    ------
    InputError
        If fewer than six views were used (each half needs three), or a half fails.
    """
    from .run import MIN_IMAGES, calibrate_corners

    used = [k for k, s in enumerate(calibration.status) if s == "used"]
    if len(used) < 2 * MIN_IMAGES:
        raise InputError(f"cross-validation calibrates two halves of the used views, each from at least {MIN_IMAGES}; "
                         f"this calibration used {len(used)}")
    halves = []
    for half in (used[0::2], used[1::2]):
        c = calibrate_corners([calibration.detections[k] for k in half], calibration.camera.model, board=board,
                              size=calibration.camera.size,
                              names=[calibration.images[k] for k in half],
                              progress=progress, warp=warp)
        if not c.ok:
            raise InputError(f"cross-validation: a half's calibration failed: {c.summary}")
        halves.append(c)
    diff = projection_diff(halves[0].camera, halves[1].camera, step)
    predicted = predicted_diff(halves[0].camera, halves[0].cov + halves[1].cov, step).reshape(diff.diff_px.shape)
    return CrossValidation(tuple(halves), diff, predicted, diff.median_px, float(np.nanmedian(predicted)))

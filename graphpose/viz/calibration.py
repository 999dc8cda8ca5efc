"""A picture of a calibration: the ``plot`` extra (``pip install -e ".[plot]"``).

Three panels: the residuals of every junction (used images in colour, rejected ones in red),
the per-image RMS, and the image itself with the projection uncertainty map under the
junctions that were used (the coverage). The map is mrcal's projection uncertainty
(:meth:`graphpose.calibrate.result.Calibration.projection_uncertainty_map`, the worst
direction's 1-sigma, pixels) at the boards' median distance: the camera frame tied to the
board poses the calibration saw, so it is smallest where the boards were and grows where the
lens model is extrapolated (a calibration without the joint covariance falls back to the
intrinsics-only :meth:`~graphpose.calibrate.result.Calibration.uncertainty_map`). Only :func:`plot_calibration` imports matplotlib, and only its
object API (no pyplot), as :mod:`graphpose.viz.plot`.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.files import atomic_write

#: Colours of the image statuses.
_COLOURS = {"used": "tab:blue", "rejected": "tab:red", "no board": "0.6", "unreadable": "0.6"}


def plot_calibration(calibration, path, *, title: str = "", step: float = 16.0) -> None:
    """Save a PNG of a calibration: residuals, per-image RMS, coverage and uncertainty.

    Parameters
    ----------
    calibration : graphpose.calibrate.result.Calibration
        The calibration (its camera must know its image size).
    path : str or Path
        Output PNG, written whole or not at all.
    title : str
        A title over the picture.
    step : float
        Grid spacing of the uncertainty map, pixels.

    Raises
    ------
    InputError
        If matplotlib is not installed or the file cannot be written.
    """
    figure = _figure((14, 5.2), "calibration")
    residuals, per_image, image = figure.subplots(1, 3, gridspec_kw={"width_ratios": [1, 1, 1.5]})
    _residuals(residuals, calibration)
    _per_image(per_image, calibration)
    _coverage(figure, image, calibration, step)
    if title:
        figure.suptitle(title)
    _save_png(figure, path)


def _figure(size, what, layout="constrained"):
    """A matplotlib figure on the Agg canvas (object API), or InputError without matplotlib."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise InputError(f"the {what} picture needs matplotlib: pip install -e \".[plot]\"") from None
    figure = Figure(figsize=size, layout=layout)
    FigureCanvasAgg(figure)
    return figure


def _save_png(figure, path) -> None:
    """``figure`` as a PNG at ``path``, written whole or not at all."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=100)
    atomic_write(path, buffer.getvalue())


def _residuals(ax, calibration) -> None:
    lim = 0.0
    for status in ("used", "rejected"):
        r = [res for res, s in zip(calibration.residuals, calibration.status) if s == status and res.size]
        if not r:
            continue
        r = np.hstack(r)
        lim = max(lim, float(np.nanmax(np.abs(r))))
        ax.plot(r[0], r[1], ".", ms=2, color=_COLOURS[status], alpha=0.6, label=f"{status} ({r.shape[1]})")
    rms = float(calibration.rms_px)
    if np.isfinite(rms):
        t = np.linspace(0, 2 * np.pi, 200)
        ax.plot(rms * np.cos(t), rms * np.sin(t), "k--", lw=1, label=f"RMS {rms:.3f} px")
    lim = 1.1 * max(lim, rms if np.isfinite(rms) else 0.0, 1e-3)
    ax.set(xlim=(-lim, lim), ylim=(lim, -lim), xlabel="du (px)", ylabel="dv (px)", aspect="equal",
           title="residuals, measured - predicted")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)


def _per_image(ax, calibration) -> None:
    rms = np.asarray(calibration.image_rms_px, dtype=float)
    colours = [_COLOURS[s] for s in calibration.status]
    k = np.arange(rms.size)
    ax.bar(k, np.where(np.isfinite(rms), rms, 0.0), color=colours)
    for i in np.flatnonzero(~np.isfinite(rms)):
        ax.text(i, 0, calibration.status[i], rotation=90, ha="center", va="bottom", fontsize=7, color="0.4")
    ax.axhline(float(calibration.rms_px), color="k", ls="--", lw=1)
    ax.set(xlabel="image", ylabel="RMS (px)", title="per image (blue used, red rejected)")
    ax.set_xticks(k)
    # The images by file name (a path's last part), as the summary and the report name them.
    ax.set_xticklabels([Path(str(name)).name for name in calibration.images], fontsize=7, rotation=60,
                       ha="right")
    ax.grid(alpha=0.3, axis="y")


def _coverage(figure, ax, calibration, step) -> None:
    from matplotlib.colors import LogNorm

    if calibration.joint_cov is not None and np.all(np.isfinite(calibration.joint_cov)):
        us, vs, sigma = calibration.projection_uncertainty_map(step)
        what = f"at the boards' {calibration.board_distance_m:.2f} m"
    else:
        us, vs, sigma = calibration.uncertainty_map(step)
        what = "intrinsics only"
    width, height = calibration.camera.size
    finite = sigma[np.isfinite(sigma) & (sigma > 0)]
    if finite.size:
        # Logarithmic: the map spans decades, from the covered middle to the extrapolated rim.
        low, high = float(finite.min()), float(finite.max())
        norm = LogNorm(vmin=low, vmax=max(high, 1.01 * low))
        mesh = ax.imshow(np.where(sigma > 0, sigma, np.nan), origin="upper", cmap="viridis", norm=norm,
                         extent=(us[0] - step / 2, us[-1] + step / 2, vs[-1] + step / 2, vs[0] - step / 2))
        figure.colorbar(mesh, ax=ax, label=f"projection 1-sigma (px), {what}", shrink=0.85)
        levels = [v for v in (0.01, 0.02, 0.05, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0) if low < v < high]
        if levels:
            lines = ax.contour(us, vs, sigma, levels=levels, colors="w", linewidths=0.8)
            ax.clabel(lines, fmt=lambda v: f"{v:g} px", fontsize=7)
    used = [p for p, s in zip(calibration.points, calibration.status) if s == "used" and p.size]
    if used:
        pts = np.hstack(used)
        ax.plot(pts[0], pts[1], ".", ms=1.5, color="tab:orange", alpha=0.8)
    ax.set(xlim=(-0.5, width - 0.5), ylim=(height - 0.5, -0.5), xlabel="u (px)", ylabel="v (px)",
           aspect="equal", title=f"junctions used (orange) over the uncertainty; max {np.nanmax(sigma):.3g} px"
           if finite.size else "junctions used")


def plot_cross_validation(cross_validation, path) -> None:
    """Save a PNG of a cross-validation (:func:`graphpose.calibrate.crossval.cross_validate`):
    the two halves' projection difference over the image after the fitted rotation, beside
    what their covariances predict for it, on one logarithmic scale.

    Parameters
    ----------
    cross_validation : graphpose.calibrate.crossval.CrossValidation
    path : str or Path
        Output PNG, written whole or not at all.

    Raises
    ------
    InputError
        If matplotlib is not installed or the file cannot be written.
    """
    figure = _figure((12, 4.6), "cross-validation")
    from matplotlib.colors import LogNorm

    cv = cross_validation
    d = cv.diff
    step = float(d.us[1] - d.us[0]) if d.us.size > 1 else 1.0
    maps = (d.diff_px, cv.predicted_px)
    finite = np.concatenate([m[np.isfinite(m) & (m > 0)] for m in maps])
    axes = figure.subplots(1, 2)
    norm = LogNorm(vmin=float(finite.min()), vmax=max(float(finite.max()), 1.01 * float(finite.min()))) \
        if finite.size else None
    titles = (f"difference after the fitted rotation: median {cv.median_px:.3f} px",
              f"predicted by the two covariances: median {cv.predicted_median_px:.3f} px")
    width, height = cv.halves[0].camera.size
    for ax, m, title in zip(axes, maps, titles):
        mesh = ax.imshow(np.where(m > 0, m, np.nan), origin="upper", cmap="viridis", norm=norm,
                         extent=(d.us[0] - step / 2, d.us[-1] + step / 2, d.vs[-1] + step / 2, d.vs[0] - step / 2))
        levels = [v for v in (0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0) if finite.size and finite.min() < v < finite.max()]
        if levels:
            lines = ax.contour(d.us, d.vs, m, levels=levels, colors="w", linewidths=0.8)
            ax.clabel(lines, fmt=lambda v: f"{v:g} px", fontsize=7)
        ax.set(xlim=(-0.5, width - 0.5), ylim=(height - 0.5, -0.5), xlabel="u (px)", ylabel="v (px)",
               aspect="equal", title=title)
    figure.colorbar(mesh, ax=axes, label="pixels", shrink=0.85)
    n0, n1 = (h.status.count("used") for h in cv.halves)
    figure.suptitle(f"cross-validation: the even ({n0}) and odd ({n1}) views calibrated apart, at infinity")
    _save_png(figure, path)

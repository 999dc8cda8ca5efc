"""A picture of a rig calibration (the ``plot`` extra): each camera's coverage and the rig from above.

One panel per camera with the junctions its used views contributed over its image (where the
calibration has seen the lens), and one panel with the rig seen from above: each camera's
centre in camera 0's frame (x to the right, z forward, metres), its optical axis, and the
baseline to camera 0 with its 1-sigma. Only :func:`plot_rig` imports matplotlib, and only its
object API, as :mod:`graphpose.viz.calibration`.
"""

from __future__ import annotations

import numpy as np

from .calibration import _figure, _save_png


def plot_rig(calibration, path) -> None:
    """Save a PNG of a rig calibration: coverage per camera and the rig from above.

    Parameters
    ----------
    calibration : graphpose.calibrate.rig.RigCalibration
    path : str or Path
        Output PNG, written whole or not at all.

    Raises
    ------
    InputError
        If matplotlib is not installed or the file cannot be written.
    """
    rig = calibration.rig
    n = len(rig)
    figure = _figure((4.2 * (n + 1), 4.0), "rig", layout=None)  # laid out by tight_layout below
    for c, (camera, cal) in enumerate(zip(rig.cameras, calibration.calibrations)):
        ax = figure.add_subplot(1, n + 1, c + 1)
        w, h = camera.size
        used = [p for p, s in zip(cal.points, cal.status) if s == "used" and p.size]
        for p in used:
            ax.plot(p[0], p[1], ".", ms=2)
        ax.set_xlim(-0.5, w - 0.5)
        ax.set_ylim(h - 0.5, -0.5)
        ax.set_aspect("equal")
        ax.set_title(f"{rig.names[c]} ({camera.model}): {len(used)} views, RMS {calibration.camera_rms_px[c]:.2f} px",
                     fontsize=8)
        ax.set_xlabel("u (px)")
        ax.set_ylabel("v (px)")
    ax = figure.add_subplot(1, n + 1, n + 1)
    centres = np.array([T[:3, 3] for T in rig.T_C0_C])
    span = max(float(np.ptp(centres[:, [0, 2]])), 0.05)
    for c, T in enumerate(rig.T_C0_C):
        x, z = T[0, 3], T[2, 3]
        axis = T[:3, 2] * 0.3 * span
        ax.plot([x], [z], "o")
        ax.annotate("", (x + axis[0], z + axis[2]), (x, z), arrowprops={"arrowstyle": "->"})
        ax.text(x, z, f" {rig.names[c]}", fontsize=8)
    for e in calibration.extrinsics():
        T = rig.T_C0_C[e["camera"]]
        ax.plot([0, T[0, 3]], [0, T[2, 3]], "k:", lw=0.8)
        ax.text(0.5 * T[0, 3], 0.5 * T[2, 3], f"{1000 * e['baseline_m']:.1f} +- {1000 * e['baseline_sigma_m']:.1f} mm",
                fontsize=7)
    mid = 0.5 * (centres[:, [0, 2]].min(axis=0) + centres[:, [0, 2]].max(axis=0))
    ax.set_xlim(mid[0] - 0.8 * span, mid[0] + 0.8 * span)
    ax.set_ylim(mid[1] - 0.6 * span, mid[1] + 1.0 * span)
    ax.set_aspect("equal")
    ax.set_xlabel("x in camera 0's frame (m)")
    ax.set_ylabel("z, forward (m)")
    ax.set_title("the rig from above", fontsize=8)
    figure.tight_layout()
    _save_png(figure, path)

"""The command line's JSON records: one format for ``estimate`` and ``track``."""

from __future__ import annotations

import numpy as np

from ..io.files import to_jsonable


def result_record(image, estimate=None, error=None) -> dict:
    """One image's result as a JSON-ready dict (the ``--json`` format of the command line).

    Parameters
    ----------
    image : str or Path
        The image, as the user named it.
    estimate : PoseEstimate or None
        The pose (see :func:`graphpose.pose.estimate.estimate_pose`); None when the image failed.
    error : str or None
        Why the image failed, or None.

    Returns
    -------
    record : dict
        Keys ``image``, ``converged``, ``iterations``, ``T_WC`` (4 x 4), ``xyz_m`` (3),
        ``rpy_deg`` (3, roll pitch yaw), ``sigma_xyz_mm`` (3), ``sigma_rpy_deg`` (3),
        ``reprojection_rms_px``, ``junctions`` (2 x n pixels, null where a junction was not
        measured; null altogether for an estimate from given points, which has no
        ``junctions``), ``trusted`` (n booleans: the junctions' flags, or the estimate's
        ``mask`` without junctions), ``cross_check`` (``translation_m``, ``rotation_deg``,
        ``agree``) and ``error``. Without an estimate every key but ``image``, ``converged``
        (false) and ``error`` is null.
    """
    record = {"image": str(image), "converged": False, "iterations": None, "T_WC": None,
              "xyz_m": None, "rpy_deg": None, "sigma_xyz_mm": None, "sigma_rpy_deg": None,
              "reprojection_rms_px": None, "junctions": None, "trusted": None,
              "cross_check": None, "error": error}
    if estimate is None:
        return record
    params = np.asarray(estimate.params)
    check = estimate.cross_check
    junctions = estimate.junctions
    record.update(
        converged=bool(estimate.converged),
        iterations=int(estimate.iterations),
        T_WC=np.asarray(estimate.T_WC),
        xyz_m=params[:3],
        rpy_deg=np.degrees(params[3:]),
        sigma_xyz_mm=1000.0 * np.asarray(estimate.sigma_xyz_m),
        sigma_rpy_deg=np.degrees(estimate.sigma_rpy_rad),
        reprojection_rms_px=float(estimate.reprojection_rms_px),
        junctions=None if junctions is None else np.asarray(junctions.points),
        trusted=np.asarray(estimate.mask if junctions is None else junctions.trusted, dtype=bool),
        cross_check={"translation_m": float(check.translation_m),
                     "rotation_deg": float(check.rotation_deg), "agree": bool(check.agree)},
    )
    return to_jsonable(record)


"""JSON records of results: one format, one set of units, for every subcommand and the batch.

Every record, whether one image of ``graphpose estimate`` or one frame of ``graphpose
track``, carries the same pose block:

==========================  =================================================================
``status``                  ``estimate``: ``"ok"`` or ``"failed"``; ``track``: ``"tracked"``,
                            ``"detected"`` or ``"lost"``
``message``                 why there is no pose (or a note on how it was found); ``null``
                            when there is nothing to say
``T_WC``                    4 x 4 camera pose in the target frame (metres)
``xyz_m``                   camera position x, y, z, metres
``rpy_deg``                 roll, pitch, yaw, degrees (``C = Cz(yaw) Cy(pitch) Cx(roll)``)
``sigma_xyz_m``             1-sigma of x, y, z, metres
``sigma_rpy_deg``           1-sigma of roll, pitch, yaw, degrees
``reprojection_rms_px``     RMS reprojection residual of the junctions used, pixels
``junctions_used``          how many junctions the pose rests on
==========================  =================================================================

Every record of ``estimate`` and ``batch`` then names what the pose was estimated with
(:func:`target_keys`): ``camera`` (``model``, ``K``, ``distortion``, ``size`` as graphpose's
JSON camera file holds them, then ``file``: the ``--camera`` file as typed or the case file
that gave the camera, null for ``--K``, and ``name``: the ``--camera-name``) and ``board``
(``cols``, ``rows``, ``square_m``).

Units are in the key's name: lengths in metres, angles in degrees, image positions in
pixels. Without a pose every value of the block but ``status`` and ``message`` is ``null``;
non-finite numbers are written as ``null`` (JSON has no NaN).
"""

from __future__ import annotations

import numpy as np

from ..geometry import params_from_T
from .files import to_jsonable
from ..pose.covariance import SIGMA_PIXEL

#: The keys every record has, in order.
POSE_KEYS = ("status", "message", "T_WC", "xyz_m", "rpy_deg", "sigma_xyz_m", "sigma_rpy_deg",
             "reprojection_rms_px", "junctions_used")


def pose_block(status: str, message, T_WC=None, cov=None, reprojection_rms_px=None, junctions_used=None) -> dict:
    """The pose keys of a record (see the module docstring).

    Parameters
    ----------
    status : str
        The record's status word.
    message : str or None
        Why there is no pose, or a note; empty strings become None.
    T_WC : (4, 4) array_like or None
        The pose; None when there is none.
    cov : (6, 6) array_like or None
        Covariance of ``(x, y, z, roll, pitch, yaw)``, metres and radians.
    reprojection_rms_px : float or None
        Pixels.
    junctions_used : int or None
        Junctions behind the pose.
    """
    block = dict.fromkeys(POSE_KEYS)
    block.update(status=status, message=message or None)
    if T_WC is None:
        return block
    params = params_from_T(T_WC)
    sigma = None if cov is None else np.sqrt(np.diag(np.asarray(cov, dtype=float)))
    block.update(
        T_WC=np.asarray(T_WC),
        xyz_m=params[:3],
        rpy_deg=np.degrees(params[3:]),
        sigma_xyz_m=None if sigma is None else sigma[:3],
        sigma_rpy_deg=None if sigma is None else np.degrees(sigma[3:]),
        reprojection_rms_px=None if reprojection_rms_px is None else float(reprojection_rms_px),
        junctions_used=None if junctions_used is None else int(junctions_used),
    )
    return block


def result_record(image, estimate=None, error=None) -> dict:
    """One image's result (``graphpose estimate --json``) as a JSON-ready dict.

    Parameters
    ----------
    image : str or Path
        The image, as the user named it.
    estimate : PoseEstimate or None
        The pose (see :func:`graphpose.estimate.estimate_pose`); None when the image failed.
    error : str or None
        Why the image failed, or None.

    Returns
    -------
    record : dict
        ``image``, then the pose block of the module docstring (``status`` ``"ok"`` when
        there is no ``error``, else ``"failed"``; the pose is kept even then when there is
        one, for instance an unreliable one), then ``converged``, ``iterations``,
        ``junctions`` (2 x n pixels, null where a junction was not measured; null
        altogether for an estimate from given points), ``trusted`` (n booleans: the
        junctions' flags, or the estimate's ``mask`` without junctions),
        ``cross_check`` (``translation_m``, ``rotation_deg``, ``agree``),
        ``orientation_ambiguous`` (true when the board is unchanged by a half turn and no
        bounds named junction 0's corner: junction 0 is then the corner nearest the image's
        upper left; null without an estimate), ``junction0_square`` (``"dark"`` or
        ``"light"``: the colour of junction 0's outer corner square as seen in the image, light
        when bounds named a corner the colours would not; null without junctions), and
        ``sigma_kind`` (what the sigmas describe:
        ``"pixel noise"``, or ``"pixel noise and calibration"`` for a camera file with the
        intrinsics' covariance) with ``sigma_pixel_xyz_m`` and ``sigma_pixel_rpy_deg`` (the
        pixel noise's share alone; the sigmas themselves when that is all there is).
    """
    status = "failed" if error else "ok"
    record = {"image": str(image)}
    if estimate is None:
        record.update(pose_block(status, error))
        record.update(converged=False, iterations=None, junctions=None, trusted=None, cross_check=None,
                      orientation_ambiguous=None, junction0_square=None, sigma_kind=None,
                      sigma_pixel_xyz_m=None, sigma_pixel_rpy_deg=None)
        return to_jsonable(record)
    check = estimate.cross_check
    junctions = estimate.junctions
    record.update(pose_block(status, error, estimate.T_WC, estimate.cov, estimate.rms_px,
                             int(np.count_nonzero(estimate.mask))))
    record.update(
        converged=bool(estimate.converged),
        iterations=int(estimate.iterations),
        junctions=None if junctions is None else np.asarray(junctions.points),
        trusted=np.asarray(estimate.mask if junctions is None else junctions.trusted, dtype=bool),
        cross_check={"translation_m": float(check.translation_m),
                     "rotation_deg": float(check.rotation_deg), "agree": bool(check.agree)},
        orientation_ambiguous=bool(getattr(estimate, "orientation_ambiguous", False)),
        junction0_square=getattr(junctions, "junction0_square", None),
    )
    pixel = pose_block(status, None, estimate.T_WC, getattr(estimate, "cov_pixel", estimate.cov))
    record.update(sigma_kind=getattr(estimate, "sigma_kind", SIGMA_PIXEL), sigma_pixel_xyz_m=pixel["sigma_xyz_m"],
                  sigma_pixel_rpy_deg=pixel["sigma_rpy_deg"])
    return to_jsonable(record)


def frame_record(frame, path) -> dict:
    """One tracked frame (``graphpose track --json``) as a JSON-ready dict.

    Parameters
    ----------
    frame : FrameResult
        The tracker's answer for the frame (:class:`graphpose.track.results.FrameResult`).
    path : str or Path
        The frame's file.

    Returns
    -------
    record : dict
        ``index``, ``file``, ``timestamp`` (seconds), then the pose block of the module
        docstring (``status`` the frame's: tracked, detected or lost).
    """
    record = {"index": int(frame.index), "file": str(path), "timestamp": float(frame.timestamp)}
    has = frame.T_WC is not None
    record.update(pose_block(frame.status, frame.message, frame.T_WC if has else None, frame.cov,
                             frame.rms_px if has else None, frame.junctions if has else None))
    return to_jsonable(record)


def target_keys(camera, board, file=None, name=None) -> dict:
    """The ``camera`` and ``board`` keys of a record: what its pose was estimated with.

    Parameters
    ----------
    camera : Camera or (3, 3) array_like
        The camera model (a ``K`` is a pinhole camera).
    board : Board
        The target.
    file : str or None
        Where the camera came from: the calibration file as the user named it, or the case
        file that gave it; None for ``--K``.
    name : str or None
        The camera's name within its file (``--camera-name``).
    """
    from ..io.cameras import camera_to_dict

    return to_jsonable({"camera": {**camera_to_dict(camera), "file": file, "name": name},
                        "board": {"cols": int(board.cols), "rows": int(board.rows), "square_m": float(board.square_m)}})


def target_words(keys: dict) -> tuple:
    """``(camera, board)`` of :func:`target_keys`' ``keys`` in words, for the reports."""
    cam, board = keys["camera"], keys["board"]
    K = cam["K"]
    where = cam["file"] if cam["file"] is not None else "--K"
    if cam["name"] is not None:
        where += f" ({cam['name']})"
    lens = cam["model"] + ("" if cam["model"] == "pinhole" else " lens")
    camera = f"{where}: {lens}, fx {K[0][0]:.1f}, fy {K[1][1]:.1f}, cx {K[0][2]:.1f}, cy {K[1][2]:.1f} px"
    return camera, f"{board['cols']} x {board['rows']} junctions, {1000 * board['square_m']:g} mm squares"


def calibration_record(calibration) -> dict:
    """The ``--report`` of a calibration, JSON-ready.

    Returns
    -------
    dict
        ``model``; ``K`` (3 x 3, pixels); ``distortion`` (OpenCV's order); ``size``
        ``[width, height]``; ``parameters`` (``{name: value}``, the covariance's order);
        ``covariance`` (P x P); ``rms_px`` (``sqrt(mean(du^2 + dv^2))`` over the junctions
        used); ``images``: per image ``image``, ``status`` (``used``, ``rejected``, ``no
        board``, ``unreadable``), ``message`` (null when there is nothing to say), ``rms_px`` (null without a
        board) and ``T_WC`` (4 x 4, the camera in the board's frame; null unless used).
    """
    camera = calibration.camera
    images = []
    for k, name in enumerate(calibration.images):
        rms = float(calibration.image_rms_px[k])
        pose = calibration.poses[k]
        images.append({
            "image": str(name),
            "status": calibration.status[k],
            "message": calibration.message[k] or None,
            "rms_px": rms if np.isfinite(rms) else None,
            "T_WC": None if pose is None else np.asarray(pose),
            "outliers": np.asarray(calibration.outliers[k]).tolist() if calibration.outliers else [],
        })
    record = {
        "model": camera.model,
        "K": camera.K,
        "distortion": camera.distortion,
        "size": None if camera.size is None else list(camera.size),
        "parameters": dict(zip(calibration.parameter_names, np.asarray(calibration.parameters, float).tolist())),
        "covariance": np.asarray(calibration.cov),
        "rms_px": float(calibration.rms_px),
        "images": images,
    }
    warp = getattr(calibration, "warp_m", None)
    if warp is not None:  # the board warp (mrcal's two parameters), where it was estimated
        record["board_warp"] = {"warp_m": np.asarray(warp, float), "covariance_m2": np.asarray(calibration.warp_cov),
                                "sag_mm": calibration.sag_mm, "sag_sigma_mm": calibration.sag_sigma_mm}
    return to_jsonable(record)

"""Rig files: a :class:`graphpose.rig.Rig` in Kalibr's camchain, OpenCV's stereo FileStorage
and graphpose's JSON, written by :func:`graphpose.io.cameras.write_camera` and read back by
:func:`graphpose.io.cameras.read_camera` (which hands a rig's document here).

Which way each transform points (``docs/rigs.md``):

- **Kalibr camchain** (``rig_formats``: ``kalibr``): ``cam0``, ``cam1``, ... each a camera as
  Kalibr writes it, and for n >= 1 ``T_cn_cnm1``, Kalibr's definition: the 4 x 4 transform
  that takes a point from camera n-1's frame into camera n's, ``p_cn = T_cn_cnm1 p_cnm1``
  (graphpose's ``T_Cn_C0 T_C0_Cn-1``). ``cam_overlaps`` lists the other cameras. A camchain
  of several cameras without ``T_cn_cnm1`` holds no extrinsics: it is read as its ``cam0``
  (or the camera ``name`` picks), as a single camera's file is read.
- **OpenCV stereo FileStorage** (``opencv``, two cameras): ``M1 D1 M2 D2 R T E F`` as OpenCV's
  ``stereo_calib`` sample writes them (``R, T`` take a point from camera 1's frame into
  camera 2's: ``p2 = R p1 + T``, metres; ``E = [T]_x R``; ``F = M2^-T E M1^-1``), and
  ``R1 R2 P1 P2 Q`` as ``stereoRectify`` defines them (computed by
  :func:`graphpose.rig.stereo_rectify`, alpha -1, zero disparity), so that a disparity tool can
  use the file as it is; with ``image_width``/``image_height`` (camera 1's; ``image_width2``,
  ``image_height2`` when camera 2's differs) and ``fisheye_model1``/``fisheye_model2``.
- **graphpose JSON** (``json``): ``{"names", "cameras": [camera files' mappings], "T_C0_C":
  [4 x 4 each, camera i's pose in camera 0's frame], "parameter_names", "covariance"}``, the
  covariance the joint one of the calibration (each camera's mapping carries its own block).

``name`` picks one camera of any rig file (``cam0``, ``cam1``, ... or the JSON's names).
"""

from __future__ import annotations

import json

import numpy as np

from ..errors import InputError
from ..rig import Rig, stereo_rectify

#: The formats a rig is written in.
RIG_FORMATS = ("json", "opencv", "kalibr")


def is_rig_document(doc) -> bool:
    """Whether a parsed calibration file holds a rig (cameras with their extrinsics)."""
    if not isinstance(doc, dict):
        return False
    if "cameras" in doc and "T_C0_C" in doc:
        return True
    if "M1" in doc and "M2" in doc:
        return True
    cams = _kalibr_cameras(doc)
    return len(cams) >= 2 and all("T_cn_cnm1" in doc[k] for k in cams[1:])


def _kalibr_cameras(doc) -> list:
    keys = [k for k, v in doc.items() if isinstance(v, dict) and ("camera_model" in v or "intrinsics" in v)]
    return sorted(keys, key=lambda k: (len(str(k)), str(k)))


def rig_from_document(doc: dict, path, name=None):
    """The rig of a parsed rig file, or the one camera ``name`` picks from it.

    Raises
    ------
    InputError
        If a key is missing or a transform is not rigid (the message names the file).
    """
    from .cameras import _from_kalibr, _matrix, camera_from_dict

    if "cameras" in doc and "T_C0_C" in doc:
        names = doc.get("names") or [f"cam{i}" for i in range(len(doc["cameras"]))]
        cameras = [camera_from_dict(c, f"{path}: camera {n}") for n, c in zip(names, doc["cameras"])]
        Ts = [_matrix(T, f"T_C0_C[{i}]", path, (4, 4)) for i, T in enumerate(doc["T_C0_C"])]
        cov = doc.get("covariance")
        rig = _rig(path, cameras, Ts, names, None if cov is None else _matrix(cov, "covariance", path, (len(cov), len(cov))),
                   doc.get("parameter_names"))
    elif "M1" in doc:
        rig = _from_opencv_stereo(doc, path)
    else:
        keys = _kalibr_cameras(doc)
        cameras = [_from_kalibr(doc, path, k) for k in keys]
        Ts = [np.eye(4)]
        for n, k in enumerate(keys[1:], start=1):
            T_cn_cnm1 = _matrix(doc[k]["T_cn_cnm1"], f"{k}.T_cn_cnm1", path, (4, 4))
            Ts.append(Ts[n - 1] @ _inverse(T_cn_cnm1, path, f"{k}.T_cn_cnm1"))
        rig = _rig(path, cameras, Ts, keys)
    if name is None:
        return rig
    try:
        return rig.camera(name)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def _rig(path, cameras, Ts, names, cov=None, parameter_names=None) -> Rig:
    try:
        return Rig(cameras, Ts, names, cov, parameter_names)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def _inverse(T, path, key) -> np.ndarray:
    from .._checks import check_transform

    try:
        T = check_transform(T, key)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


def _from_opencv_stereo(doc, path) -> Rig:
    from .cameras import _build, _matrix, _require, _size, _trim
    from ..camera_models import FisheyeCamera, PinholeCamera, RadTanCamera

    what = "OpenCV stereo calibration (M1 D1 M2 D2 R T)"
    size1 = _size(doc.get("image_width"), doc.get("image_height"), path, "image_width and image_height")
    size2 = _size(doc.get("image_width2"), doc.get("image_height2"), path, "image_width2 and image_height2") or size1
    cameras = []
    for k, size in ((1, size1), (2, size2)):
        K = _matrix(_require(doc, f"M{k}", path, what), f"M{k}", path, (3, 3))
        d = _matrix(_require(doc, f"D{k}", path, what), f"D{k}", path).ravel()
        if doc.get(f"fisheye_model{k}", 0) == 1:
            cameras.append(_build(FisheyeCamera, path, K, d, size))
        elif d.size == 0:
            cameras.append(_build(PinholeCamera, path, K, size))
        else:
            cameras.append(_build(RadTanCamera, path, K, _trim(d), size))
    T21 = np.eye(4)
    T21[:3, :3] = _matrix(_require(doc, "R", path, what), "R", path, (3, 3))
    T21[:3, 3] = _matrix(_require(doc, "T", path, what), "T", path, (3,))
    return _rig(path, cameras, [np.eye(4), _inverse(T21, path, "R, T")], ("cam0", "cam1"))


def rig_text(rig: Rig, format: str) -> str:
    """The text of a rig file of ``format`` (:data:`RIG_FORMATS`).

    Raises
    ------
    InputError
        If the format is unknown or cannot hold the rig (OpenCV's stereo file holds two
        cameras; Kalibr's radtan four coefficients: :func:`graphpose.io.cameras.write_camera`).
    """
    if format not in RIG_FORMATS:
        raise InputError(f"a rig is written as {', '.join(RIG_FORMATS)}, not {format!r} (a ros camera_info "
                         "holds one camera)")
    return {"json": _json, "opencv": _opencv, "kalibr": _kalibr}[format](rig)


def _json(rig: Rig) -> str:
    from .cameras import camera_to_dict

    doc = {"names": list(rig.names), "cameras": [camera_to_dict(c) for c in rig.cameras],
           "T_C0_C": [T.tolist() for T in rig.T_C0_C]}
    if rig.cov is not None:
        doc["parameter_names"] = list(rig.parameter_names)
        doc["covariance"] = rig.cov.tolist()
    lines = ",\n".join(f"  {json.dumps(key)}: {json.dumps(value)}" for key, value in doc.items())
    return "{\n" + lines + "\n}\n"


def _opencv(rig: Rig) -> str:
    from .cameras import _opencv_matrix_yaml as _opencv_matrix

    if len(rig) != 2:
        raise InputError(f"OpenCV's stereo file holds two cameras and this rig has {len(rig)}: write the "
                         "kalibr or json format")
    c1, c2 = rig.cameras
    pair = rig.stereo(0, 1)
    rect = stereo_rectify(rig, 0, 1)
    lines = ["%YAML:1.0", "---"]
    if c1.size is not None:
        lines += [f"image_width: {c1.size[0]}", f"image_height: {c1.size[1]}"]
    if c2.size is not None and c2.size != c1.size:
        lines += [f"image_width2: {c2.size[0]}", f"image_height2: {c2.size[1]}"]
    lines += [f"fisheye_model1: {int(c1.model == 'fisheye')}", f"fisheye_model2: {int(c2.model == 'fisheye')}"]
    text = "\n".join(lines) + "\n"
    text += _opencv_matrix("M1", c1.K, 3, 3) + _opencv_matrix("D1", c1.distortion, 1, c1.distortion.size)
    text += _opencv_matrix("M2", c2.K, 3, 3) + _opencv_matrix("D2", c2.distortion, 1, c2.distortion.size)
    text += _opencv_matrix("R", pair["R"], 3, 3) + _opencv_matrix("T", pair["T"], 3, 1)
    text += _opencv_matrix("E", pair["E"], 3, 3) + _opencv_matrix("F", pair["F"], 3, 3)
    for key, shape in (("R1", (3, 3)), ("R2", (3, 3)), ("P1", (3, 4)), ("P2", (3, 4)), ("Q", (4, 4))):
        text += _opencv_matrix(key, rect[key], *shape)
    return text


def _kalibr(rig: Rig) -> str:
    from .cameras import _floats, _kalibr as kalibr_camera

    text = ""
    names = [f"cam{i}" for i in range(len(rig))]
    for n, camera in enumerate(rig.cameras):
        text += kalibr_camera(camera, names[n])
        others = [i for i in range(len(rig)) if i != n]
        text += f"  cam_overlaps: [{', '.join(map(str, others))}]\n"
        if n:
            T = rig.T_cn_cnm1(n)
            text += "  T_cn_cnm1:\n" + "".join(f"  - [{_floats(row)}]\n" for row in T)
    return text

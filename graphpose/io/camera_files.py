"""Camera calibration files out: graphpose's JSON, OpenCV FileStorage YAML, ROS, Kalibr.

:func:`write_camera` writes one camera in one of :data:`FORMATS`, each as its own readers
expect it (and as :func:`graphpose.io.calibration.read_camera` reads it back, every number to
the last bit: floats are written in full, ``repr``):

- ``json``: graphpose's camera file ``{"model", "K", "distortion", "size"}``, and, when the
  camera carries the covariance of its intrinsic parameters (a calibration's), also
  ``"parameters"`` (the parameters by name, in the covariance's order) and ``"covariance"``;
- ``opencv``: OpenCV FileStorage YAML as ``cv::FileStorage`` and OpenCV's calibration sample
  write it (``camera_matrix``, ``distortion_coefficients``, ``image_width``/``image_height``,
  ``fisheye_model`` 1 for the fisheye); a pinhole camera has an empty coefficient matrix;
- ``ros``: a ROS ``camera_info`` YAML (``plumb_bob`` for 4 or 5 coefficients and for the
  pinhole's none, ``rational_polynomial`` for 8, ``equidistant`` for the fisheye), with the
  identity rectification and ``projection_matrix`` ``[K | 0]``;
- ``kalibr``: a Kalibr camchain of one camera (``camera_model: pinhole``, distortion
  ``radtan``, ``equidistant`` or ``none``).

Where a format cannot hold the camera the writer refuses (:class:`~graphpose.errors.InputError`
saying why and which format can), never drops a term: Kalibr's ``radtan`` keeps four
coefficients (k3..k6 must be zero), its ``intrinsics`` have no skew, and it needs the image
size; OpenCV's and ROS's radial-tangential model has no skew either (the camera class
already refuses it). The covariance is kept by the JSON file only; the other formats have no
place for it (:func:`covariance_note` says so, for the command line).
"""

from __future__ import annotations

import json

import numpy as np

from ..camera_models import as_camera
from ..errors import InputError
from .files import atomic_write

#: The formats :func:`write_camera` writes.
FORMATS = ("json", "opencv", "ros", "kalibr")


def camera_to_dict(camera) -> dict:
    """graphpose's JSON camera mapping of a camera (or of a pinhole ``K``).

    Returns
    -------
    dict
        ``{"model", "K", "distortion", "size"}``, plain lists and numbers; ``size`` is None
        when the camera's is unknown. A camera with a covariance adds ``"parameters"``
        (``{name: value}`` in the covariance's order) and ``"covariance"`` (P x P).
    """
    camera = as_camera(camera)
    doc = {
        "model": camera.model,
        "K": camera.K.tolist(),
        "distortion": camera.distortion.tolist(),
        "size": None if camera.size is None else list(camera.size),
    }
    cov = getattr(camera, "covariance", None)
    if cov is not None:

        doc["parameters"] = dict(zip(camera.parameter_names,
                                     np.asarray(camera.parameters, float).tolist()))
        doc["covariance"] = np.asarray(cov, float).tolist()
    return doc


def write_camera(path, camera, format: str = "json", *, name: str | None = None) -> None:
    """Write a camera as a calibration file, whole or not at all.

    Parameters
    ----------
    path : str or Path
        Destination; its folder must exist.
    camera : Camera, Rig or (3, 3) array_like
        The camera (a ``K`` is written as a pinhole camera), or a rig of cameras in the
        json, opencv (two cameras) or kalibr format (:mod:`graphpose.io.rig_files`).
    format : {"json", "opencv", "ros", "kalibr"}
        graphpose's JSON (with ``parameters`` and ``covariance`` when the camera carries a
        covariance), OpenCV FileStorage YAML, ROS camera_info YAML, Kalibr camchain YAML
        (see the module docstring).
    name : str, optional
        ROS: the ``camera_name`` (``camera`` if None); Kalibr: the camera's key in the chain
        (``cam0`` if None). The JSON and OpenCV files hold no name and refuse one.

    Raises
    ------
    InputError
        If the format is unknown, the format cannot hold the camera (the message says
        why: e.g. a Kalibr radtan camera with k3 not zero), the camera is invalid, or the
        file cannot be written.
    """
    from ..rig import Rig

    if isinstance(camera, Rig):  # a rig's file (graphpose.io.rig_files)
        from .rig_files import rig_text

        atomic_write(path, rig_text(camera, format))
        return
    if format not in FORMATS:
        raise InputError(f"unknown calibration file format {format!r}; graphpose writes "
                         f"{', '.join(FORMATS)}")
    camera = as_camera(camera)
    if name is not None and format in ("json", "opencv"):
        raise InputError(f"a {format} calibration file holds one camera and no name: name={name!r} "
                         f"is for the ros (camera_name) and kalibr (cam0, ...) formats")
    text = {"json": _json, "opencv": _opencv, "ros": _ros, "kalibr": _kalibr}[format](camera, name)
    atomic_write(path, text)


def covariance_note(camera, format: str) -> str | None:
    """Why the file of ``format`` does not keep the camera's covariance, or None when it does
    (JSON) or there is none."""
    if getattr(camera, "covariance", None) is None or format == "json":
        return None
    return (f"the {format} format has no place for the intrinsics' covariance: it is not in the "
            f"file (the json format keeps it, and 'graphpose estimate --camera' then reports "
            f"sigmas that include it)")


def _json(camera, name) -> str:
    doc = camera_to_dict(camera)
    if doc["size"] is None:
        del doc["size"]
    # One key a line, each value on its line (K's rows together); floats in full (repr).
    lines = ",\n".join(f"  {json.dumps(key)}: {json.dumps(value)}" for key, value in doc.items())
    return "{\n" + lines + "\n}\n"


def _float(x) -> str:
    """A float in full (``repr``), in a form YAML 1.1 and OpenCV both read as a float."""
    s = repr(float(x))
    if "e" in s and "." not in s:  # 1e-05: PyYAML's YAML 1.1 wants a dot in a float
        s = s.replace("e", ".0e")
    return s


def _floats(values) -> str:
    return ", ".join(_float(v) for v in np.ravel(values))


def _opencv_matrix(key: str, a, rows: int, cols: int) -> str:
    data = f" {_floats(a)} " if np.size(a) else ""
    return (f"{key}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n"
            f"   data: [{data}]\n")


def _opencv(camera, name) -> str:
    lines = ["%YAML:1.0", "---"]
    if camera.size is not None:
        lines += [f"image_width: {camera.size[0]}", f"image_height: {camera.size[1]}"]
    lines.append(f"fisheye_model: {1 if camera.model == 'fisheye' else 0}")
    d = camera.distortion
    return ("\n".join(lines) + "\n" + _opencv_matrix("camera_matrix", camera.K, 3, 3)
            + _opencv_matrix("distortion_coefficients", d, 1, d.size))


def _ros_model(camera) -> str:
    if camera.model == "fisheye":
        return "equidistant"
    return "rational_polynomial" if camera.distortion.size == 8 else "plumb_bob"


def _yaml_matrix(rows: int, cols: int, a) -> str:
    return f"{{rows: {rows}, cols: {cols}, data: [{_floats(a)}]}}"


def _ros(camera, name) -> str:
    name = "camera" if name is None else name
    w, h = (0, 0) if camera.size is None else camera.size  # ROS writes 0 for unknown
    d = camera.distortion
    P = np.hstack([camera.K, np.zeros((3, 1))])
    return "\n".join([
        f"image_width: {w}",
        f"image_height: {h}",
        f"camera_name: {_yaml_string(name)}",
        f"camera_matrix: {_yaml_matrix(3, 3, camera.K)}",
        f"distortion_model: {_ros_model(camera)}",
        f"distortion_coefficients: {_yaml_matrix(1, d.size, d)}",
        f"rectification_matrix: {_yaml_matrix(3, 3, np.eye(3))}",
        f"projection_matrix: {_yaml_matrix(3, 4, P)}",
    ]) + "\n"


def _yaml_string(text: str) -> str:
    """``text`` as one YAML scalar that reads back as that string."""
    import yaml

    return yaml.safe_dump(str(text), default_style=None).splitlines()[0] if text else "''"


def _kalibr(camera, name) -> str:
    name = "cam0" if name is None else name
    why = "a Kalibr camchain cannot hold this camera"
    if camera.skew != 0.0:
        raise InputError(f"{why}: Kalibr's intrinsics [fu, fv, pu, pv] have no skew, and K[0, 1] "
                         f"is {camera.skew}; the json, opencv and ros formats keep it")
    if camera.size is None:
        raise InputError(f"{why}: Kalibr's camchain needs the image size (resolution), and the "
                         f"camera has none; give the camera its size")
    d = camera.distortion
    if camera.model == "rational":
        raise InputError(f"{why}: Kalibr has no rational model (its radtan keeps k1, k2, p1, p2), and this camera is "
                         "OpenCV's rational model (k1..k6, p1, p2); write the json (keeps the model), opencv or ros "
                         "(rational_polynomial) format")
    if camera.model == "radtan":
        extra = camera.coefficients[4:]
        if np.any(extra != 0.0):
            raise InputError(
                f"{why}: Kalibr's radtan model has four coefficients (k1, k2, p1, p2), and this "
                f"camera's k3..k6 are {extra[:d.size - 4].tolist()}, not zero; a coefficient is "
                f"never dropped: write the json, opencv or ros format")
        d = d[:4]
    distortion = {"pinhole": "none", "radtan": "radtan", "fisheye": "equidistant"}[camera.model]
    return "\n".join([
        f"{_yaml_string(name)}:",
        "  camera_model: pinhole",
        f"  intrinsics: [{_floats([camera.fx, camera.fy, camera.cx, camera.cy])}]",
        f"  distortion_model: {distortion}",
        f"  distortion_coeffs: [{_floats(d)}]",
        f"  resolution: [{camera.size[0]}, {camera.size[1]}]",
    ]) + "\n"

"""Camera calibration files read and written: the ones users have, and graphpose's own JSON.

:func:`read_camera` reads, telling the format from the file's content (not its name):

- OpenCV FileStorage YAML (``%YAML:1.0``, ``!!opencv-matrix``) and XML (``<opencv_storage>``),
  as ``cv::FileStorage`` and OpenCV's calibration sample write them: ``camera_matrix``,
  ``distortion_coefficients``, optional ``image_width``/``image_height``, and
  ``fisheye_model: 1`` for a fisheye calibration (else the coefficient count decides:
  4, 5, 8 are radial-tangential);
- ROS ``camera_info`` YAML: ``camera_matrix``, ``distortion_model`` (``plumb_bob``,
  ``rational_polynomial`` or ``equidistant``), ``distortion_coefficients`` (none at all with
  ``plumb_bob``: a camera without distortion),
  ``image_width``/``image_height``;
- Kalibr camchain YAML: ``cam0``, ``cam1``, ... each with ``camera_model: pinhole``,
  ``intrinsics: [fu, fv, pu, pv]``, ``distortion_model`` (``radtan``, ``equidistant``,
  ``none``), ``distortion_coeffs``, ``resolution``; the camera is chosen by name, ``cam0``
  by default;
- graphpose's JSON camera file, which :func:`write_camera` writes (it writes the other three
  as well, below)::

      {"model": "radtan", "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],
       "distortion": [k1, k2, p1, p2, k3], "size": [width, height]}

  with ``model`` one of ``pinhole`` (``distortion`` ``[]`` or absent), ``radtan``,
  ``fisheye``, and ``size`` optional; a calibration's file adds ``"parameters"`` (``{name:
  value}``, the camera's ``parameter_names`` order) and ``"covariance"``
  (P x P, that order), which the camera then carries.

Every problem is an :class:`~graphpose.errors.InputError` naming the file and what is wrong:
a missing key, a NaN, a model graphpose does not support (named), a coefficient count that
fits no model.

:func:`write_camera` writes one camera in one of :data:`FORMATS`, each as its own readers
expect it (and as :func:`read_camera` reads it back, every number to
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

import dataclasses
import functools
import json
import math
from pathlib import Path

import numpy as np

from ..camera_models import MODELS, Camera, FisheyeCamera, PinholeCamera, RadTanCamera, as_camera
from ..errors import InputError
from .files import atomic_write

#: ROS camera_info distortion models and graphpose's names for them.
ROS_MODELS = {"plumb_bob": "radtan", "rational_polynomial": "radtan", "equidistant": "fisheye"}
#: Kalibr distortion models (of camera_model pinhole) and graphpose's names for them.
KALIBR_DISTORTIONS = {"radtan": "radtan", "equidistant": "fisheye", "none": "pinhole"}
#: Kalibr camera models graphpose does not support, with what they are.
KALIBR_UNSUPPORTED = {
    "omni": "the unified omnidirectional model",
    "ds": "the double sphere model",
    "eucm": "the extended unified model",
}
_SUPPORTED = ("graphpose supports pinhole, radtan (OpenCV's radial-tangential, ROS plumb_bob "
              "and rational_polynomial) and fisheye (OpenCV's fisheye, ROS/Kalibr equidistant)")


def _opencv_matrix(loader, node):
    fields = loader.construct_mapping(node, deep=True)
    return _OpenCVMatrix(fields)


class _OpenCVMatrix(dict):
    """An ``!!opencv-matrix`` node: its mapping (rows, cols, dt, data), kept as it came."""


@functools.lru_cache(maxsize=1)
def _opencv_loader():
    """PyYAML's safe loader with OpenCV's ``!!opencv-matrix`` tags understood (made, with
    PyYAML imported, on the first YAML file: a command given ``--K`` reads none)."""
    import yaml

    class _OpenCVLoader(yaml.SafeLoader):
        pass

    for tag in ("tag:yaml.org,2002:opencv-matrix", "!opencv-matrix",
                "tag:yaml.org,2002:opencv-nd-matrix", "!opencv-nd-matrix"):
        _OpenCVLoader.add_constructor(tag, _opencv_matrix)
    return _OpenCVLoader


def _number(token) -> float:
    """A float of a token as OpenCV writes numbers (``.Nan``, ``.Inf``, ``-.Inf`` included)."""
    if isinstance(token, bool):
        raise TypeError(f"{token!r} is not a number")
    if isinstance(token, (int, float)):
        return float(token)
    text = str(token).strip().lower()
    special = {".nan": math.nan, ".inf": math.inf, "+.inf": math.inf, "-.inf": -math.inf}
    return special[text] if text in special else float(text)


def read_camera(path, name: str | None = None) -> Camera:
    """Read a camera from a calibration file.

    Parameters
    ----------
    path : str or Path
        An OpenCV FileStorage YAML or XML file, a ROS camera_info YAML, a Kalibr camchain
        YAML, or graphpose's JSON camera file (see the module docstring); the format is
        told from the content.
    name : str, optional
        Kalibr: the camera of the chain (``cam0`` if None). ROS: checked against the
        file's ``camera_name`` if given. Other formats hold one camera and take no name.

    Returns
    -------
    camera : Camera or Rig
        :class:`~graphpose.camera_models.PinholeCamera`, :class:`~graphpose.camera_models.RadTanCamera`
        or :class:`~graphpose.camera_models.FisheyeCamera`, with the file's image size if it
        gives one; a :class:`graphpose.rig.Rig` for a rig file without ``name`` (a Kalibr
        camchain with ``T_cn_cnm1``, an OpenCV stereo file, graphpose's rig JSON:
        :mod:`graphpose.io.rig_files`), whose camera ``name`` (``cam0``, ``cam1``, ...) picks.

    Raises
    ------
    InputError
        If the file is missing or unreadable, of no known format, lacks a key, holds NaN,
        names a model graphpose does not support, or has a coefficient count that fits no
        model; the message names the file.
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except FileNotFoundError:
        raise InputError(f"calibration file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read calibration file {path}: {exc}") from None
    head = text.lstrip()
    if head.startswith("<"):
        doc = _parse_xml(text, path)
        return _rig_or(doc, path, name) or _from_opencv(doc, path, name)
    if head.startswith("{"):
        try:
            doc = json.loads(text)
        except ValueError:
            doc = _parse_yaml(text, path)  # a YAML flow mapping, perhaps
    else:
        doc = _parse_yaml(text, path)
    if not isinstance(doc, dict):
        raise InputError(f"{path} is not a camera calibration: expected a mapping of keys, "
                         f"got {type(doc).__name__}")
    rig = _rig_or(doc, path, name)
    if rig is not None:
        return rig
    if "model" in doc and "K" in doc:
        _no_name(name, path, "graphpose camera file")
        return camera_from_dict(doc, what=str(path))
    if "distortion_model" in doc and "camera_matrix" in doc:
        return _from_ros(doc, path, name)
    if "camera_matrix" in doc:
        return _from_opencv(doc, path, name)
    if any(isinstance(v, dict) and ("camera_model" in v or "intrinsics" in v)
           for v in doc.values()):
        return _from_kalibr(doc, path, name)
    raise InputError(
        f"{path} is no calibration format graphpose reads (OpenCV FileStorage YAML/XML with "
        f"camera_matrix, ROS camera_info, Kalibr camchain, graphpose JSON with model and K); "
        f"its top-level keys are {sorted(map(str, doc))[:12]}")


def _rig_or(doc, path, name):
    """A rig file's :class:`graphpose.rig.Rig` (or its camera ``name``), None for a camera file
    (:mod:`graphpose.io.rig_files`)."""
    from .rig_files import is_rig_document, rig_from_document

    return rig_from_document(doc, path, name) if is_rig_document(doc) else None


def _parse_yaml(text: str, path: Path):
    lines = text.lstrip().splitlines()
    if lines and lines[0].startswith("%YAML"):
        # OpenCV writes "%YAML:1.0", which is not YAML's directive syntax ("%YAML 1.1").
        lines = lines[1:]
    import yaml

    try:
        return yaml.load("\n".join(lines), Loader=_opencv_loader())
    except yaml.YAMLError as exc:
        raise InputError(f"cannot parse {path} as YAML: {exc}") from None


def _parse_xml(text: str, path: Path) -> dict:
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise InputError(f"cannot parse {path} as XML: {exc}") from None
    if root.tag != "opencv_storage":
        raise InputError(f"{path}: an XML calibration must be OpenCV FileStorage "
                         f"(<opencv_storage>), got <{root.tag}>")
    return _xml_mapping(root)


def _xml_mapping(element) -> dict:
    """OpenCV FileStorage XML as the dict its YAML twin parses to."""
    out = {}
    for child in element:
        if "opencv-matrix" in child.get("type_id", ""):
            out[child.tag] = _OpenCVMatrix({sub.tag: (sub.text or "") for sub in child})
        elif len(child):
            out[child.tag] = _xml_mapping(child)
        else:
            value = (child.text or "").strip()
            try:
                out[child.tag] = int(value)
            except ValueError:
                try:
                    out[child.tag] = _number(value)
                except ValueError:
                    out[child.tag] = value.strip('"')
    return out


def _require(doc: dict, key: str, path, what: str):
    if key not in doc:
        raise InputError(f"{path}: missing key '{key}' ({what})")
    return doc[key]


def _matrix(value, key: str, path, shape=None) -> np.ndarray:
    """A matrix from an ``!!opencv-matrix``, a ROS ``{rows, cols, data}`` or a plain list."""
    if isinstance(value, dict):
        for part in ("rows", "cols", "data"):
            if part not in value:
                raise InputError(f"{path}: {key} lacks '{part}' (a matrix has rows, cols, data)")
        data = value["data"]
        if isinstance(data, str):  # OpenCV XML: whitespace-separated numbers
            data = data.split()
        try:
            rows, cols = int(value["rows"]), int(value["cols"])
            flat = np.array([_number(t) for t in data], dtype=float)
        except (TypeError, ValueError, KeyError):
            raise InputError(f"{path}: {key} must hold rows, cols and numeric data, "
                             f"got {dict(value)!r}"[:300]) from None
        if flat.size != rows * cols:
            raise InputError(f"{path}: {key} is {rows} x {cols} but holds {flat.size} numbers")
        a = flat.reshape(rows, cols)
    else:
        try:
            a = np.array([_number(t) for t in np.ravel(np.array(value, dtype=object))])
        except (TypeError, ValueError):
            raise InputError(f"{path}: {key} must be numbers, got {value!r}"[:300]) from None
    if not np.all(np.isfinite(a)):
        raise InputError(f"{path}: {key} contains NaN or infinite values: {a.ravel().tolist()}")
    if shape is not None:
        if a.size != math.prod(shape):
            raise InputError(f"{path}: {key} must hold {math.prod(shape)} numbers "
                             f"{shape}, got {a.size}")
        a = a.reshape(shape)
    return a


def _size(width, height, path, what: str):
    """(width, height) or None when the file does not say (absent, or ROS's 0)."""
    if width is None and height is None:
        return None
    if isinstance(width, int) and isinstance(height, int) and width == height == 0:
        return None
    if not all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in (width, height)):
        raise InputError(f"{path}: {what} must be positive integers, got {width!r}, {height!r}")
    return width, height


def _trim(d: np.ndarray) -> np.ndarray:
    """OpenCV's 12 or 14 coefficients whose thin-prism and tilt terms are all 0 -> 8."""
    if d.size in (12, 14) and np.all(d[8:] == 0.0):
        return d[:8]
    return d


def _build(cls, path, *args, **kwargs) -> Camera:
    """The camera, with the constructor's complaint (count, skew, ...) prefixed by the file."""
    try:
        return cls(*args, **kwargs)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def _no_name(name, path, what: str) -> None:
    if name is not None:
        raise InputError(f"{path} holds one camera ({what}): name={name!r} selects a "
                         f"camera of a Kalibr camchain only")


def _from_opencv(doc: dict, path: Path, name) -> Camera:
    _no_name(name, path, "OpenCV FileStorage calibration")
    what = "OpenCV FileStorage calibration"
    K = _matrix(_require(doc, "camera_matrix", path, what), "camera_matrix", path, (3, 3))
    d = _matrix(_require(doc, "distortion_coefficients", path, what),
                "distortion_coefficients", path).ravel()
    size = _size(doc.get("image_width"), doc.get("image_height"), path,
                 "image_width and image_height")
    fisheye = doc.get("fisheye_model", 0)
    if fisheye not in (0, 1):
        raise InputError(f"{path}: fisheye_model must be 0 or 1, got {fisheye!r}")
    if fisheye:
        return _build(FisheyeCamera, path, K, d, size)
    if d.size == 0:
        return _build(PinholeCamera, path, K, size)
    return _build(RadTanCamera, path, K, _trim(d), size)


def _from_ros(doc: dict, path: Path, name) -> Camera:
    what = "ROS camera_info"
    if name is not None and name != doc.get("camera_name"):
        raise InputError(f"{path}: asked for camera {name!r}, but this ROS camera_info file "
                         f"is of camera_name {doc.get('camera_name')!r}")
    model = doc["distortion_model"]
    if model not in ROS_MODELS:
        raise InputError(f"{path}: ROS distortion_model {model!r} is not supported; "
                         f"{_SUPPORTED}")
    K = _matrix(doc["camera_matrix"], "camera_matrix", path, (3, 3))
    d = _matrix(_require(doc, "distortion_coefficients", path, what),
                "distortion_coefficients", path).ravel()
    # plumb_bob with no coefficients is a camera without distortion (as ROS's own tools read it).
    counts = {"plumb_bob": (0, 4, 5), "rational_polynomial": (8,), "equidistant": (4,)}[model]
    if model == "rational_polynomial":
        d = _trim(d)
    if d.size not in counts:
        raise InputError(f"{path}: ROS distortion_model {model} takes "
                         f"{' or '.join(map(str, counts))} coefficients, got {d.size}")
    size = _size(doc.get("image_width"), doc.get("image_height"), path,
                 "image_width and image_height")
    if d.size == 0:
        return _build(PinholeCamera, path, K, size)
    return _build(MODELS[ROS_MODELS[model]], path, K, d, size)


def _from_kalibr(doc: dict, path: Path, name) -> Camera:
    cams = [k for k, v in doc.items() if isinstance(v, dict)]
    key = "cam0" if name is None else name
    if key not in doc or not isinstance(doc[key], dict):
        raise InputError(f"{path}: no camera {key!r} in this Kalibr camchain; it holds "
                         f"{', '.join(map(str, cams))}")
    cam = doc[key]
    what = f"Kalibr camchain camera {key}"
    model = _require(cam, "camera_model", path, what)
    if model != "pinhole":
        kind = KALIBR_UNSUPPORTED.get(model, "a model graphpose does not know")
        raise InputError(f"{path}: {key} has Kalibr camera_model {model!r} ({kind}), which is "
                         f"not supported; {_SUPPORTED}")
    distortion = _require(cam, "distortion_model", path, what)
    if distortion not in KALIBR_DISTORTIONS:
        raise InputError(f"{path}: {key} has Kalibr distortion_model {distortion!r}, which is "
                         f"not supported; {_SUPPORTED}")
    fu, fv, pu, pv = _matrix(_require(cam, "intrinsics", path, what), f"{key}.intrinsics",
                             path, (4,))
    K = np.array([[fu, 0.0, pu], [0.0, fv, pv], [0.0, 0.0, 1.0]])
    resolution = cam.get("resolution")
    if resolution is None:
        size = None
    elif isinstance(resolution, list) and len(resolution) == 2:
        size = _size(resolution[0], resolution[1], path, f"{key}.resolution")
    else:
        raise InputError(f"{path}: {key}.resolution must be [width, height], got {resolution!r}")
    model = KALIBR_DISTORTIONS[distortion]
    if model == "pinhole":
        return _build(PinholeCamera, path, K, size)
    d = _matrix(_require(cam, "distortion_coeffs", path, what), f"{key}.distortion_coeffs", path)
    if d.size != 4:
        raise InputError(f"{path}: Kalibr distortion_model {distortion} takes 4 coefficients "
                         f"({key}.distortion_coeffs), got {d.size}")
    return _build(MODELS[model], path, K, d, size)


def camera_from_dict(doc: dict, what: str = "camera") -> Camera:
    """A camera from graphpose's JSON camera mapping (see the module docstring).

    Parameters
    ----------
    doc : dict
        ``{"model": ..., "K": ..., "distortion": ..., "size": [w, h]}``; ``distortion`` may
        be left out for the pinhole, ``size`` always.
    what : str
        The source's name in messages (the file).

    Raises
    ------
    InputError
        If a key is missing, the model unknown, or the values invalid.
    """
    if not isinstance(doc, dict):
        raise InputError(f"{what}: a camera must be a mapping, got {type(doc).__name__}")
    model = _require(doc, "model", what, "graphpose camera: model, K, distortion, size")
    if model not in MODELS:
        raise InputError(f"{what}: camera model {model!r} is not supported; graphpose's camera "
                         f"models are {', '.join(MODELS)}")
    K = _matrix(_require(doc, "K", what, "graphpose camera"), "K", what, (3, 3))
    size = doc.get("size")
    if size is not None:
        if not isinstance(size, list) or len(size) != 2:
            raise InputError(f"{what}: size must be [width, height], got {size!r}")
        size = _size(size[0], size[1], what, "size")
    if model == "pinhole":
        d = _matrix(doc.get("distortion", []), "distortion", what).ravel()
        if d.size and np.any(d != 0.0):
            raise InputError(f"{what}: a pinhole camera has no distortion, got {d.tolist()}")
        camera = _build(PinholeCamera, what, K, size)
    else:
        d = _matrix(_require(doc, "distortion", what, f"a {model} camera"), "distortion", what)
        camera = _build(MODELS[model], what, K, d.ravel(), size)
    return _with_covariance(camera, doc, what)


def _with_covariance(camera: Camera, doc: dict, what: str) -> Camera:
    """The camera with the file's ``covariance`` of its ``parameters``, when it has one.

    ``parameters`` (``{name: value}``) must name the model's parameters in order and agree
    with ``K`` and ``distortion`` (to 1e-12): the covariance belongs to those numbers.
    """
    parameters, cov = doc.get("parameters"), doc.get("covariance")
    if parameters is None and cov is None:
        return camera

    names = list(camera.parameter_names)
    if not isinstance(parameters, dict):
        raise InputError(f"{what}: a covariance needs 'parameters', the mapping of the "
                         f"{camera.model} camera's {', '.join(names)} to their values, got "
                         f"{parameters!r}"[:300])
    if list(parameters) != names:
        raise InputError(f"{what}: parameters must be {', '.join(names)} (a {camera.model} "
                         f"camera's, in this order), got {', '.join(map(str, parameters))}")
    values = _matrix(list(parameters.values()), "parameters", what).ravel()
    mine = camera.parameters
    if not np.allclose(values, mine, rtol=1e-12, atol=0.0):
        raise InputError(f"{what}: parameters {values.tolist()} disagree with K and distortion "
                         f"({mine.tolist()}); the covariance belongs to the parameters")
    if cov is None:
        return camera
    cov = _matrix(cov, "covariance", what, (len(names), len(names)))
    try:
        return dataclasses.replace(camera, covariance=cov)
    except InputError as exc:
        raise InputError(f"{what}: {exc}") from None


def camera_from_ros_info(doc: dict, what: str) -> Camera:
    """A camera from a ROS camera_info mapping (the file's keys: ``camera_matrix``,
    ``distortion_model``, ``distortion_coefficients``, ``image_width``, ``image_height``),
    e.g. a bag's ``sensor_msgs/CameraInfo`` message; ``what`` names it in errors."""
    return _from_ros(doc, what, None)


# ---- writing ------------------------------------------------------------------------

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


def _opencv_matrix_yaml(key: str, a, rows: int, cols: int) -> str:
    data = f" {_floats(a)} " if np.size(a) else ""
    return (f"{key}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n"
            f"   data: [{data}]\n")


def _opencv(camera, name) -> str:
    lines = ["%YAML:1.0", "---"]
    if camera.size is not None:
        lines += [f"image_width: {camera.size[0]}", f"image_height: {camera.size[1]}"]
    lines.append(f"fisheye_model: {1 if camera.model == 'fisheye' else 0}")
    d = camera.distortion
    return ("\n".join(lines) + "\n" + _opencv_matrix_yaml("camera_matrix", camera.K, 3, 3)
            + _opencv_matrix_yaml("distortion_coefficients", d, 1, d.size))


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

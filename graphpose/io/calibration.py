"""Camera calibration files: the ones users have, and graphpose's own JSON.

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
  as well: :mod:`graphpose.io.camera_files`)::

      {"model": "radtan", "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],
       "distortion": [k1, k2, p1, p2, k3], "size": [width, height]}

  with ``model`` one of ``pinhole`` (``distortion`` ``[]`` or absent), ``radtan``,
  ``fisheye``, and ``size`` optional; a calibration's file adds ``"parameters"`` (``{name:
  value}``, the camera's ``parameter_names`` order) and ``"covariance"``
  (P x P, that order), which the camera then carries.

Every problem is an :class:`~graphpose.errors.InputError` naming the file and what is wrong:
a missing key, a NaN, a model graphpose does not support (named), a coefficient count that
fits no model.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from pathlib import Path

import numpy as np

from ..camera_models import MODELS, Camera, FisheyeCamera, PinholeCamera, RadTanCamera
from ..errors import InputError
from .camera_files import FORMATS, camera_to_dict, write_camera  # noqa: F401  (the writers)

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

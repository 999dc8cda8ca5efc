"""Camera models with lens distortion, one object per camera, in OpenCV's definitions.

Three models share one interface (:class:`Camera`):

- :class:`PinholeCamera`: ``[u, v, 1]^T ~ K p_C``, the model of :mod:`graphpose.geometry`
  (skew allowed), and the default: :func:`as_camera` turns a 3 x 3 ``K`` into one;
- :class:`RadTanCamera`: OpenCV's radial-tangential (Brown-Conrady) model, coefficients in
  OpenCV's order ``(k1, k2, p1, p2[, k3[, k4, k5, k6]])`` (4, 5 or 8 of them; 8 is OpenCV's
  rational model); no skew, as in OpenCV;
- :class:`RationalCamera`: the same equations with all eight coefficients as a model of its own
  (``"rational"``, OpenCV's ``CALIB_RATIONAL_MODEL``, mrcal's ``OPENCV8``), what a calibration
  with ``model="rational"`` gives;
- :class:`FisheyeCamera`: OpenCV's fisheye (equidistant Kannala-Brandt) model, ``(k1, k2,
  k3, k4)``, skew allowed (OpenCV's ``alpha = K[0, 1] / fx``), defined beyond 90 degrees
  off the axis.

Conventions are those of :mod:`graphpose.geometry`: pixels ``(u, v)`` with the centre of the
upper-left pixel at (0, 0) (as OpenCV), 2 x N and 3 x N point arrays, camera frame x right,
y down, z forward. The equations are in ``docs/cameras.md``.

Every camera offers

- ``project(P_C)``: camera-frame points (3, N), metres -> pixels (2, N);
- ``project_jacobian(P_C)``: the pixels and the analytic ``d uv / d P_C``, (N, 2, 3);
- ``unproject(uv)``: pixels (2, N) -> unit rays (3, N) in the camera frame (one API for all
  three models: a fisheye sees rays at more than 90 degrees, which normalised coordinates
  ``(x/z, y/z)`` cannot hold). Iterative for the distorting models; the ray reprojects onto
  ``uv`` within :data:`UNPROJECT_TOL` in normalised units, that is within 1e-12 x the focal
  length in pixels (5e-10 px at f = 533 px, as measured over whole images; the tests hold
  it to 1e-9 px). Where the inversion finds no ray on the model's unfolded branch (past
  the radius where a strong radial term folds the image back; past the fisheye's
  ``theta_max``) the column is NaN, never a flipped or folded-back ray;
- ``distort(xy)`` / ``undistort(xy_d)`` on normalised image coordinates, and
  ``distort_pixels`` / ``undistort_pixels`` between this camera's pixels and those of the
  distortion-free pinhole camera with the same ``K`` (:meth:`Camera.pinhole`);
- ``gtsam_calibration()``: the matching GTSAM calibration (Cal3_S2, Cal3DS2, Cal3Fisheye)
  or None where GTSAM has none (a radial-tangential camera with k3..k6 not all zero).

Every camera answers for the intrinsic parameters a calibration estimates (the table of names
is in ``docs/cameras.md``; OpenCV's order, pixels and unitless):

- ``parameter_names`` (a class attribute): their names, ``fx, fy, cx, cy`` and the model's
  coefficients;
- ``parameters``: the (P,) vector;
- ``from_parameters(params, size=None, covariance=None, *, skew=0.0)`` (a classmethod) and
  ``with_parameters(params, covariance=None)``: the camera of those parameters (the latter
  keeps this camera's model, size, and what is not a parameter: the skew, an eight-coefficient
  radial-tangential camera's ``k4, k5, k6``);
- ``parameter_jacobian(P_C)``: ``d uv / d params``, (N, 2, P), analytic, for camera-frame points.

A camera may carry the ``covariance`` of its intrinsic parameters (a calibration's, see
:mod:`graphpose.calibrate`): (P, P) in the order of the class's ``parameter_names``, pixels and
unitless, None (unknown) by default; symmetric positive semi-definite, read-only. It is not
part of equality or the hash: two cameras are equal when they project alike (same model, ``K``,
coefficients, size), so a camera read back from a file format that cannot hold a covariance
(OpenCV, ROS, Kalibr) still equals the calibrated one it was written from.

One module per model: :mod:`~graphpose.camera_models.base` (the interface, the pinhole camera,
:func:`as_camera`, :func:`check_image_size`), :mod:`~graphpose.camera_models.radtan`,
:mod:`~graphpose.camera_models.fisheye`; and the one registry of model names,
:mod:`~graphpose.camera_models.registry` (:data:`MODELS`, :data:`HELD_MODELS`,
:func:`model_class`, :func:`calibration_model`); every name is imported from here.
"""

from .base import MAX_ITERATIONS, UNPROJECT_TOL, Camera, PinholeCamera, as_camera, check_image_size
from .fisheye import FisheyeCamera
from .radtan import RadTanCamera, RationalCamera
from .registry import HELD_MODELS, MODELS, calibration_model, model_class

__all__ = ["Camera", "PinholeCamera", "RadTanCamera", "RationalCamera", "FisheyeCamera", "as_camera", "check_image_size",
           "UNPROJECT_TOL", "MAX_ITERATIONS", "MODELS", "HELD_MODELS", "model_class", "calibration_model"]

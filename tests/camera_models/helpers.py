"""Cameras shared by the camera models' tests: one of each model and coefficient count, and
the pixel grids and points in view they are tested on."""

import numpy as np

from graphpose import FisheyeCamera, PinholeCamera, RadTanCamera
from graphpose.camera_models import RationalCamera

# The left camera of OpenCV's stereo samples (its README), and stronger lenses.
K_SAMPLE = [[533.5, 0.0, 341.6], [0.0, 533.5, 235.2], [0.0, 0.0, 1.0]]
RADTAN = {
    "4": (-0.288, 0.097, 0.001, -0.0003),
    "5": (-0.35, 0.15, 0.001, -0.0003, -0.03),
    "8": (2.5, 1.2, 0.0005, -0.0004, 0.05, 2.8, 2.0, 0.3),  # OpenCV's rational model
}
# A fisheye of about 220 degrees: 190 degrees fit the 1280 x 1024 image vertically, the
# model folds back at about 112 degrees off the axis, inside the image's corners.
K_FISHEYE = [[300.0, 0.9, 640.0], [0.0, 310.0, 512.0], [0.0, 0.0, 1.0]]
FISHEYE = (-0.013, -0.004, 0.0035, -0.001)


def cameras():
    """One camera of each model and coefficient count."""
    out = [PinholeCamera([[500.0, 1.5, 320.0], [0.0, 510.0, 240.0], [0, 0, 1]], (640, 480))]
    out += [RadTanCamera(K_SAMPLE, d, (640, 480)) for d in RADTAN.values()]
    out.append(FisheyeCamera(K_FISHEYE, FISHEYE, (1280, 1024)))
    return out


def normalised(camera, uv):
    """``K^-1 [u, v, 1]``, the first two rows."""
    return np.linalg.solve(camera.K, np.vstack([uv, np.ones(uv.shape[1])]))[:2]


def to_pixels(camera, xy):
    """``K [x, y, 1]``, the first two rows."""
    return (camera.K @ np.vstack([xy, np.ones(xy.shape[1])]))[:2]


def whole_image(camera, step=4.0):
    """Pixels on a grid over the whole image, its border rows and columns included."""
    width, height = camera.size
    us = np.unique(np.r_[np.arange(0.0, width, step), width - 1.0])
    vs = np.unique(np.r_[np.arange(0.0, height, step), height - 1.0])
    u, v = np.meshgrid(us, vs)
    return np.stack([u.ravel(), v.ravel()])


def points_in_view(camera, n, rng, max_angle=None):
    """Camera-frame points on rays up to ``max_angle`` (60 degrees) off the axis, 0.3 to 3 m
    away."""
    max_angle = np.radians(60) if max_angle is None else max_angle
    theta = np.arccos(rng.uniform(np.cos(max_angle), 1.0, n))
    phi = rng.uniform(-np.pi, np.pi, n)
    rays = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    return rays * rng.uniform(0.3, 3.0, n)


# The cameras whose calibration parameters are tested: every model, OpenCV's order.
K = [[533.5, 0.0, 341.6], [0.0, 531.0, 235.2], [0.0, 0.0, 1.0]]
K_SKEW = [[300.0, 0.9, 640.0], [0.0, 310.0, 512.0], [0.0, 0.0, 1.0]]
RATIONAL = (2.5, 1.2, 0.0005, -0.0004, 0.05, 2.8, 2.0, 0.3)
CAMERAS = {
    "pinhole": PinholeCamera([[500.0, 1.5, 320.0], [0.0, 510.0, 240.0], [0, 0, 1]], (640, 480)),
    "radtan4": RadTanCamera(K, (-0.288, 0.097, 0.001, -0.0003), (640, 480)),
    "radtan5": RadTanCamera(K, (-0.35, 0.15, 0.001, -0.0003, -0.03), (640, 480)),
    "rational": RadTanCamera(K, RATIONAL, (640, 480)),
    "rational_model": RationalCamera(K, RATIONAL, (640, 480)),
    "fisheye": FisheyeCamera(K_SKEW, (-0.013, -0.004, 0.0035, -0.001), (1280, 1024)),
}

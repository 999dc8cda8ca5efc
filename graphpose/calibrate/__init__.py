"""Camera calibration from images of the board: intrinsics, lens and their covariance.

One module per idea, beside :mod:`graphpose.camera_params` (the parameter vectors and the
projection's derivative in them, which the camera files and the pose covariance share too):
:mod:`.zhang` (the closed-form start), :mod:`.graph` (the GTSAM graph), :mod:`.lm` (the hand-written
Levenberg-Marquardt that cross-checks it), :mod:`.result` (:class:`Calibration` and the
uncertainty map) and :mod:`.run` (:func:`calibrate`, the steps from images to the result).

``graphpose.calibrate`` is this package, and it is callable: ``graphpose.calibrate(images,
...)`` is :func:`calibrate` (the package and the function share the public name, so the
module object forwards calls; ``from graphpose.calibrate import calibrate`` works as well). Names are imported on first use, so that importing the package loads no GTSAM.
"""

from __future__ import annotations

import importlib
import sys
import types

from ..camera_params import (  # noqa: F401  (re-exported: listed in __all__)
    camera_parameters,
    camera_with_parameters,
    parameter_names,
    projection_jacobian_intrinsics,
)

#: Public name -> the module of this package that defines it (imported lazily, PEP 562).
_EXPORTS = {"calibrate": "run", "calibrate_corners": "run", "Calibration": "result",
            "ProjectionUncertainty": "uncertainty", "calibrate_rig": "rig", "RigCalibration": "rig"}

__all__ = sorted(["camera_parameters", "camera_with_parameters", "parameter_names",
                  "projection_jacobian_intrinsics", *_EXPORTS])


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'graphpose.calibrate' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return __all__


class _CallableModule(types.ModuleType):
    """This package's type: calling it calls :func:`calibrate`."""

    def __call__(self, *args, **kwargs):
        return self.calibrate(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule

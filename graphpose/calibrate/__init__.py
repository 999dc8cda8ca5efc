"""Camera calibration from images of the board: intrinsics, lens and their covariance.

One module per idea, on the cameras of :mod:`graphpose.camera_models` (each answers for its
parameter vector, their names and the projection's derivative in them, which the camera files
and the pose covariance use too): :mod:`.zhang` (the closed-form start), :mod:`.graph` (the GTSAM graph), :mod:`.lm` (the hand-written
Levenberg-Marquardt that cross-checks it), :mod:`.result` (:class:`Calibration` and the
uncertainty map) and :mod:`.run` (:func:`calibrate`, the steps from images to the result).

``graphpose.calibrate`` is this package, and it is callable: ``graphpose.calibrate(images,
...)`` is :func:`calibrate` (the package and the function share the public name, so the
module object forwards calls; ``from graphpose.calibrate import calibrate`` works as well). Names are imported on first use, so that importing the package loads no GTSAM.
"""

from __future__ import annotations

import sys
import types

from .._lazy import lazy_getattr

#: Public name -> the module of this package that defines it (imported lazily, PEP 562).
_EXPORTS = {"calibrate": "run", "calibrate_corners": "run", "Calibration": "result",
            "ProjectionUncertainty": "uncertainty", "calibrate_rig": "rig", "RigCalibration": "rig"}

__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)


def __dir__():
    return __all__


class _CallableModule(types.ModuleType):
    """This package's type: calling it calls :func:`calibrate`."""

    def __call__(self, *args, **kwargs):
        return self.calibrate(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule

"""The one registry of camera models: each model's name (that of the JSON camera file, the
calibration's ``model`` and the command line's ``--model``) and its class.

A class answers for its own parameters (``parameter_names``, ``parameters``,
``from_parameters``, ``with_parameters``, ``parameter_jacobian``: see
:class:`graphpose.camera_models.Camera`); this module only maps names to classes.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .base import PinholeCamera
from .fisheye import FisheyeCamera
from .radtan import RadTanCamera, RationalCamera

#: The camera class of each model name.
MODELS = {"pinhole": PinholeCamera, "radtan": RadTanCamera, "rational": RationalCamera, "fisheye": FisheyeCamera}


#: Calibration models that hold some of a camera model's parameters at 0, not estimated: name ->
#: (the camera model, the parameters held). ``radtan4`` is Kalibr's pinhole-radtan: OpenCV's
#: radial-tangential camera with ``k1, k2, p1, p2`` and ``k3 = 0``.
HELD_MODELS = {"radtan4": ("radtan", ("k3",))}


def model_class(model: str) -> type:
    """The camera class of a model name of :data:`MODELS`.

    Raises
    ------
    InputError
        For a model graphpose does not know (the message names those it knows).
    """
    if not isinstance(model, str) or model not in MODELS:
        raise InputError(f"unknown camera model {model!r}: graphpose's models are "
                         f"{', '.join(MODELS)}")
    return MODELS[model]


def calibration_model(model: str):
    """The camera class of a calibration model and the mask of its parameters held at 0.

    Parameters
    ----------
    model : str
        A model of :data:`MODELS`, or of :data:`HELD_MODELS` (``"radtan4"``).

    Returns
    -------
    cls : type
        The camera class.
    held : (P,) ndarray of bool
        True for each parameter (the class's ``parameter_names`` order) held at 0; all False
        for a model of :data:`MODELS`.

    Raises
    ------
    InputError
        For a model graphpose does not know (the message names those it knows).
    """
    base, names = HELD_MODELS.get(model, (model, ())) if isinstance(model, str) else (model, ())
    if not isinstance(base, str) or base not in MODELS:
        raise InputError(f"unknown camera model {model!r}: graphpose's models are "
                         f"{', '.join([*MODELS, *HELD_MODELS])}")
    cls = MODELS[base]
    return cls, np.isin(cls.parameter_names, names)

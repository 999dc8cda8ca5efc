"""Deprecated module name: :func:`estimate_pose` lives in :mod:`graphpose.estimate` now.

``graphpose.pipeline.estimate_pose`` still works for this release (with a DeprecationWarning);
use ``graphpose.estimate_pose`` or ``graphpose.estimate.estimate_pose``.
"""

from __future__ import annotations

import importlib
import warnings


def __getattr__(name: str):
    value = getattr(importlib.import_module("graphpose.estimate"), name)  # AttributeError as there
    warnings.warn(f"graphpose.pipeline is deprecated: use graphpose.estimate.{name}", DeprecationWarning,
                  stacklevel=2)
    return value

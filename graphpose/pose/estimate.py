"""Deprecated module name: :mod:`graphpose.estimate` holds its names now.

``graphpose.pose.estimate.estimate_pose_from_points`` (and ``PoseEstimate``, ``fit_pose``,
``pose_difference`` ...) still work for this release (with a DeprecationWarning); use
``graphpose.estimate``, or :mod:`graphpose.pose.cross_check` for ``CrossCheck`` and the
agreement bounds.
"""

from __future__ import annotations

import importlib
import warnings


def __getattr__(name: str):
    value = getattr(importlib.import_module("graphpose.estimate"), name)  # AttributeError as there
    warnings.warn(f"graphpose.pose.estimate is deprecated: use graphpose.estimate.{name}", DeprecationWarning,
                  stacklevel=2)
    return value

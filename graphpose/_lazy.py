"""Names a package loads on first use (PEP 562), so that importing it stays light.

``graphpose`` itself, ``graphpose.calibrate``, ``graphpose.batch`` and ``graphpose.track``
each list their public names with the module that defines them and get their module
``__getattr__`` from :func:`lazy_getattr`: ``import graphpose`` does not load GTSAM, and
``graphpose.track.config`` (the command line's options) does not load the detector.
"""

from __future__ import annotations

import importlib
import sys


def lazy_getattr(package: str, exports: dict, packages=()):
    """A module ``__getattr__`` that imports a public name's module on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : dict
        Public name -> the module (relative to ``package``, dotted) that defines it.
    packages : collection of str
        Public names that are subpackages themselves (the subpackage is the value).

    Returns
    -------
    callable
        ``__getattr__(name)``: the value, kept in the package's namespace so that later
        look-ups skip it; AttributeError, as Python's own, for any other name.
    """

    def __getattr__(name: str):
        if name in packages:
            return importlib.import_module(f".{name}", package)  # sets the attribute itself
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{module}", package), name)
        setattr(sys.modules[package], name, value)  # later look-ups skip this function
        return value

    return __getattr__

"""The seed's module name for the saddle fit; the code lives in :mod:`graphpose.detect.saddle`.

Kept so that ``import graphpose.saddle`` and ``from graphpose.saddle import saddle_point``
keep working; it imports neither GTSAM nor anything beyond numpy.
"""

from .detect.saddle import SaddleFit, fit_saddles, saddle_point

__all__ = ["SaddleFit", "fit_saddles", "saddle_point"]

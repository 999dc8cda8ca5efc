"""Build the compiled core: every ``graphpose/**/*.pyx`` becomes an extension module.

Everything else about the package is declared in ``pyproject.toml``; this file exists only
because setuptools takes extension modules from ``setup()``. The build backend runs it at
install (``pip install -e .``, ``pip install .``, ``python -m build``), so a C compiler and the
Python headers are needed there, and nothing after. Each kernel sits beside the Python module it
serves (``graphpose/detect/_refine.pyx`` beside ``refine.py``) and uses typed memoryviews only,
so the build needs Cython but not NumPy's C headers.
"""

from pathlib import Path

from Cython.Build import cythonize
from setuptools import Extension, setup

ROOT = Path(__file__).parent


def _extensions():
    """One extension per ``.pyx`` under ``graphpose/``, named by its dotted path."""
    extensions = []
    for source in sorted((ROOT / "graphpose").rglob("*.pyx")):
        relative = source.relative_to(ROOT).with_suffix("")
        extensions.append(Extension(".".join(relative.parts), [str(source.relative_to(ROOT))]))
    return extensions


setup(
    ext_modules=cythonize(
        _extensions(),
        language_level=3,
        # The kernels index only where their callers have checked the bounds, and divide only by
        # quantities they have tested: C semantics, with no per-access Python checks.
        compiler_directives={
            "boundscheck": False,
            "wraparound": False,
            "cdivision": True,
            "initializedcheck": False,
        },
    ),
)

"""Build the compiled core: every ``graphpose/**/*.pyx`` becomes an extension module.

Everything else about the package is declared in ``pyproject.toml``; this file exists only
because setuptools takes extension modules from ``setup()``. The build backend runs it at
install (``pip install -e .``, ``pip install .``, ``python -m build``), so a C compiler and the
Python headers are needed there, and nothing after. Each kernel sits beside the Python module it
serves (``graphpose/detect/_refine.pyx`` beside ``refine.py``) and uses typed memoryviews only,
so the build needs Cython but not NumPy's C headers.

A kernel already built in the tree for this Python (its ``.so`` newer than its ``.pyx`` and
the ``.pxd`` files beside it) is not compiled again: it is copied where the build wants it. So
adding an extra to a built checkout (``pip install -e ".[plot]"``) takes seconds, not the
minutes of a full compile (about 2 min on two cores); a changed ``.pyx`` is still rebuilt.
"""

import shutil
import sysconfig
from pathlib import Path

from Cython.Build import cythonize
from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).parent
#: The file name ending of an extension module for this Python, e.g. ".cpython-311-x86_64-linux-gnu.so".
SUFFIX = sysconfig.get_config_var("EXT_SUFFIX")


def _extensions():
    """One extension per ``.pyx`` under ``graphpose/``, named by its dotted path."""
    extensions = []
    for source in sorted((ROOT / "graphpose").rglob("*.pyx")):
        relative = source.relative_to(ROOT).with_suffix("")
        extensions.append(Extension(".".join(relative.parts), [str(source.relative_to(ROOT))]))
    return extensions


def _built(extension):
    """The extension's module file already built in the tree and newer than its sources
    (the ``.pyx`` and the ``.pxd`` files beside it), or None."""
    pyx = ROOT / Path(*extension.name.split(".")).with_suffix(".pyx")
    built = pyx.with_name(pyx.stem + SUFFIX)
    if not built.is_file():
        return None
    newest = max(p.stat().st_mtime for p in [pyx, *pyx.parent.glob("*.pxd")])
    return built if built.stat().st_mtime >= newest else None


class BuildExt(build_ext):
    """build_ext that copies a kernel built already (:func:`_built`) instead of compiling it."""

    def build_extension(self, ext):
        built = _built(ext)
        if built is None:
            return super().build_extension(ext)
        target = Path(self.get_ext_fullpath(ext.name))
        if not target.exists() or not target.samefile(built):
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(built, target)
        return None


_ALL = _extensions()
_TO_BUILD = [e for e in _ALL if _built(e) is None]

setup(
    cmdclass={"build_ext": BuildExt},
    ext_modules=[e for e in _ALL if _built(e) is not None] + cythonize(
        _TO_BUILD,
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

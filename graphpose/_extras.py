"""Optional dependencies (the extras of pyproject.toml): imported where used, with the right hint.

``plot`` (matplotlib) and ``batch`` (Dask, pyarrow) are extras: graphpose imports them only
when a feature needs them, and :func:`require` turns a missing one into an
:class:`~graphpose.errors.InputError` whose hint fits how graphpose was installed
(:func:`install_hint`): ``pip install -e ".[plot]"`` in a checkout installed editable (or run
from its folder), ``pip install "graphpose[plot]"`` for a wheel or sdist. The command line
calls :func:`require` before the work starts, so a missing extra is found in seconds, not at
the end of a run.
"""

from __future__ import annotations

import importlib
import json
from pathlib import Path

from .errors import InputError


def checkout_root() -> Path | None:
    """The repository graphpose is imported from (the folder with its pyproject.toml), or None
    when it is an installed copy (a wheel in site-packages)."""
    package = Path(__file__).resolve().parent
    root = package.parent
    if (root / "pyproject.toml").is_file() and (root / "graphpose" / "__init__.py").is_file():
        return root
    return _editable_root()


def _editable_root() -> Path | None:
    """The folder of an editable install (PEP 610 ``direct_url.json``), or None."""
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        text = distribution("graphpose").read_text("direct_url.json")
    except PackageNotFoundError:
        return None
    try:
        doc = json.loads(text or "{}")
    except ValueError:
        return None
    if not (doc.get("dir_info") or {}).get("editable") or not str(doc.get("url", "")).startswith("file://"):
        return None
    return Path(doc["url"][len("file://"):])


def install_hint(extra: str) -> str:
    """The pip command that installs the extra ``extra`` (``"plot"``, ``"batch"``) for this
    installation (see the module docstring)."""
    root = checkout_root()
    if root is None:
        return f'pip install "graphpose[{extra}]"'
    return f'pip install -e ".[{extra}]" (in {root})'


def require(module: str, extra: str, what: str):
    """Import ``module`` (e.g. ``"matplotlib"``) of the extra ``extra``, or raise.

    Parameters
    ----------
    module : str
        The module to import.
    extra : str
        The extra of pyproject.toml that installs it.
    what : str
        What needs it, for the message (``"graphpose track --plot"``).

    Raises
    ------
    InputError
        If ``module`` cannot be imported: ``WHAT needs MODULE (the EXTRA extra): HINT``.
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        raise InputError(f"{what} needs {module.split('.')[0]} (the {extra} extra): {install_hint(extra)}") from None

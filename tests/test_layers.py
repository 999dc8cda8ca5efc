"""The package's imports run one way: the layers of docs/index.md ("Layers"), bottom up.

Every import of a graphpose module by another, at the top of a file or inside a function (a
lazy import is still a dependency), is read from the source with ``ast``. A module may import
from its own layer's group and from the layers below it, never from a layer above; two groups of
one layer may not import each other. The package's facade (``graphpose/__init__.py``) imports
its errors and the lazy loader only and loads every other name on first use, so it sits low;
``__main__``, the course's starter functions and the deprecated module names sit above everything.

Privacy runs by subpackage (:func:`private_imports`): a name with a leading underscore, and
every name of a private module (``graphpose.detect._refine``), is private to the subpackage
that holds it (a top-level module, ``graphpose.rig``, is a unit of its own): no other
subpackage imports it. The package's own top-level private modules (``graphpose._checks``,
``_deprecated``, ``_extras``, ``_lazy``, ``_pixels``, ``_png``, ``_png_filters``) are the package's shared internals:
private to graphpose, not to one subpackage (they are underscored because they are not the
user's API: the validators every public edge calls, the optional-dependency guard, the
compiled pixel kernels), so any graphpose module may import their public names. And
detection has one seam (:func:`detect_seam_imports`): the estimate, calibration and tracking
import from ``graphpose.detect`` itself, only the names of its ``__all__``.
"""

from __future__ import annotations

import pytest
import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "graphpose"

#: Bottom up. Each layer is a tuple of groups; a group is a module or subpackage (dotted,
#: below ``graphpose``), and the most specific group containing a module is its own.
LAYERS = (
    # errors, the compiled view of decoded pixels, the PNG row filters and the packages' lazy
    # names (they import no graphpose module).
    ("errors", "_pixels", "_png_filters", "_lazy"),
    # The facade: it imports its errors and _lazy only; every other name loads on first use (PEP 562).
    # _png: the grey-PNG reader, on the compiled pixels.
    ("_checks", "_deprecated", "_extras", "__init__", "_png"),
    # The robust-estimation rules (a Huber threshold, a sigma from residuals) beside it.
    ("geometry", "robust"),
    ("board", "camera_models", "image"),
    # A rig of cameras and its stereo matrices (on the cameras and their parameters).
    ("rig",),
    ("observations", "io"),
    # Junctions from an image, and a pose from points, know nothing of each other.
    ("detect", "pose", "synth"),
    ("estimate", "pipeline_rig"),
    ("io.records",),
    ("calibrate", "track", "batch", "viz"),
    ("cli",),
    # The course's starter functions (on detect and pose), the deprecated module names.
    ("__main__", "course", "pipeline", "pose.estimate"),
)


def _rank():
    return {group: (level, group) for level, groups in enumerate(LAYERS) for group in groups}


RANK = _rank()


def group_of(module: str) -> str:
    """The most specific group of :data:`LAYERS` that holds ``module`` (dotted, below graphpose)."""
    parts = module.split(".")
    for n in range(len(parts), 0, -1):
        name = ".".join(parts[:n])
        if name in RANK:
            return name
    raise KeyError(module)


def _module_name(path: Path, package: Path = PACKAGE) -> str:
    parts = list(path.relative_to(package).with_suffix("").parts)
    if parts[-1] == "__init__" and len(parts) > 1:
        parts = parts[:-1]
    return ".".join(parts)


def _package(path: Path, root: Path = PACKAGE) -> list:
    """The package (dotted parts below graphpose) that relative imports in ``path`` start from."""
    module = _module_name(path, root)
    if module == "__init__":
        return []
    return module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]


def imports(path: Path, root: Path = PACKAGE):
    """``(imported module below graphpose, line)`` for every graphpose import in ``path``."""
    package = _package(path, root)
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                if node.module:
                    yield ".".join(base + node.module.split(".")), node.lineno
                else:  # ``from .. import x``: a submodule x, or a name of the package itself
                    for alias in node.names:
                        sub = root.joinpath(*base, alias.name)
                        is_module = sub.is_dir() or sub.with_suffix(".py").is_file()
                        yield ".".join(base + [alias.name]) if is_module else ".".join(base) or "__init__", node.lineno
            elif node.module and (node.module == "graphpose" or node.module.startswith("graphpose.")):
                yield node.module.partition(".")[2] or "__init__", node.lineno
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("graphpose."):
                    yield alias.name.partition(".")[2], node.lineno


def violations(package: Path = PACKAGE) -> list:
    """Every import against the layers, as ``"file:line: a (layer i) imports b (layer j)"``."""
    found = []
    for path in sorted(package.rglob("*.py")):
        source = group_of(_module_name(path, package))
        for target, line in imports(path, package):
            dest = group_of(target)
            if dest == source or dest.startswith(source + ".") or source.startswith(dest + "."):
                # within one group (io and io.records are one package but two layers)
                if RANK[dest][0] <= RANK[source][0]:
                    continue
            elif RANK[dest][0] < RANK[source][0]:
                continue
            rel = path.relative_to(package.parent)
            found.append(f"{rel}:{line}: {source} (layer {RANK[source][0]}) imports {target} "
                         f"(layer {RANK[dest][0]})")
    return found


def test_every_module_has_a_layer():
    for path in PACKAGE.rglob("*.py"):
        group_of(_module_name(path))  # KeyError names a module that has none


@pytest.mark.slow  # 0.5 s or so on two idle cores: a render, a calibration or a subprocess
def test_imports_run_one_way():
    assert violations() == []


@pytest.mark.slow  # 0.6 s or so on two idle cores: a render, a calibration or a subprocess
def test_the_check_finds_a_backward_import(tmp_path):
    """A copy of the package with one planted import from a higher layer fails the check."""
    import shutil

    copy = tmp_path / "graphpose"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "*.so", "*.c"))
    geometry = copy / "geometry.py"
    geometry.write_text(geometry.read_text() + "\n\ndef _planted():\n    from .pose import estimate  # noqa: F401\n")
    found = violations(copy)
    assert len(found) == 1 and "geometry.py" in found[0] and "imports pose (layer" in found[0], found


#: A name's unit for privacy: the subpackage (or top-level module) below graphpose.
def _unit(module: str) -> str:
    return module.split(".")[0]


def _binds(init: Path, name: str) -> bool:
    """Does the package ``__init__.py`` at ``init`` bind ``name`` at its top level?"""
    if not init.is_file():
        return False
    for node in ast.parse(init.read_text()).body:
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            if any((a.asname or a.name) == name for a in node.names):
                return True
        elif isinstance(node, (ast.FunctionDef, ast.ClassDef)) and node.name == name:
            return True
        elif isinstance(node, ast.Assign) and any(getattr(t, "id", None) == name for t in node.targets):
            return True
    return False


def imported_names(path: Path, root: Path = PACKAGE):
    """``(module below graphpose, name or None, line)`` for every graphpose import in ``path``:
    the name imported from the module (None where a module itself is imported)."""
    package = _package(path, root)
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                target = base + (node.module.split(".") if node.module else [])
            elif node.module and (node.module == "graphpose" or node.module.startswith("graphpose.")):
                target = node.module.split(".")[1:]
            else:
                continue
            for alias in node.names:
                sub = root.joinpath(*target, alias.name)
                if _binds(root.joinpath(*target, "__init__.py"), alias.name):
                    # ``from ..detect import refine``: the package's own name first (as Python looks it up)
                    yield ".".join(target) or "__init__", alias.name, node.lineno
                elif sub.is_dir() or sub.with_suffix(".py").is_file() or sub.with_suffix(".pyx").is_file():
                    yield ".".join(target + [alias.name]), None, node.lineno
                else:
                    yield ".".join(target) or "__init__", alias.name, node.lineno
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("graphpose."):
                    yield alias.name.partition(".")[2], None, node.lineno


def _private(module: str, name) -> bool:
    """Is ``name`` of ``module`` (or the module itself, for None) private to its subpackage?"""
    parts = module.split(".")
    if name is not None and name.startswith("_") and not (name.startswith("__") and name.endswith("__")):
        return True
    # A top-level private module (graphpose._checks) is the package's shared internals.
    inner = parts[1:] if len(parts) > 1 else []
    return any(p.startswith("_") and p != "__init__" for p in inner)


def private_imports(package: Path = PACKAGE) -> list:
    """Every import of a name private to another subpackage, as ``"file:line: a imports b.name"``."""
    found = []
    for path in sorted(package.rglob("*.py")):
        source = _module_name(path, package)
        for target, name, line in imported_names(path, package):
            if _unit(target) != _unit(source) and _private(target, name):
                rel = path.relative_to(package.parent)
                found.append(f"{rel}:{line}: {source} imports {target}" + (f".{name}" if name else "")
                             + f", private to {_unit(target)}")
    return found


#: The subpackages and modules that use detection through its public seam only.
SEAM_USERS = ("estimate", "pipeline_rig", "calibrate", "track")


def _detect_all(package: Path) -> set:
    tree = ast.parse((package / "detect" / "__init__.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
            return set(ast.literal_eval(node.value))
    return set()


def detect_seam_imports(package: Path = PACKAGE) -> list:
    """Every import by :data:`SEAM_USERS` of detection other than a name of ``graphpose.detect.__all__``."""
    public = _detect_all(package)
    found = []
    for path in sorted(package.rglob("*.py")):
        source = _module_name(path, package)
        if _unit(source) not in SEAM_USERS:
            continue
        for target, name, line in imported_names(path, package):
            if _unit(target) == "detect" and not (target == "detect" and name in public):
                rel = path.relative_to(package.parent)
                found.append(f"{rel}:{line}: {source} imports {target}" + (f".{name}" if name else "")
                             + ", not a name of graphpose.detect.__all__")
    return found


@pytest.mark.slow  # 0.8 s or so on two idle cores: a render, a calibration or a subprocess
def test_no_subpackage_imports_another_ones_private_names():
    assert private_imports() == []


def test_pipeline_calibration_and_tracking_use_detections_public_seam():
    assert detect_seam_imports() == []


def _copy(tmp_path):
    import shutil

    copy = tmp_path / "graphpose"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "*.so", "*.c"))
    return copy


@pytest.mark.slow  # 0.7 s or so on two idle cores: a render, a calibration or a subprocess
def test_the_check_finds_a_private_import_across_subpackages(tmp_path):
    """A copy of the package with a planted import of another subpackage's private name (and
    one of a private module's name) fails the check; within a subpackage, and from the
    package's shared top-level internals, they pass."""
    copy = _copy(tmp_path)
    lm = copy / "calibrate" / "lm.py"
    lm.write_text(lm.read_text() + "\n\ndef _planted():\n    from ..detect.junctions import _judge  # noqa: F401\n"
                  "    from ..pose._homography import nothing  # noqa: F401\n"
                  "    from .run import _mad_sigma  # noqa: F401\n    from .._checks import check_number  # noqa: F401\n")
    found = private_imports(copy)
    assert len(found) == 2, found
    assert "calibrate.lm imports detect.junctions._judge, private to detect" in found[0]
    assert "calibrate.lm imports pose._homography.nothing, private to pose" in found[1]


def test_the_check_finds_an_import_past_detections_seam(tmp_path):
    copy = _copy(tmp_path)
    frontend = copy / "track" / "frontend.py"
    frontend.write_text(frontend.read_text() + "\n\ndef _planted():\n    from ..detect.search import median  # noqa: F401\n"
                        "    from ..detect import refine  # noqa: F401\n")
    found = detect_seam_imports(copy)
    assert len(found) == 1 and "track.frontend imports detect.search.median, not a name" in found[0], found

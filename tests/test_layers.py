"""The package's imports run one way: the layers of docs/index.md ("Layers"), bottom up.

Every import of a graphpose module by another, at the top of a file or inside a function (a
lazy import is still a dependency), is read from the source with ``ast``. A module may import
from its own layer's group and from the layers below it, never from a layer above; two groups of
one layer may not import each other. The package's facade (``graphpose/__init__.py``) imports
its errors and the lazy loader only and loads every other name on first use, so it sits low; ``__main__`` and the
old top-level ``saddle`` module sit above everything.
"""

from __future__ import annotations

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
    ("_checks", "_extras", "__init__", "_png"),
    # The robust-estimation rules (a Huber threshold, a sigma from residuals) beside it.
    ("geometry", "robust"),
    ("board", "camera_models", "image"),
    ("camera_params",),
    # A rig of cameras and its stereo matrices (on the cameras and their parameters).
    ("rig",),
    ("observations", "io"),
    # Junctions from an image, and a pose from points, know nothing of each other.
    ("detect", "pose", "synth"),
    ("pipeline", "pipeline_rig"),
    ("io.records",),
    ("calibrate", "track", "batch", "viz"),
    ("cli",),
    ("saddle", "__main__"),
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


def imports(path: Path, root: Path = PACKAGE):
    """``(imported module below graphpose, line)`` for every graphpose import in ``path``."""
    module = _module_name(path, root)
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    if module == "__init__":
        package = []
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


def test_imports_run_one_way():
    assert violations() == []


def test_the_check_finds_a_backward_import(tmp_path):
    """A copy of the package with one planted import from a higher layer fails the check."""
    import shutil

    copy = tmp_path / "graphpose"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "*.so", "*.c"))
    geometry = copy / "geometry.py"
    geometry.write_text(geometry.read_text() + "\n\ndef _planted():\n    from .pose import estimate  # noqa: F401\n")
    found = violations(copy)
    assert len(found) == 1 and "geometry.py" in found[0] and "imports pose (layer" in found[0], found

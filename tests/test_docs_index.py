"""docs/index.md's module table is the one map of the package, and every dotted name the
documentation gives imports (issue 26): a module added without a row, or a name renamed under
the docs, fails here rather than in a reader's hands."""

import importlib
import pkgutil
import re

import pytest

import graphpose
from tests.conftest import REPO

PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
#: A dotted name: graphpose.a.b (a file path has slashes, not dots).
DOTTED = re.compile(r"(?<![\w/.-])graphpose(?:\.[A-Za-z_]\w*)+")
FROM_IMPORT = re.compile(r"from (graphpose(?:\.\w+)*) import (\([^)]*\)|[\w, ]+)")


def _modules():
    """Every module and package of graphpose, by dotted name (compiled kernels and
    ``__main__`` aside: they are named beside the module they serve)."""
    names = ["graphpose"]
    for info in pkgutil.walk_packages(graphpose.__path__, "graphpose."):
        last = info.name.rsplit(".", 1)[1]
        if last == "__main__" or (last.startswith("_") and not info.ispkg and _compiled(info)):
            continue
        names.append(info.name)
    return names


def _compiled(info) -> bool:
    spec = info.module_finder.find_spec(info.name.rsplit(".", 1)[1])
    return spec is not None and spec.origin is not None and not spec.origin.endswith(".py")


def _table(text: str, heading: str) -> list:
    """The rows of the first table after ``heading`` (its consecutive lines starting with |)."""
    rows, started = [], False
    for line in text.split(heading, 1)[1].splitlines():
        if line.startswith("|"):
            rows.append(line)
            started = True
        elif started:
            break
    return rows


def _listed(name: str, rows) -> bool:
    """``name`` is in a row as itself, or as a short name beside its package's full name
    (``graphpose.detect`` (``grid``, ``saddle``))."""
    for row in rows:
        if f"`{name}`" in row or f"`{name}." in row:  # itself, or a package by its modules
            return True
        parent, last = name.rsplit(".", 1)
        if f"`{last}`" in row and re.search(rf"`{re.escape(parent)}(\.\w+)?`", row):
            return True
    return False


def test_every_module_of_the_package_is_in_docs_index_module_table():
    rows = _table((REPO / "docs" / "index.md").read_text(), "## The package")
    assert len(rows) > 20
    missing = [name for name in _modules() if name != "graphpose" and not _listed(name, rows)]
    assert not missing, f"modules missing from docs/index.md's table (## The package): {missing}"


def test_the_readme_links_to_the_one_module_table_and_has_none_of_its_own():
    readme = (REPO / "README.md").read_text()
    assert "docs/index.md#the-package" in readme
    assert "| step | module |" not in readme


def _resolve(dotted: str):
    """Import the longest importable module prefix of ``dotted`` and get the rest as attributes."""
    parts = dotted.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ModuleNotFoundError:
            continue
        for attr in parts[k:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(dotted)


def _names():
    found = {}
    for page in PAGES:
        text = page.read_text()
        for name in DOTTED.findall(text):
            found.setdefault(name, page.name)
        for module, names in FROM_IMPORT.findall(text):
            for item in names.strip("()").split(","):
                name = item.split()[0] if item.split() else ""
                if name:
                    found.setdefault(f"{module}.{name}", page.name)
    return sorted(found.items())


NAMES = _names()


def test_the_docs_name_many_things():
    assert len(NAMES) > 50


def test_every_dotted_name_in_the_docs_imports():
    broken = []
    for name, page in NAMES:
        try:
            _resolve(name)
        except (ImportError, AttributeError) as exc:
            broken.append(f"{page}: {name} ({type(exc).__name__})")
    assert not broken, "names in the docs that do not import:\n" + "\n".join(broken)


@pytest.mark.parametrize("stale", ["graphpose.pose.estimate_pose", "graphpose.io.read_tum",
                                   "graphpose.viz.draw_overlay", "graphpose.detect.extract_junctions",
                                   "graphpose.synth.render_sequence"])
def test_the_readmes_old_names_are_gone_or_import(stale):
    if stale in dict(NAMES):
        _resolve(stale)


def test_the_readmes_command_table_lists_every_command():
    from graphpose.cli import build_parser

    rows = _table((REPO / "README.md").read_text(), "## Command line")
    parser = build_parser()
    commands = {sub.prog.split()[-1] for sub in
                next(a for a in parser._actions if a.dest == "command").choices.values()}
    assert {"estimate", "track", "render-sequence", "batch", "calibrate"} <= commands
    missing = [c for c in sorted(commands) if not any(f"`graphpose {c} " in row or f"`graphpose {c}`" in row
                                                      for row in rows)]
    assert not missing, f"README.md's command table leaves out: {missing}"

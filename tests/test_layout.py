"""Tests mirror modules (issue 25, item 8): every module ``graphpose/<sub>/<name>.py`` has its own
test file ``tests/<sub>/test_<name>.py`` holding the tests of that module, a leading underscore
dropped (``graphpose/_extras.py`` -> ``tests/test_extras.py``). A module without one is listed
by name, with the file it lacks."""

from __future__ import annotations

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: Modules without a mirror file of their own, each with its reason.
EXEMPT = {
    # The deprecated shims: old names kept for one release, nothing but a DeprecationWarning in
    # front of their new homes; their tests (each old name still answers, with the warning) are
    # together in tests/test_deprecated.py, beside the other deprecated names.
    "graphpose/pipeline.py": "deprecated shim, tested in tests/test_deprecated.py",
    "graphpose/pose/estimate.py": "deprecated shim, tested in tests/test_deprecated.py",
}


def mirror_of(module: Path) -> Path:
    """The test file of ``module``, a path relative to the repository: ``graphpose/a/_b.py`` ->
    ``tests/a/test_b.py``."""
    parts = module.parts
    assert parts[0] == "graphpose" and module.suffix == ".py", module
    return Path("tests", *parts[1:-1], "test_" + module.stem.lstrip("_") + ".py")


def missing_mirrors(repo: Path, exempt=EXEMPT) -> list[tuple[str, str]]:
    """``(module, test file)`` of every module under ``repo/graphpose`` (``.py``, not
    ``__init__`` or ``__main__``, not in ``exempt``) whose test file does not exist, sorted."""
    missing = []
    for path in sorted((repo / "graphpose").rglob("*.py")):
        module = path.relative_to(repo)
        if path.stem in ("__init__", "__main__") or module.as_posix() in exempt:
            continue
        test = mirror_of(module)
        if not (repo / test).is_file():
            missing.append((module.as_posix(), test.as_posix()))
    return missing


def test_mirror_names():
    assert mirror_of(Path("graphpose/_extras.py")) == Path("tests/test_extras.py")
    assert mirror_of(Path("graphpose/synth/raster.py")) == Path("tests/synth/test_raster.py")
    assert mirror_of(Path("graphpose/io/sources/bag.py")) == Path("tests/io/sources/test_bag.py")


def test_missing_mirrors_finds_a_missing_file_and_passes_when_all_exist(tmp_path):
    # A tree of its own: the check is not trivially true, and its exemptions are exactly these.
    for name in ("__init__.py", "__main__.py", "_extras.py", "pipeline.py", "sub/__init__.py", "sub/mod.py"):
        (tmp_path / "graphpose" / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "graphpose" / name).touch()
    (tmp_path / "tests" / "sub").mkdir(parents=True)
    (tmp_path / "tests" / "test_extras.py").touch()
    assert missing_mirrors(tmp_path, {"graphpose/pipeline.py": "shim"}) == [
        ("graphpose/sub/mod.py", "tests/sub/test_mod.py")]
    assert missing_mirrors(tmp_path, {}) == [("graphpose/pipeline.py", "tests/test_pipeline.py"),
                                             ("graphpose/sub/mod.py", "tests/sub/test_mod.py")]
    (tmp_path / "tests" / "sub" / "test_mod.py").touch()
    assert missing_mirrors(tmp_path, {"graphpose/pipeline.py": "shim"}) == []


def test_every_module_has_its_mirror_test_file():
    for module in EXEMPT:
        assert (REPO / module).is_file(), f"{module} is exempt but gone: drop it from EXEMPT"
    missing = missing_mirrors(REPO)
    for module, test in missing:
        print(f"{module}: no {test}")
    assert not missing, f"{len(missing)} modules without their test file: " + ", ".join(m for m, _ in missing)

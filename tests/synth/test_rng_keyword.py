"""rng is a keyword everywhere (issue 18): every signature in the package takes it after ``*``."""

import pytest
import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "graphpose"


@pytest.mark.slow  # 0.6 s or so on two idle cores: a render, a calibration or a subprocess
def test_rng_is_keyword_only_in_every_signature():
    # Read from the source (ast): every function of the package that takes an rng takes it as a
    # keyword, apart from a converter whose one argument it is.
    offenders = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                positional = [a.arg for a in node.args.posonlyargs + node.args.args if a.arg not in ("self", "cls")]
                if "rng" in positional and positional != ["rng"]:
                    offenders.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno} {node.name}")
    assert offenders == []

"""rng is a keyword everywhere; the old positional calls of the synth functions still work and
draw the same numbers."""

import ast
from pathlib import Path

import numpy as np
import pytest

from graphpose import Board
from graphpose.synth._rng import is_seed
from graphpose.synth.poses import loose_polygon, perturb_pose, random_pose
from graphpose.synth.render import render
from graphpose.synth.scenes import random_scene
from graphpose.synth.sequence import HandHeldMotion
from tests.conftest import PROJECT_K as K

PACKAGE = Path(__file__).resolve().parents[2] / "graphpose"


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


def test_old_positional_calls_draw_the_same():
    T_new = random_pose(K, Board(), rng=3)
    np.testing.assert_array_equal(random_pose(3, K, Board()), T_new)
    np.testing.assert_array_equal(perturb_pose(np.random.default_rng(4), T_new),
                                  perturb_pose(T_new, rng=np.random.default_rng(4)))
    r = render(K, T_new, noise_sigma=0.0, rng=0)
    np.testing.assert_array_equal(loose_polygon(r, 5), loose_polygon(r, rng=5))
    a, b = random_scene(6, K), random_scene(K, rng=6)
    np.testing.assert_array_equal(a.image, b.image)
    m1, m2 = HandHeldMotion(np.random.default_rng(7), K, Board(), (640, 480), 5.0), \
        HandHeldMotion(K, Board(), (640, 480), 5.0, rng=7)
    np.testing.assert_array_equal(m1(1.0), m2(1.0))


@pytest.mark.parametrize("value, seed", [(None, True), (3, True), (np.int64(3), True), (np.random.default_rng(), True),
                                         (np.random.SeedSequence(1), True), (True, False), (K, False), (3.0, False)])
def test_what_counts_as_a_seed(value, seed):
    assert is_seed(value) is seed

"""Inputs are checked once, at the public edge: one estimate_pose call on a bundled image runs
check_observations and check_K (and check_transform, check_image, check_image_size) at most once
each (docs/index.md, graphpose/_checks.py).

Every module that holds one of the two functions (imported by name, or its own definition,
which its module's other functions call) gets a counting wrapper that calls the original, so
that a call from anywhere is counted, whichever name it goes through.
"""

import sys

import pytest

import graphpose
from graphpose.image import read_image
from graphpose.io.cases import bundled_cases_path, load_cases
from graphpose.estimate import estimate_pose

CHECKS = ("check_observations", "check_K", "check_transform", "check_image", "check_image_size")


@pytest.fixture(scope="module")
def bundled():
    doc = load_cases(bundled_cases_path())
    case = doc.cases[0]
    return doc, case, read_image(case.image)


def _count(monkeypatch):
    """Wrap every module-level reference to the checks; returns {name: [calls]}."""
    calls = {name: [] for name in CHECKS}
    for module in list(sys.modules.values()):
        if not getattr(module, "__name__", "").startswith("graphpose"):
            continue
        for name in CHECKS:
            original = module.__dict__.get(name)
            if original is None or not callable(original):
                continue

            def counting(*args, _original=original, _name=name, _module=module.__name__, **kwargs):
                calls[_name].append(_module)
                return _original(*args, **kwargs)

            monkeypatch.setattr(module, name, counting)
    return calls


def test_every_holder_of_the_checks_is_wrapped(monkeypatch):
    # The counting reaches the checks' own modules and their importers (a rename or a new
    # holder would otherwise escape the count).
    import graphpose.estimate  # noqa: F401  (loads the pose modules)
    import graphpose.pose.graph  # noqa: F401

    _count(monkeypatch)
    wrapped = {m.__name__ for m in sys.modules.values() if getattr(m, "__name__", "").startswith("graphpose")
               and getattr(m.__dict__.get("check_observations"), "__name__", "") == "counting"}
    assert {"graphpose.observations", "graphpose.estimate"} <= wrapped, wrapped


@pytest.mark.parametrize("with_guess", [True, False], ids=["guess", "homography start"])
@pytest.mark.parametrize("robust", [False, True], ids=["plain", "robust"])
def test_one_estimate_checks_each_input_once(bundled, monkeypatch, with_guess, robust):
    doc, case, image = bundled
    camera = doc.camera.K  # a K (array): the pipeline makes the camera, which checks K
    calls = _count(monkeypatch)
    estimate = estimate_pose(image, camera, bounds=case.bounds, board=doc.board,
                             guess=case.guess_T_WC if with_guess else None,
                             robust=robust)
    assert estimate.ok
    for name in CHECKS:
        assert len(calls[name]) <= 1, f"{name} ran {len(calls[name])} times, from {calls[name]}"


def test_the_count_sees_a_repeated_check(bundled, monkeypatch):
    """The count is not blind: the public points-level estimate after the image-level one
    checks again (its own edge), and the wrapper counts that."""
    doc, case, image = bundled
    calls = _count(monkeypatch)
    estimate = estimate_pose(image, doc.camera, bounds=case.bounds, board=doc.board, guess=case.guess_T_WC)
    before = len(calls["check_observations"])
    graphpose.estimate_pose_from_points(estimate.junctions.points, doc.board.world_points(), doc.camera,
                                        mask=estimate.junctions.trusted)
    assert len(calls["check_observations"]) >= before + 1

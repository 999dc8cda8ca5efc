"""Shared fixtures: the real ROB501 images beside the checkout, skipped only when absent."""

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
REAL_DIR = Path(os.environ.get("GRAPHPOSE_ROB501", REPO.parent / "shared" / "data" / "rob501"))


@pytest.fixture(scope="session")
def real_cases():
    """The parsed real case file (:class:`graphpose.io.CaseFile`)."""
    from graphpose.io import load_cases

    if not (REAL_DIR / "cases.json").is_file():
        pytest.skip(f"real data folder {REAL_DIR} is absent")
    return load_cases(REAL_DIR / "cases.json")


@pytest.fixture(scope="session")
def real_images(real_cases):
    """List of (case, grey float image) for the six real images."""
    from graphpose.io import read_image

    return [(case, read_image(case.image)) for case in real_cases.cases]

"""Frames shared by the frame sources' tests (videos, bags, image files)."""

import numpy as np
import pytest


@pytest.fixture(scope="module")
def frames():
    """Twelve 8-bit frames of a moving pattern (distinct, so a wrong frame is seen), 64 x 48."""
    rng = np.random.default_rng(3)
    base = rng.integers(0, 256, (48, 64)).astype(np.uint8)
    return np.stack([np.roll(base, 3 * k, axis=1) for k in range(12)])

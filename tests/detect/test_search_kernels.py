"""The noise estimate's compiled kernels against plain NumPy written here, on small inputs.

(The search's, lattice's and identification's kernels are tested in their modules' files:
tests/detect/test_search.py, test_lattice.py, test_identify.py.) Each reference below is the
loop a kernel replaced, written out the plain way.
"""

import numpy as np
import pytest


def test_the_grey_range_of_an_eight_bit_image_is_the_partitions():
    from graphpose.detect.noise import grey_range

    rng = np.random.default_rng(11)
    for trial in range(200):
        image = rng.integers(0, 256, tuple(rng.integers(1, 60, 2))).astype(np.uint8)
        if trial % 3 == 0:
            image = image[::2, 1:]  # a strided view, as a board's crop is
        stride, tail = int(rng.integers(1, 5)), float(rng.choice([0.0, 1.0, 5.0, 25.0, 50.0, 70.0]))
        values = image[::stride, ::stride].ravel()
        if values.size == 0:
            assert grey_range(image, stride=stride, tail=tail) == 0.0
            continue
        k = np.rint(np.array([tail, 100.0 - tail]) / 100.0 * (values.size - 1)).astype(int)
        lo, hi = np.partition(values, k)[k]
        assert grey_range(image, stride=stride, tail=tail) == float(hi) - float(lo), trial
        assert grey_range(image.astype(float), stride=stride, tail=tail) == float(hi) - float(lo), trial


def immerkaer_reference(image, s):
    """|Immerkaer's mask| at every s-th row and column, float32, the plain way."""
    a = image.astype(np.float32)
    h, w = a.shape
    out = []
    for i in range(0, h - 2, s):
        for j in range(0, w - 2, s):
            p = a[i:i + 3, j:j + 3]
            out.append(abs(p[0, 0] - 2 * p[0, 1] + p[0, 2] - 2 * (p[1, 0] - 2 * p[1, 1] + p[1, 2])
                           + p[2, 0] - 2 * p[2, 1] + p[2, 2]))
    return np.array(out, dtype=np.float32)


@pytest.mark.parametrize("s", [1, 3, 4])
def test_the_noise_median_of_an_eight_bit_image_is_the_partitions(s):
    from graphpose.detect.noise import _MAD_TO_SIGMA, estimate_noise

    rng = np.random.default_rng(s)
    for image in (rng.integers(0, 256, (41, 57)).astype(np.uint8), np.full((9, 9), 7, np.uint8),
                  (rng.uniform(size=(30, 40)) > 0.5).astype(np.uint8) * 255):
        r = immerkaer_reference(image, s)
        median = np.partition(r, r.size // 2)[r.size // 2]
        assert estimate_noise(image, stride=s) == pytest.approx(float(median) * _MAD_TO_SIGMA / 6.0, rel=1e-15)
        # The float path (the same responses, partitioned) agrees with the counted one.
        assert estimate_noise(image.astype(np.float32), stride=s) == estimate_noise(image, stride=s)



"""graphpose.viz.font: the overlay's 5 x 9 bitmap glyphs."""

import numpy as np

from graphpose.viz.font import glyph


def test_font():
    assert glyph("0").shape == (9, 5)
    assert glyph("g")[7:].any() and not glyph("A")[7:].any()  # descenders below the baseline
    np.testing.assert_array_equal(glyph("\u20ac"), glyph("?"))
    assert not glyph(" ").any()

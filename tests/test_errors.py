"""graphpose.errors: one base class for every error graphpose raises on purpose, and what the
board refusals carry."""

import pytest

from graphpose.errors import (
    BoardMismatchError,
    BoardNotFoundError,
    ConvergenceError,
    DegenerateGeometryError,
    GraphposeError,
    InputError,
    SaddleError,
)


@pytest.mark.parametrize("error", [InputError, SaddleError, BoardNotFoundError, BoardMismatchError,
                                   DegenerateGeometryError, ConvergenceError])
def test_every_error_is_a_graphpose_error(error):
    assert issubclass(error, GraphposeError)


@pytest.mark.parametrize("error, value_error", [(InputError, True), (SaddleError, True),
                                               (DegenerateGeometryError, True), (BoardNotFoundError, False),
                                               (ConvergenceError, False)])
def test_bad_numbers_are_value_errors_and_a_missing_board_is_not(error, value_error):
    assert issubclass(error, ValueError) == value_error


def test_a_missing_board_says_how_much_it_saw():
    plain = BoardNotFoundError("no board")
    assert str(plain) == "no board" and plain.junctions_seen == 0 and plain.two_boards is False
    seen = BoardNotFoundError("two", junctions_seen=54.0, two_boards=1)
    assert seen.junctions_seen == 54 and isinstance(seen.junctions_seen, int) and seen.two_boards is True


def test_a_board_of_another_size_is_a_missing_board_that_names_what_it_saw():
    error = BoardMismatchError("9 x 6, not 8 x 6", found=(9.0, 6.0), size_px=231, junctions_seen=54)
    assert isinstance(error, BoardNotFoundError)
    assert error.found == (9, 6) and all(isinstance(n, int) for n in error.found)
    assert error.size_px == 231.0 and isinstance(error.size_px, float) and error.junctions_seen == 54
    assert error.two_boards is False
    assert BoardMismatchError("partial").found is None

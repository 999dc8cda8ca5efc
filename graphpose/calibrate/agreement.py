"""Do the views agree with the board spec? A calibration refuses a spec its images contradict.

A wrong spec does not always fail loudly: with an 8 x 6 spec, OpenCV's samples of a 9 x 6
board are each refused ("found a 9 x 6 board"), but a small picture of a board in the
background of a few of them may be taken for the spec, and a camera of fx 68 px calibrated
from those. :func:`check_agreement` looks at the first pass's searches together and refuses
(:class:`graphpose.errors.BoardMismatchError`, exit code 1 on the command line, no camera file)
when

- images showing a board of another size (:class:`~graphpose.errors.BoardMismatchError`
  from the search) are as many as those where the spec's board was found, or the board is
  found in fewer than half the images while others show another board;
- the boards found are far smaller in the image (under :data:`SMALLER` of the median size)
  than the other board the other images show.

The refusal names what was found: the size of the other board, in how many images, which
ones, and how large each was.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from ..board import Board
from ..errors import BoardMismatchError

#: Boards found whose median size in the image is under this fraction of the median size of
#: the boards of another size the other images show are not the board photographed.
SMALLER = 0.5


def board_size_px(found) -> float:
    """A found board's size in the image, pixels (:attr:`graphpose.errors.BoardMismatchError.size_px`):
    its median step times the square root of its seen junctions."""
    return float(np.median(found.step_px[found.seen])) * float(np.sqrt(found.seen.sum()))


def check_agreement(board: Board, labels, found: dict, mismatched: dict) -> None:
    """Refuse a board spec the views contradict (see the module docstring).

    Parameters
    ----------
    board : Board
        The spec.
    labels : sequence of str
        The images' names, one per image.
    found : dict
        ``{image index: size_px}`` of the images where the spec's board was found
        (:func:`board_size_px`).
    mismatched : dict
        ``{image index: BoardMismatchError}`` of the images whose search saw a board of
        another size.

    Raises
    ------
    BoardMismatchError
        Naming the board the other images show, how many and which, and the sizes.
    """
    if not mismatched:
        return
    n = len(labels)
    other = Counter(e.found for e in mismatched.values() if e.found is not None).most_common(1)
    seen = other[0][0] if other else None
    what = f"a {seen[0]} x {seen[1]} board" if seen else "a board of another size"
    names = ", ".join(labels[i] for i in sorted(mismatched)[:4]) + (" ..." if len(mismatched) > 4 else "")
    spec = f"{board.cols} x {board.rows}"
    head = (f"the images disagree with the {spec} board spec: {len(mismatched)} of {n} show {what} "
            f"({names})")
    hint = f"; is the board {seen[0]} x {seen[1]}? (inner junctions along a row and down a column)" if seen else ""
    other_px = float(np.median([e.size_px for e in mismatched.values()]))
    if len(mismatched) >= len(found) or 2 * len(found) < n:
        raise BoardMismatchError(f"{head}; the spec's board is found in {len(found)}{hint}", found=seen,
                                 size_px=other_px)
    ours_px = float(np.median(list(found.values())))
    if ours_px < SMALLER * other_px:
        raise BoardMismatchError(
            f"{head}, about {other_px:.0f} px across, while the {len(found)} boards found for the spec are "
            f"about {ours_px:.0f} px across: too small to be the board photographed{hint}", found=seen,
            size_px=other_px)

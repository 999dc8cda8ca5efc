"""graphpose.io.sources.base: what every recording does with its reader (decode on, or seek),
its frames in order, and a recording that ends before its index said."""

import numpy as np
import pytest

from graphpose.errors import InputError
from graphpose.io.sources.base import FORWARD_DECODE, BrokenRecordingError, Frame, Recording


class Counted(Recording):
    """A recording of ``n`` frames (frame k is filled with k) whose reader gives out after
    ``readable`` frames; it counts where it was opened and how many frames it decoded."""

    kind = "counted"

    def __init__(self, n, readable=None, damage=""):
        super().__init__("counted.rec", 0.5 * np.arange(n))
        self.readable = n if readable is None else readable
        self.damage = damage
        self.opened, self.decoded = [], 0

    def _open_at(self, k):
        self.opened.append(k)
        for j in range(k, self.readable):
            self.decoded += 1
            yield Frame(j, float(self.timestamps[j]), np.full((2, 3), j, np.uint16))


def test_frames_in_order_open_the_reader_once_and_decode_each_frame_once():
    rec = Counted(7)
    got = list(rec.frames())
    assert [f.index for f in got] == list(range(7)) and rec.opened == [0] and rec.decoded == 7
    assert [f.timestamp for f in got] == [0.5 * k for k in range(7)]
    assert all(f.image.dtype == np.uint16 and (f.image == f.index).all() for f in got)
    assert [f.index for f in Counted(10).frames(start=1, stop=8, step=3)] == [1, 4, 7]
    assert len(rec) == 7 and rec.label(3) == "counted.rec#3" and str(rec.path(3)) == "counted.rec"


def test_a_frame_behind_is_a_seek_and_a_frame_a_little_ahead_is_decoded_on():
    rec = Counted(FORWARD_DECODE + 20)
    assert rec.read(2).index == 2 and rec.opened == [2]
    assert rec.read(5).index == 5 and rec.opened == [2] and rec.decoded == 4  # 3 and 4 decoded on, not seeked
    assert rec.read(1).index == 1 and rec.opened == [2, 1]  # behind: reopened there
    far = 2 + FORWARD_DECODE + 1  # the next frame is 2: this is one beyond FORWARD_DECODE ahead, a seek
    assert rec.read(far).index == far and rec.opened == [2, 1, far]
    assert (rec.read(far + 1).image == far + 1).all() and rec.opened == [2, 1, far]  # the next: read on
    # Exactly FORWARD_DECODE ahead is still decoded on.
    rec = Counted(FORWARD_DECODE + 20)
    rec.read(0)
    assert rec.read(1 + FORWARD_DECODE).index == 1 + FORWARD_DECODE and rec.opened == [0]
    assert rec.decoded == 2 + FORWARD_DECODE


@pytest.mark.parametrize("k", [-1, 4])
def test_a_frame_outside_the_recording_is_refused(k):
    with pytest.raises(InputError, match=rf"frame {k} is not in counted.rec \(4 frames\)"):
        Counted(4).read(k)


def test_a_reader_that_ends_early_breaks_at_the_first_missing_frame():
    rec = Counted(6, readable=4)
    got = []
    with pytest.raises(BrokenRecordingError, match=r"counted.rec ended at frame 4 of the 6 its index counted "
                                                   r"\(t = 2.000 s\)") as caught:
        for f in rec.frames():
            got.append(f.index)
    assert got == [0, 1, 2, 3] and caught.value.index == 4 and caught.value.timestamp == 2.0
    assert isinstance(caught.value, InputError)  # callers that catch bad input catch this too


def test_damage_found_by_the_index_is_raised_after_the_last_frame():
    rec = Counted(3, damage="counted.rec is cut short after frame 2")
    got = []
    with pytest.raises(BrokenRecordingError, match="cut short after frame 2") as caught:
        for f in rec.frames():
            got.append(f.index)
    assert got == [0, 1, 2] and caught.value.index == 3 and caught.value.timestamp == 1.0
    assert list(rec.frames(stop=2)) and Counted(3).end_error() is None  # stopped early, or undamaged: no error

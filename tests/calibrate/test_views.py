"""graphpose.calibrate.views: choose_views on a short recording made by hand from rendered frames
whose fate is known: still sharp frames of three poses (one view each, the rest copies of it), a
blurred one, frames without a board, and two frames of a fast move."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from graphpose import Board, InputError
from graphpose.calibrate.views import (
    BLURRED,
    DUPLICATE,
    MOVING,
    NO_BOARD,
    NOT_SCANNED,
    USED,
    ViewChoice,
    choose_views,
)
from graphpose.geometry import T_from_params
from graphpose.synth.poses import random_pose
from graphpose.synth.render import render
from tests.conftest import PROJECT_K as K


class Frames:
    """A Recording's face (len, read(k).image, timestamps) over a list of images."""

    def __init__(self, images):
        self.images = images
        self.timestamps = 0.1 * np.arange(len(images))

    def __len__(self):
        return len(self.images)

    def read(self, k):
        return SimpleNamespace(index=k, timestamp=self.timestamps[k], image=self.images[k])


@pytest.fixture(scope="module")
def recording():
    rng = np.random.default_rng(4)

    def shot(T):
        return render(K, T, noise_sigma=1.0, supersample=2, rng=rng).image

    a, b, c, d = (random_pose(K, rng=rng) for _ in range(4))
    d_moved = d @ T_from_params([0.02, 0.0, 0.0, 0.0, 0.0, 0.0])  # 2 cm along the board in one frame
    a, b, c, d, d_moved = (shot(T) for T in (a, b, c, d, d_moved))
    blurred = np.round(gaussian_filter(a.astype(float), 2.5)).astype(a.dtype)
    blank = np.full_like(a, 128)
    images = [a, a, blurred, a, blank, b, b, b, blank, c, c, blank, d, d_moved, blank]
    return Frames(images)


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_each_frame_gets_the_reason_it_was_or_was_not_used(recording):
    choice = choose_views(recording, Board(), max_views=10)
    assert isinstance(choice, ViewChoice) and choice.scan_every == 1
    status = choice.status
    assert [status[k] for k in (4, 8, 11, 14)] == [NO_BOARD] * 4
    assert status[2] == BLURRED and "blur" in choice.detail[2]
    assert status[12] == status[13] == MOVING and "px a frame" in choice.detail[12]
    # One view of each still pose, the other frames of it copies of that one.
    for frames in ((0, 1, 3), (5, 6, 7), (9, 10)):
        used = [k for k in frames if status[k] == USED]
        assert len(used) == 1, [status[k] for k in frames]
        for k in frames:
            if k != used[0]:
                assert status[k] == DUPLICATE and choice.detail[k] == f"of frame {used[0]}"
    assert choice.frames.tolist() == sorted(k for k in range(15) if status[k] == USED)
    assert choice.counts() == {DUPLICATE: 5, NO_BOARD: 4, USED: 3, MOVING: 2, BLURRED: 1}
    assert list(choice.counts())[:2] == [DUPLICATE, NO_BOARD]  # most first
    # The measurements behind the reasons: still frames do not move, the blurred one is wider.
    assert choice.speed_px[0] < 0.1 and choice.speed_px[12] > 2.0
    assert choice.blur_px[2] > 1.6 * choice.sharp_blur_px
    assert choice.junctions[0] == 48 and choice.junctions[4] == 0
    np.testing.assert_array_equal(choice.timestamps, recording.timestamps)


def test_scanning_every_other_frame_leaves_the_rest_unscanned(recording):
    choice = choose_views(recording, Board(), max_views=10, scan_every=2)
    assert choice.scan_every == 2
    assert all(choice.status[k] == NOT_SCANNED and choice.detail[k] == "" for k in range(1, 15, 2))
    assert all(choice.status[k] != NOT_SCANNED for k in range(0, 15, 2))
    assert np.isnan(choice.blur_px[1]) and choice.junctions[1] == 0


@pytest.mark.parametrize("kwargs, match", [
    ({"max_views": 2}, "max_views must be an integer >= 3, got 2"),
    ({"max_views": True}, "max_views must be an integer >= 3"),
    ({"scan_every": 0}, "scan_every must be >= 1, got 0"),
])
def test_bad_options_are_refused(kwargs, match):
    with pytest.raises(InputError, match=match):
        choose_views(Frames([]), Board(), **kwargs)


def test_kept_images_are_the_chosen_frames_and_only_when_asked(recording, monkeypatch):
    import graphpose.calibrate.views as views

    choice = choose_views(recording, Board(), max_views=10, scan_every=3, keep_images=True)
    assert choice.images is not None and len(choice.images) == len(choice.frames) > 0
    for k, image in zip(choice.frames, choice.images):
        np.testing.assert_array_equal(image, recording.images[k])
    assert choose_views(recording, Board(), max_views=10, scan_every=3).images is None
    # Beyond the memory budget nothing is kept: the caller reads the chosen frames again.
    monkeypatch.setattr(views, "KEEP_BYTES", recording.images[0].nbytes)
    assert choose_views(recording, Board(), max_views=10, scan_every=3, keep_images=True).images is None

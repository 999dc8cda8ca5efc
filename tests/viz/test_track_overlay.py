"""graphpose.viz.track_overlay: a tracker's frame result drawn on its frame."""

import numpy as np

from graphpose import Board, project
from graphpose.geometry import T_from_params
from graphpose.track.results import FrameResult
from graphpose.viz.overlay import COLOURS
from graphpose.viz.track_overlay import draw_track_frame
from tests.conftest import PROJECT_K as K

BOARD = Board()
T_WC = T_from_params([0.2, 0.15, -0.9, 0.05, -0.04, 0.03])
GREY = 40 + 170 * 0.5  # a 0.5 grey pixel once dimmed for the marks


def _close(pixels, colour, tol=40):
    """Whether each pixel (..., 3) is within tol of colour in every channel."""
    return np.all(np.abs(pixels.astype(int) - colour) <= tol, axis=-1)


def _text_box(out):
    """Pixels in the text's corner (the upper-left 40 rows)."""
    return out[:40]


def test_a_tracked_frame_shows_reprojections_measurements_and_its_text():
    image = np.full((480, 640), 0.5)
    before = image.copy()
    points = project(K, T_WC, BOARD.world_points())
    frame = FrameResult(3, 0.1, "tracked", T_WC=T_WC, cov=np.eye(6) * 1e-8, junctions=BOARD.n, rms_px=0.12,
                        points=points + [[8.0], [0.0]])  # measured 8 px right of the reprojections
    out = draw_track_frame(image, frame, K, BOARD, label="7")
    np.testing.assert_array_equal(image, before)  # pure: the input is untouched
    assert out.shape == (480, 640, 3) and out.dtype == np.uint8
    W = BOARD.world_points()
    clear = (W[0] > 2.5 * BOARD.square_m) | (W[1] > 2.5 * BOARD.square_m)  # off the target's axes
    assert clear.sum() > 30
    for u, v in points[:, clear].T:
        assert _close(out[int(round(v)), int(round(u))], COLOURS["reprojected"])  # plus at the reprojection
        # The measured junction's ring (radius 6 px) passes 6 px from it, i.e. 2 px right of the plus.
        assert _close(out[int(round(v)), int(round(u + 8.0 + 6.0))], COLOURS["trusted"])
    assert _close(out[470, 630], (GREY,) * 3, tol=1)  # far from the board: the dimmed image
    assert _close(_text_box(out), COLOURS["good"], tol=1).sum() > 50  # the text in green: a good frame


def test_a_lost_frame_is_the_dimmed_image_with_its_status_in_red():
    image = np.full((480, 640), 0.5)
    out = draw_track_frame(image, FrameResult(4, 0.2, "lost", message="out of view"), K, BOARD, label="8")
    red = _close(out, COLOURS["bad"], tol=1)
    assert red.sum() > 50 and red[40:].sum() == 0  # the text only, in its corner
    assert _close(out[240, 320], (GREY,) * 3, tol=1)  # no marks: the board's middle is plain image
    assert np.count_nonzero(np.abs(out[40:].astype(int) - GREY) > 1) == 0


def test_the_text_grows_with_the_frame():
    small = draw_track_frame(np.full((240, 320), 0.5), FrameResult(0, 0.0, "lost"), K / [[2], [2], [1]], BOARD)
    large = draw_track_frame(np.full((960, 1280), 0.5), FrameResult(0, 0.0, "lost"), K * [[2], [2], [1]], BOARD)
    written = [np.count_nonzero(np.abs(o.astype(int) - GREY).max(axis=2) > 1) for o in (small, large)]
    assert written[1] == 16 * written[0]  # glyph scale 1 then 4: sixteen times the pixels

"""Detection under noise, blur and low contrast: the noise estimate, the noise-aware search,
the refinement's smoothing, and never a mislabel.

The boards here are rendered with exact truth; each of the noisy ones was refused before
the noise-aware search (``no checkerboard in the image: N junction-like points but no grid
of cross-junctions among them``).
"""

import numpy as np
import pytest

from graphpose import Board, BoardNotFoundError, InputError, extract_junctions
from graphpose.detect import find as find_module
from graphpose.detect.noise import estimate_noise, grey_range
from graphpose.detect.refine import MAX_SMOOTH_SIGMA, SMOOTH_SIGMA, noise_smoothing
from graphpose.synth.poses import loose_polygon, random_pose
from graphpose.synth.render import render
from graphpose.track.frontend import board_symmetries
from tests.conftest import PROJECT_K as K


def _rendered(seed, board, noise, blur, black=35.0, white=215.0):
    rng = np.random.default_rng(seed)
    T = random_pose(K, board, (640, 480), distance=(0.6, 0.9) if board == Board() else (0.5, 0.7), rng=rng)
    return render(K, T, board, (640, 480), noise_sigma=noise, blur_sigma=blur, black=black, white=white, rng=rng)


def _label_error(J, truth) -> float:
    """Largest distance (px) of a trusted junction from the true junction of its label (of the
    labels a half turn gives too, when the board's pattern cannot tell them apart)."""
    err = np.hypot(*(J.points[:, J.trusted] - truth[:, J.trusted])).max()
    if J.orientation_ambiguous:
        err = min(err, np.hypot(*(J.points[:, J.trusted] - truth[:, ::-1][:, J.trusted])).max())
    return float(err)


# ------------------------------------------------------------------------- the estimate


@pytest.mark.parametrize("sigma", [1.0, 4.0, 9.0, 16.0])
def test_noise_estimate_on_a_rendered_board_with_known_noise(sigma):
    # Unquantised, so that the figure is the noise the renderer added, edges and all.
    R = render(K, random_pose(K, rng=3), noise_sigma=sigma, blur_sigma=1.5, rng=4, quantize=False)
    assert estimate_noise(R.image) == pytest.approx(sigma, rel=0.08)
    assert estimate_noise(R.image, stride=1) == pytest.approx(sigma, rel=0.08)


def test_noise_estimate_ignores_smooth_shading_and_reads_quantisation():
    v, u = np.mgrid[0:240, 0:320].astype(float)
    shading = 40 + 0.3 * u + 0.2 * v + 1e-3 * (u - 160) ** 2
    assert estimate_noise(shading) < 1e-3
    noisy = shading + np.random.default_rng(0).normal(0, 5.0, shading.shape)
    assert estimate_noise(noisy) == pytest.approx(5.0, rel=0.05)
    assert estimate_noise(noisy.astype(np.float32) / 255) == pytest.approx(5.0 / 255, rel=0.05)
    assert grey_range(noisy) == pytest.approx(np.percentile(noisy[::3, ::3], 99) - np.percentile(noisy[::3, ::3], 1), rel=0.01)


@pytest.mark.slow  # 0.4 s or so on two idle cores: a render, a calibration or a subprocess
def test_a_large_image_is_read_sparser_with_the_same_estimate(monkeypatch):
    """At 12 MP the estimate reads at most MAX_SAMPLES positions, and reads the same noise as
    every position would."""
    from graphpose.detect import noise as module

    rng = np.random.default_rng(5)
    big = np.clip(128 + rng.normal(0.0, 7.0, (3024, 4032)), 0, 255).astype(np.uint8)
    stride = module._stride((3022, 4030), 4)
    assert stride > 4 and -(-3022 // stride) * -(-4030 // stride) <= module.MAX_SAMPLES
    assert module._stride((478, 638), 4) == 4  # a VGA image: every fourth row and column, not thinned further
    sparse_noise, sparse_range = estimate_noise(big), grey_range(big)
    monkeypatch.setattr(module, "MAX_SAMPLES", big.size)  # no cap: every position asked for
    assert sparse_noise == pytest.approx(estimate_noise(big, stride=1), rel=0.02)
    assert sparse_noise == pytest.approx(np.sqrt(7.0**2 + 1 / 12), rel=0.03)
    assert sparse_range == pytest.approx(grey_range(big, stride=1), abs=1.0)


def test_noise_estimate_checks_its_input():
    with pytest.raises(InputError, match="grey"):
        estimate_noise(np.zeros((4, 4, 3)))
    with pytest.raises(InputError, match="3 x 3"):
        estimate_noise(np.zeros((2, 9)))
    with pytest.raises(InputError, match="stride"):
        estimate_noise(np.zeros((9, 9)), stride=0)


def test_smoothing_follows_the_noise_over_the_contrast():
    assert noise_smoothing(0.5, 180.0, 30.0) == SMOOTH_SIGMA  # a clean image: the default smoothing
    assert noise_smoothing(2.0, 180.0, 30.0) == SMOOTH_SIGMA
    grown = [noise_smoothing(s, 180.0, 30.0) for s in (4.0, 8.0, 12.0)]
    assert SMOOTH_SIGMA < grown[0] < grown[1] < grown[2] <= MAX_SMOOTH_SIGMA
    assert noise_smoothing(16.0, 35.0, 30.0) == MAX_SMOOTH_SIGMA
    assert noise_smoothing(16.0, 35.0, 8.0) == pytest.approx(0.8)  # a small square bounds it


# ---------------------------------------------------------------------- noisy boards


@pytest.mark.parametrize("seed, board, noise, blur, black, white", [
    (0, Board(), 16.0, 2.0, 35.0, 215.0),
    (2, Board(9, 6, 0.03), 12.0, 3.0, 35.0, 215.0),
    (3, Board(), 6.0, 2.0, 100.0, 135.0),  # low contrast
])
@pytest.mark.slow  # 0.2 s or so on two idle cores: a render, a calibration or a subprocess
def test_noisy_blurred_and_low_contrast_boards_are_found_and_labelled(seed, board, noise, blur, black, white):
    R = _rendered(seed, board, noise, blur, black, white)
    J = extract_junctions(R.image, bounds=None, board=board)
    assert J.seen.all() and J.trusted.sum() >= 0.9 * board.n
    assert _label_error(J, R.junctions) < 0.6
    # Their accuracy: well under a tenth of a square, as the grid gate demands.
    assert np.sqrt(np.mean(np.sum((J.points - R.junctions) ** 2, axis=0)[J.trusted])) < 0.3 or J.orientation_ambiguous


def test_a_noisy_board_inside_loose_bounds_is_found():
    board = Board(7, 5, 0.04)
    R = _rendered(4, board, 16.0, 3.0)
    J = extract_junctions(R.image, bounds=loose_polygon(R, rng=5), board=board)
    assert J.seen.all() and _label_error(J, R.junctions) < 0.6
    assert not J.orientation_ambiguous


def test_a_faint_board_in_a_bright_scene_is_judged_by_its_own_contrast():
    """A board of 30 grey levels at noise 3, with black and white objects elsewhere in the
    scene: against the whole image's range the noise looks small and the noise-aware search
    never ran (refused on this seed); inside the bounds it is the board's range that counts."""
    board = Board()
    rng = np.random.default_rng(0)
    T = random_pose(K, board, (640, 480), rng=rng)
    r = render(K, T, board, (640, 480), noise_sigma=3.0, rng=rng, black=110.0, white=140.0, background=125.0,
               blur_sigma=1.5)
    image = r.image.copy()
    image[:40, :80] = 0
    image[-40:, -80:] = 255
    J = extract_junctions(image, bounds=loose_polygon(r, rng=rng), board=board)
    assert J.trusted.sum() == board.n
    assert np.max(np.hypot(*(J.points - r.junctions))) < 0.5


@pytest.mark.slow  # 0.3 s or so on two idle cores: a render, a calibration or a subprocess
def test_noisy_images_are_never_mislabelled():
    # Boards of every symmetry, some partly off the image: found right or refused.
    boards = [Board(), Board(7, 5, 0.04), Board(6, 6, 0.04), Board(9, 6, 0.03)]
    for seed, board in enumerate(boards):
        rng = np.random.default_rng(40 + seed)
        T = random_pose(K, board, (640, 480), distance=(0.7, 1.0), rng=rng)
        T[0, 3] += 0.3 * (seed % 2)  # the camera moved right: the board runs off the image's left
        R = render(K, T, board, (640, 480), noise_sigma=16.0, blur_sigma=3.0, rng=rng)
        try:
            J = extract_junctions(R.image, bounds=None, board=board)
        except BoardNotFoundError:
            continue
        truth = R.junctions
        errors = [np.hypot(*(J.points[:, J.trusted] - truth[:, perm][:, J.trusted])).max()
                  for perm in board_symmetries(board)]
        assert min(errors) < 1.0, (seed, errors)


def test_clean_images_take_the_fast_path_only(monkeypatch):
    # A clean image whose fast path finds nothing is not searched again: its noise is
    # under NOISY of its grey range.
    calls = []
    real = find_module._search

    def search(*args, **kwargs):
        calls.append(args[5] if len(args) > 5 else kwargs.get("noise"))
        return real(*args, **kwargs)

    monkeypatch.setattr(find_module, "_search", search)
    R = render(K, random_pose(K, rng=5), noise_sigma=1.0, rng=6)
    blank = R.image.copy()
    blank[:] = np.clip(np.rint(R.image.mean() + np.random.default_rng(7).normal(0, 0.5, R.image.shape)), 0, 255)
    blank[100:300, 100:400] = 200  # a white sheet, no board
    with pytest.raises(BoardNotFoundError, match="no grid of cross-junctions"):
        find_module.find_board(blank, Board())
    assert calls and all(noise is None for noise in calls)


# --- the noise estimate's compiled kernels against plain NumPy (the loops they replaced) ---


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



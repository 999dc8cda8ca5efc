"""``calibrate(images, model, *, board)``: the calibration from images to :class:`Calibration`.

The steps (``docs/calibration.md``):

1. **First pass.** Every image's junctions, found as :func:`graphpose.estimate_pose` finds
   them (:func:`graphpose.detect.find_board`, no camera: the board and its labels come from
   the image, searched once; then :func:`graphpose.detect.refine`, through a ``camera`` if
   given), the trusted ones only. An image without a board is named
   and the others go on; at least three images must have one. A fisheye hides most boards
   from a search without its camera (only those near the image's centre are found): the
   error says so. (An equidistant camera fitted to one or two boards, or guessed from the
   image's size, was tried as a bootstrap: it is not close enough for the detector's
   planarity check away from the centre, and found no more boards.)
2. **Start.** :func:`.zhang.start`: Zhang's closed form (the fisheye: the equidistant model's
   own), poses from the homographies.
3. **Solve.** A plain least-squares solve (:func:`.lm.solve_lm`) from the start, then two
   Huber solves, each with the pixel noise ``sigma`` from the last one's residuals (1.4826 x
   their median absolute value): the majority's fit. An image whose RMS against it exceeds
   :data:`REJECT_RATIO` times the median image's is rejected and the rest solved again. Then the robust solve twice, from the plain solution: GTSAM's graph
   (:func:`.graph.solve_graph`, Huber at ``huber_k`` sigmas) and the hand-written
   Levenberg-Marquardt over the same cost (:func:`.lm.solve_lm`). They must agree on every
   parameter to :data:`CROSS_CHECK_TOL` of ``max(|p|, sigma_p)`` or the calibration is not ok.
4. **Passes with the camera.** Every image again, with the camera found (lens-aware
   detection and refinement find boards a raw fisheye image hides from the first pass, and
   refine every junction through the lens), and step 3 again from the previous solution;
   repeated while a pass finds a board the previous did not (at most
   :data:`MAX_CAMERA_PASSES` times: a first camera from a few central boards may not yet
   find those at the rim). The last pass is always one with the final pass's camera
   before the final solve.

The covariance is the Huber estimate's by the sandwich rule, over the intrinsics and every
pose jointly (:func:`.uncertainty.huber_covariance`; its intrinsics' block is ``cov``, the
whole is what the projection uncertainty propagates); the pixel noise reported is
``sqrt(sum r^2 / (2M - P - 6n))`` (M junctions, n images). A focal length whose relative sigma exceeds
:data:`MAX_FOCAL_SIGMA` means the views do not constrain it: an error saying so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._checks import check_number
from ..board import check_board
from ..board import Board
from ..errors import BoardNotFoundError, DegenerateGeometryError, InputError
from ..camera_models import calibration_model
from .._deprecated import ignored_rng
from ..robust import HUBER_K, mad_sigma  # noqa: F401  (HUBER_K: calibrate's default, named here too)
from ..pose.gauss_newton import reprojection_rms
from .result import Calibration, SolverCrossCheck, sag_mm

#: An image whose RMS exceeds this many times the median image's is rejected.
REJECT_RATIO = 3.0
#: ... unless it is below this (pixels): rendered images fit to a few hundredths of a pixel.
REJECT_FLOOR_PX = 0.1
#: A junction whose 2-D residual exceeds this many pixel sigmas (1.4826 x the median absolute
#: residual coordinate of the robust fit) is an outlier: left out, and named in its image's
#: report. For Gaussian noise P(|r| > c sigma) = exp(-c^2 / 2): 4e-6 of good junctions at 5.
OUTLIER_SIGMAS = 5.0
#: An image with more than this fraction of its junctions outliers is rejected whole (a moved
#: board or a wrong label is no set of single outliers).
OUTLIER_IMAGE_FRACTION = 0.25
#: The two solvers must agree on each parameter to this fraction of max(|p|, sigma_p).
CROSS_CHECK_TOL = 1e-6
#: Fewest images with a board.
MIN_IMAGES = 3
#: Fewest trusted junctions an image must give to join a calibration: more than a pose's
#: (:data:`graphpose.observations.MIN_JUNCTIONS`), as an image must fix its own pose (six
#: unknowns) and still tell the camera's parameters something (16 equations, 10 beyond its pose).
MIN_CALIBRATION_JUNCTIONS = 8
#: The smallest pixel sigma the residuals' median gives (:func:`graphpose.robust.mad_sigma`).
SIGMA_FLOOR_PX = 1e-6
#: Passes with the camera after the first: they stop when one finds no new board.
MAX_CAMERA_PASSES = 3
#: Largest relative 1-sigma of fx or fy a calibration may have.
MAX_FOCAL_SIGMA = 0.05
#: ``warp="auto"`` keeps the board warp where its sag's 1-sigma is at most this fraction of
#: the board's span (the diagonal between its outer junctions: 1.2 mm on a 9 x 6 board of
#: 25 mm squares): a sag known no better than that says nothing of a board's bending (a
#: printed board on card sags 0.5-3 mm), and only widens the intrinsics' sigmas.
WARP_MAX_SIGMA = 0.005
#: ``warp="auto"`` keeps the board warp only where the views agree on it (:func:`warp_agreement`):
#: a board's bending is one shape, the same in every view. Each view's own warp (its pose and
#: the warp fitted with the intrinsics held) must scatter about their weighted mean no more
#: than its covariance allows: the chi-square of that scatter (2 (n - 1) dof) is refused
#: beyond this upper-tail probability. On rendered sets, bent or flat, the scatter is what the
#: noise gives (p 0.4-0.98); on OpenCV's samples it is 4-6 times its dof (p below 1e-11): the
#: warp there follows each view's own misfit, not the board, and its two halves' cameras
#: repeat worse with it (``docs/calibration.md``, Bent boards).
WARP_AGREEMENT_P = 1e-3


def _load(images, names):
    """The images as arrays and their names; image files are read. A file that cannot be read
    is None among the arrays, with its reason in the third dict (index -> reason): the others
    go on."""
    from ..image import read_image
    from .._checks import check_image

    if isinstance(images, (str, Path)) or (isinstance(images, np.ndarray) and images.ndim == 2):
        raise InputError("images must be a sequence of images (arrays or file paths), not one image")
    images = list(images)
    out, labels, unreadable = [], [], {}
    for i, image in enumerate(images):
        if isinstance(image, (str, Path)):
            labels.append(Path(image).name)
            try:
                out.append(read_image(image, as_float=False))
            except InputError as exc:  # missing, corrupt, not an image: named, and the others go on
                out.append(None)
                unreadable[i] = " ".join(str(exc).split())
        else:
            labels.append(f"image {i}")
            out.append(check_image(image, f"image {i}"))
    if names is not None:
        labels = [str(n) for n in names]
        if len(labels) != len(out):
            raise InputError(f"names must name every image: {len(out)} images, {len(labels)} names")
    if not out:
        raise InputError(f"calibrate needs images of the board, at least {MIN_IMAGES}; got none")
    read = [k for k, im in enumerate(out) if im is not None]
    if not read:
        raise InputError(f"no image could be read: {labels[0]}: {unreadable[0]}"
                         + (f" (and {len(out) - 1} more)" if len(out) > 1 else ""))
    sizes = {k: (out[k].shape[1], out[k].shape[0]) for k in read}
    if len(set(sizes.values())) > 1:
        first = sizes[read[0]]
        other = next(k for k in read if sizes[k] != first)
        raise InputError(
            f"the images differ in size: {labels[read[0]]} is {first[0]} x {first[1]} but {labels[other]} is "
            f"{sizes[other][0]} x {sizes[other][1]}; one calibration holds for one image size: give "
            "images of one camera at one resolution")
    return out, labels, sizes[read[0]], unreadable


def _search(image, board):
    """The board's search in one image, which does not depend on the camera (done once for
    every pass): ``((image, found), "")`` or ``(None, reason)``."""
    return _search_refusal(image, board)[:2]


def _search_refusal(image, board):
    """:func:`_search`, and the refusal itself (None where the board was found):
    ``((image, found) or None, reason, BoardNotFoundError or None)``."""
    from ..detect import find_board

    try:
        return (image, find_board(image, board)), "", None
    except BoardNotFoundError as exc:
        return None, str(exc), exc


def _detect(searched, board, camera):
    """The trusted junctions (uv (2, m), W (3, m), index (m,)) of a searched image
    (:func:`_search`), refined and judged through ``camera`` (:func:`graphpose.detect.refine`,
    as :func:`graphpose.detect.extract_junctions` does), or the reason there are none."""
    from ..detect import refine

    found, reason = searched
    if found is None:
        return None, reason
    image, board_found = found
    try:
        J = refine(image, board_found, camera=camera)
    except BoardNotFoundError as exc:
        return None, str(exc)
    index = np.flatnonzero(J.trusted)
    if index.size < MIN_CALIBRATION_JUNCTIONS:
        return None, f"only {index.size} trusted junctions (need {MIN_CALIBRATION_JUNCTIONS})"
    return (J.points[:, index], board.world_points()[:, index], index), ""


def _rms(r):
    """The calibration's RMS of residuals (2, m): :func:`graphpose.pose.gauss_newton.reprojection_rms`
    summed a junction at a time (``by_junction``), the order every calibration report uses."""
    return reprojection_rms(r, by_junction=True)


def _solve(camera, poses, obs, huber_k, final=True, plain=True, held=None, warp_board=None, warp_start=None,
           warp_auto=False):
    """Step 3 on the images ``obs`` (a dict image -> observation): the plain solve, the
    robust screening and the rejections, the robust solve twice (``final``; else only the
    screening's fit, which a pass before the last needs for its camera). Returns what the
    result needs (``graph`` None when not ``final``). ``held``: the parameters held at 0;
    ``warp_board``: the board whose warp is estimated (None: flat), from ``warp_start``;
    ``warp_auto``: dropped where the views do not constrain it (:func:`_warp_constrained`) or
    disagree on it (:func:`_why_flat`), the reason returned last."""
    from .graph import solve_graph
    from .lm import solve_lm

    keys = list(obs)
    obs = dict(obs)
    rejected, outliers = {}, {}
    fit = None

    def bases(view):
        return None if warp_board is None else [warp_board.warp_basis(W) for _, W, _ in view]

    while True:
        view = [obs[k] for k in keys]
        # From Zhang's start a plain fit first; from an earlier pass's camera the residuals
        # at the start (no iterations) set the first Huber threshold.
        fit = solve_lm(camera, [poses[k] for k in keys], view, max_iterations=100 if plain else 0,
                       prior_px=mad_sigma(fit.residuals, floor=SIGMA_FLOOR_PX) if fit is not None else 1.0, held=held,
                       bases=bases(view), warp=warp_start if fit is None else fit.warp)
        # Robust screening: two Huber solves (the noise from the residuals' median each time)
        # give the majority's fit, against which an image that does not fit stands out (a
        # plain fit spreads one bad image's misfit over all of them).
        for _ in range(2):
            s = mad_sigma(fit.residuals, floor=SIGMA_FLOOR_PX)
            fit = solve_lm(fit.camera, fit.poses, view, huber_k * s, prior_px=s, held=held, bases=bases(view),
                           warp=fit.warp)
        camera, poses = fit.camera, dict(zip(keys, fit.poses))
        plain = False
        # Single junctions that do not fit the majority's solution: left out, and solved again.
        limit_px = OUTLIER_SIGMAS * mad_sigma(fit.residuals, floor=SIGMA_FLOOR_PX)
        flagged, whole = False, None
        for k, r in zip(keys, fit.residuals):
            bad = np.hypot(r[0], r[1]) > limit_px
            if not bad.any():
                continue
            uv, W, index = obs[k]
            if bad.sum() > OUTLIER_IMAGE_FRACTION * bad.size or bad.size - bad.sum() < MIN_CALIBRATION_JUNCTIONS:
                if whole is None or bad.mean() > whole[1]:
                    whole = (k, bad.mean(), int(bad.sum()), bad.size)
                continue
            outliers[k] = np.sort(np.r_[outliers.get(k, np.zeros(0, int)), index[bad]]).astype(int)
            obs[k] = (uv[:, ~bad], W[:, ~bad], index[~bad])
            flagged = True
        if whole is not None and len(keys) > MIN_IMAGES:
            k, _, nbad, m = whole
            rejected[k] = (f"rejected: {nbad} of its {m} junctions are more than {OUTLIER_SIGMAS:g} sigmas "
                           f"({limit_px:.3f} px) off the others' solution (a moved board, a wrong label, "
                           "a blurred image?)")
            keys.remove(k)
            continue
        if flagged:
            continue
        rms = np.array([_rms(r) for r in fit.residuals])
        limit = max(REJECT_RATIO * float(np.median(rms)), REJECT_FLOOR_PX)
        worst = int(np.argmax(rms))
        if rms[worst] <= limit or len(keys) <= MIN_IMAGES:
            break
        rejected[keys[worst]] = (f"rejected: RMS {rms[worst]:.3f} px, more than {REJECT_RATIO:g} times the "
                                 f"median image's {np.median(rms):.3f} px (a moved board, a wrong label, "
                                 "a blurred image?)")
        keys.pop(worst)
    sigma0 = mad_sigma(fit.residuals, floor=SIGMA_FLOOR_PX)
    flat_why = None
    if warp_board is not None and warp_auto:
        flat_why = _why_flat(fit, sigma0, view, warp_board)
    if flat_why is not None:
        # The views do not tell the board's bending, or tell each a different one: a flat
        # board from here on.
        warp_board = None
        fit = solve_lm(fit.camera, fit.poses, view, huber_k * sigma0, prior_px=sigma0, held=held)
        sigma0 = mad_sigma(fit.residuals, floor=SIGMA_FLOOR_PX)
    plain = fit
    start_poses = fit.poses
    if not final:
        return keys, rejected, None, fit, sigma0, obs, outliers, flat_why
    graph = solve_graph(plain.camera, start_poses, view, sigma0, huber_k, prior_px=sigma0, held=held,
                        bases=bases(view), warp=plain.warp)
    lm = solve_lm(plain.camera, start_poses, view, huber_k * sigma0, prior_px=sigma0, held=held, bases=bases(view),
                  warp=plain.warp)
    return keys, rejected, graph, lm, sigma0, obs, outliers, flat_why


def _why_flat(fit, sigma_px, view, board):
    """Why ``warp="auto"`` takes the board as flat, or None where it keeps the warp of ``fit``
    (:func:`_warp_constrained`, :func:`warp_agreement`)."""
    if not _warp_constrained(fit, sigma_px, board):
        return f"the views do not constrain its bending: the sag's 1-sigma is above {WARP_MAX_SIGMA:.1%} of its span"
    chi2, dof = warp_agreement(fit, view, board)
    if not _agrees(chi2, dof):
        return (f"the views disagree on its bending: each view's own warp against the others' gives chi-square "
                f"{chi2:.0f} for {dof} dof")
    return None


def _warp_constrained(fit, sigma_px, board) -> bool:
    """Whether the views constrain the board warp of ``fit`` (a :func:`.lm.solve_lm` result
    with the warp): the sag's 1-sigma at most :data:`WARP_MAX_SIGMA` of the board's span."""
    S = fit.information
    free = np.diag(S) > 0
    try:
        C = np.linalg.inv(S[np.ix_(free, free)])
    except np.linalg.LinAlgError:
        return False
    sag_sd = sigma_px * float(np.sqrt(max(np.sum(C[-2:, -2:]), 0.0)))
    span = np.hypot(board.cols - 1, board.rows - 1) * board.square_m
    return bool(np.isfinite(sag_sd) and sag_sd <= WARP_MAX_SIGMA * span)


def warp_agreement(fit, view, board):
    """The views' agreement on the board warp of ``fit`` (a :func:`.lm.solve_lm` result with
    the warp, on the views' observations ``view``): per view, its pose and its own warp fitted
    with the intrinsics held at ``fit``'s, and that warp's covariance from the view's own
    residuals (``sum r^2 / (2m - 8)``: a noisier view weighs less); their chi-square about the
    information-weighted mean of the views' warps.

    Returns
    -------
    chi2 : float
        ``sum_k (w_k - w)^T C_k^-1 (w_k - w)``; NaN where fewer than two views fix their own
        warp.
    dof : int
        ``2 (n - 1)`` over the n views that fix their own warp.
    """
    from .lm import solve_lm

    P = fit.camera.parameters.size
    hold = np.ones(P, dtype=bool)
    warps, infos = [], []
    for T, obs in zip(fit.poses, view):
        one = solve_lm(fit.camera, [T], [obs], held=hold, bases=[board.warp_basis(obs[1])], warp=fit.warp)
        r = one.residuals[0]
        S = one.information[P:, P:]
        if r.size <= 8 or not np.all(np.isfinite(S)) or np.linalg.matrix_rank(S) < 2:
            continue
        warps.append(one.warp)
        infos.append(S / max(float(np.sum(r * r)) / (r.size - 8), SIGMA_FLOOR_PX ** 2))
    if len(warps) < 2:
        return float("nan"), 0
    mean = np.linalg.solve(sum(infos), sum(I @ w for I, w in zip(infos, warps)))
    chi2 = float(sum((w - mean) @ I @ (w - mean) for I, w in zip(infos, warps)))
    return chi2, 2 * (len(warps) - 1)


def _agrees(chi2, dof) -> bool:
    """Whether the views agree on the board warp (:func:`warp_agreement`'s ``chi2``, ``dof``):
    the chi-square within the upper-tail probability :data:`WARP_AGREEMENT_P`."""
    from scipy.stats import chi2 as chi2_distribution

    return bool(dof > 0 and chi2_distribution.sf(chi2, dof) >= WARP_AGREEMENT_P)


def check_warp(warp):
    """``warp`` as :func:`calibrate` takes it: True, False or ``"auto"``."""
    if warp is True or warp is False or (isinstance(warp, str) and warp == "auto"):
        return warp
    if isinstance(warp, (bool, np.bool_)):
        return bool(warp)
    raise InputError(f"warp must be True, False or 'auto', got {warp!r}")


def calibrate(images, model: str = "radtan", *, board: Board = Board(), names=None, camera=None,
              huber_k: float = HUBER_K, rng=None, progress=None, warp="auto") -> Calibration:
    """Calibrate a camera from images of the board.

    Parameters
    ----------
    images : sequence of (H, W) array_like or path
        Raw images of one camera at one resolution (arrays, or files read with
        :func:`graphpose.read_image`).
    model : str
        ``"pinhole"``, ``"radtan"`` (OpenCV's five coefficients), ``"radtan4"`` (k1, k2, p1,
        p2 with k3 held at 0: Kalibr's pinhole-radtan; the camera has four coefficients, k3's
        row and column of the covariance are zero) or ``"fisheye"``.
    board : Board
        The board in the images.
    names : sequence of str, optional
        The images' names in messages; their file names, or ``image i``, by default.
    camera : Camera, optional
        A camera to search the first pass with (an earlier calibration of this camera, or a
        nominal one of the lens): its boards are then found through the lens from the start.
        Only the detection uses it; the calibration starts from Zhang's closed form as
        without it.
    huber_k : float
        Huber threshold, in sigmas of the pixel noise.
    rng : None
        Deprecated and ignored (a DeprecationWarning when given): the calibration draws
        nothing, it is deterministic. It goes in the next release.
    progress : callable, optional
        Called as ``progress(stage, done, total)`` after each image of each pass
        (``stage`` ``"first pass"``, ``"pass 2"``, ...) and after each solve (``"solve"``),
        for a progress bar.
    warp : bool or "auto"
        Estimate the board's bending with the camera (mrcal's two-parameter board warp,
        :meth:`graphpose.board.Board.warp_basis`; the result's ``warp_m``, ``warp_cov`` and
        ``sag_mm``). ``"auto"`` (default): estimated, and kept where the views constrain it
        (the sag's 1-sigma at most :data:`WARP_MAX_SIGMA` of the board's span) and agree on
        it (each view's own warp within its noise of the others', :data:`WARP_AGREEMENT_P`),
        else the board is taken as flat; True: always; False: a flat board.

    Returns
    -------
    Calibration
        ``ok`` False (with ``summary``) when a solver did not converge or the two disagree.

    Raises
    ------
    InputError
        If the model is not known, the images differ in size, fewer than three images show
        the board (each image without one is named), or the views do not constrain the
        focal length (all boards parallel).
    """
    cls, held = calibration_model(model)
    check_board(board)
    huber_k = check_number("huber_k", huber_k, 0.0, strict=True)
    warp = check_warp(warp)
    warp_board = None if warp is False else board
    ignored_rng("calibrate", rng=rng)
    images, labels, size, unreadable = _load(images, names)
    report = progress or (lambda stage, done, total: None)
    n = len(images)

    # 1. First pass: no camera.
    if camera is not None:
        from ..camera_models import Camera, check_image_size

        if not isinstance(camera, Camera):
            raise InputError(f"camera must be a graphpose camera, got {type(camera).__name__}")
        check_image_size(camera, images[0], labels[0])
    obs, found_in, why = {}, {}, {}
    searched = []  # each image's search, for every pass (it does not depend on the camera)
    refusals = {}  # image -> the search's refusal, for the spec's check
    for i, image in enumerate(images):
        if image is None:
            searched.append((None, unreadable[i]))
        else:
            found_i, reason_i, refusals[i] = _search_refusal(image, board)
            searched.append((found_i, reason_i))
        o, reason = _detect(searched[i], board, camera)
        if o is None:
            why[i] = reason
        else:
            obs[i], found_in[i] = o, 1
        report("first pass", i + 1, n)
    _check_spec(board, labels, searched, refusals)
    if len(obs) < MIN_IMAGES:
        missing = "; ".join(f"{labels[i]}: {why[i]}" for i in sorted(why)[:5])
        raise InputError(f"fewer than {MIN_IMAGES} images show the board ({len(obs)} of {n}); a calibration "
                         f"needs at least {MIN_IMAGES} views at different tilts"
                         + (" (a fisheye's boards are found without a camera near the image's centre: "
                            "include views with the board there)" if cls.model == "fisheye" else "")
                         + (f". No board in: {missing}" + (" ..." if len(why) > 5 else "") if why else ""))

    # 2-3. Start and solve.
    from .zhang import start

    keys = sorted(obs)
    camera0, poses0 = start(cls.model, size, [obs[k][:2] for k in keys])
    keys, rejected, graph, lm, sigma0, inliers, outliers, flat_why = _solve(
        camera0, dict(zip(keys, poses0)), obs, huber_k, final=False, held=held, warp_board=warp_board,
        warp_auto=warp == "auto")
    report("solve", 1, 2)

    # 4. Passes with the camera: every image again, until no new board is found.
    from ..pose.homography import pose_from_homography

    for pass_number in range(2, 2 + MAX_CAMERA_PASSES):
        camera1 = lm.camera
        poses1 = dict(zip(keys, lm.poses))
        obs2 = {}
        for i in range(n):
            o, reason = _detect(searched[i], board, camera1)
            found = o is not None
            if not found and i in obs:
                o = obs[i]  # the earlier pass's junctions stand
            if o is not None and i not in poses1:
                # Found for the first time, or rejected by the last solve (which kept no pose
                # for it): a start from its own homography through the camera so far.
                try:
                    poses1[i] = pose_from_homography(o[0], o[1], camera1)
                except DegenerateGeometryError as exc:
                    o, reason = None, f"no pose from its junctions: {exc}"
            if o is not None:
                obs2[i] = o
                if found:
                    found_in.setdefault(i, pass_number)
                    why.pop(i, None)
            else:
                why[i] = reason
            report(f"pass {pass_number}", i + 1, n)
        grew = len(obs2) > len(obs)
        obs = obs2
        last = not grew or pass_number == 1 + MAX_CAMERA_PASSES
        # Only the last pass's solve is the calibration: GTSAM and the cross-check run there.
        keys, rejected, graph, lm, sigma0, inliers, outliers, flat_why = _solve(
            camera1, poses1, obs, huber_k, final=last, plain=False, held=held, warp_board=warp_board,
            warp_start=lm.warp, warp_auto=warp == "auto")
        report("solve", pass_number, pass_number)
        if last:
            break
    return _result(cls, labels, size, obs, keys, rejected, graph, lm, sigma0, found_in, why,
                   "no camera" if camera is None else "with the given camera", board, huber_k, inliers, outliers,
                   held, unreadable, flat_why=flat_why)


def calibrate_corners(corners, model: str = "radtan", *, board: Board = Board(), size=None, names=None,
                      huber_k: float = HUBER_K, progress=None, warp="auto") -> Calibration:
    """Calibrate a camera from junctions found by any detector (no images).

    Steps 2 and 3 of :func:`calibrate` (Zhang's start, the solves, the single outliers and
    the rejections) on the given junctions; no pass with the camera (there is no image to
    search again).

    Parameters
    ----------
    corners : graphpose.io.corners.Corners or sequence
        :func:`graphpose.io.corners.read_corners`' result (mrcal's corners.vnl or
        graphpose's JSON), or per image None (no board) or ``(uv (2, m), index (m,))``:
        pixels and the board's junction numbers (``Board.world_points`` columns).
    model : str
        As :func:`calibrate`'s.
    board : Board
    size : (int, int), optional
        The images' ``(width, height)``, pixels; required unless ``corners`` says it.
    names : sequence of str, optional
        The images' names; the file's (or ``image i``) by default.
    huber_k : float
    progress : callable, optional
        As :func:`calibrate`'s (stage ``"solve"``).
    warp : bool or "auto"
        As :func:`calibrate`'s.

    Returns
    -------
    Calibration
        As :func:`calibrate`'s; each used image's message says its junctions were read.

    Raises
    ------
    InputError
        If the size is missing or bad, a junction set is malformed, or fewer than three
        images have :data:`MIN_CALIBRATION_JUNCTIONS` junctions.
    """
    from .._checks import check_size
    from ..io.corners import Corners

    cls, held = calibration_model(model)
    check_board(board)
    huber_k = check_number("huber_k", huber_k, 0.0, strict=True)
    warp = check_warp(warp)
    warp_board = None if warp is False else board
    if isinstance(corners, Corners):
        labels = list(corners.images)
        size = corners.size if size is None else size
        corners = list(corners.junctions)
    else:
        corners = list(corners)
        labels = [f"image {i}" for i in range(len(corners))]
    if names is not None:
        labels = [str(x) for x in names]
        if len(labels) != len(corners):
            raise InputError(f"names must name every image: {len(corners)} junction sets, {len(labels)} names")
    if size is None:
        raise InputError("calibrating from corners needs the images' size (width, height): the corners.vnl does "
                         "not hold it (give --image-size WIDTHxHEIGHT, or the images beside the file)")
    size = check_size(size)
    report = progress or (lambda stage, done, total: None)
    W_all = board.world_points()
    obs, found_in, why = {}, {}, {}
    for i, j in enumerate(corners):
        if j is None:
            why[i] = "no board in the corners file"
            continue
        uv = np.asarray(j[0], float)
        index = np.asarray(j[1], int).ravel()
        if uv.ndim != 2 or uv.shape != (2, index.size) or not np.all(np.isfinite(uv)) \
                or np.any(index < 0) or np.any(index >= board.n):
            raise InputError(f"{labels[i]}: junctions must be pixels (2, m) with m board junction numbers in "
                             f"0..{board.n - 1}")
        if index.size < MIN_CALIBRATION_JUNCTIONS:
            why[i] = f"only {index.size} junctions (need {MIN_CALIBRATION_JUNCTIONS})"
            continue
        obs[i], found_in[i] = (uv, W_all[:, index], index), 0
    if len(obs) < MIN_IMAGES:
        raise InputError(f"fewer than {MIN_IMAGES} images have a board in the corners ({len(obs)} of {len(corners)}); "
                         f"a calibration needs at least {MIN_IMAGES} views at different tilts")
    from .zhang import start

    keys = sorted(obs)
    camera0, poses0 = start(cls.model, size, [obs[k][:2] for k in keys])
    keys, rejected, graph, lm, sigma0, inliers, outliers, flat_why = _solve(
        camera0, dict(zip(keys, poses0)), obs, huber_k, held=held, warp_board=warp_board, warp_auto=warp == "auto")
    report("solve", 1, 1)
    return _result(cls, labels, size, obs, keys, rejected, graph, lm, sigma0, found_in, why,
                   "the corners", board, huber_k, inliers, outliers, held, flat_why=flat_why)


def _joint(lm, observations, huber_px, sigma0, board, held):
    """The joint covariance of the intrinsics and the poses (:func:`.uncertainty.huber_covariance`)
    and the median distance from the camera to the board's centre."""
    from .uncertainty import huber_covariance

    bases = None if lm.warp is None else [board.warp_basis(W) for _, W, _ in observations]
    joint = huber_covariance(lm.camera, lm.poses, observations, huber_px, prior_px=sigma0, held=held, bases=bases,
                             warp=lm.warp)
    centre = np.mean(board.world_points(), axis=1)
    distance = float(np.median([np.linalg.norm(T[:3, 3] - centre) for T in lm.poses]))
    return joint, distance


def _check_spec(board, labels, searched, refusals) -> None:
    """Refuse a board spec the first pass's searches (and their ``refusals``, per image) contradict
    (:func:`graphpose.calibrate.agreement.check_agreement`)."""
    from ..errors import BoardMismatchError
    from .agreement import board_size_px, check_agreement

    found = {i: board_size_px(s[0][1]) for i, s in enumerate(searched) if s[0] is not None}
    mismatched = {i: e for i, e in refusals.items() if isinstance(e, BoardMismatchError)}
    check_agreement(board, labels, found, mismatched)


def _result(cls, labels, size, obs, keys, rejected, graph, lm, sigma0, found_in, why,
            first_camera, board, huber_k, inliers, outliers, held, unreadable=None, flat_why=None) -> Calibration:
    P_all = len(cls.parameter_names)
    nw = 0 if lm.warp is None else 2
    P = P_all - int(np.sum(held)) + nw  # the parameters estimated
    p_lm, p_g = lm.camera.parameters, graph.camera.parameters
    r_all = np.hstack(lm.residuals)
    M = r_all.shape[1]
    dof = 2 * M - P - 6 * len(keys)
    sigma = float(np.sqrt(np.sum(r_all * r_all) / max(dof, 1)))
    # The Huber estimate's covariance by the sandwich rule (:func:`.uncertainty.huber_covariance`):
    # the intrinsics' block is ``cov``, the whole is the projection uncertainty's. The board
    # warp's block is its own; out of ``joint`` (the projection does not depend on it) it is
    # marginalised, which for a Gaussian is dropping its rows and columns.
    joint, distance = _joint(lm, [inliers[k] for k in keys], huber_k * sigma0, sigma0, board, held)
    warp_cov = joint[P_all:P_all + nw, P_all:P_all + nw].copy() if nw else None
    if nw:
        keep = np.r_[np.arange(P_all), np.arange(P_all + nw, joint.shape[0])]
        joint = joint[np.ix_(keep, keep)]
    cov = joint[:P_all, :P_all].copy()
    sd = np.sqrt(np.abs(np.diag(cov)))
    if not np.all(np.isfinite(cov)):
        sd = np.sqrt(np.abs(np.diag(np.linalg.pinv(lm.information))))[:P_all] * sigma
    scale = np.where(held, 1.0, np.maximum(np.abs(p_lm), sd))  # a held parameter: 0 in both, sigma 0
    difference = float(np.max(np.abs(p_g - p_lm) / scale))
    if nw and graph.warp is None:  # GTSAM failed before it had a warp: no cross-check, no result
        difference = float("inf")
    elif nw:  # the warp's agreement on the same scale (max(|w|, sigma_w))
        w_sd = np.sqrt(np.abs(np.diag(warp_cov)))
        difference = max(difference, float(np.max(np.abs(graph.warp - lm.warp) / np.maximum(np.abs(lm.warp), w_sd))))
    converged = bool(graph.converged and lm.converged)
    ok = converged and difference <= CROSS_CHECK_TOL and np.all(np.isfinite(cov))
    focal = sd[:2] / p_lm[:2]
    if converged and (np.any(focal > MAX_FOCAL_SIGMA) or not np.all(np.isfinite(focal))):
        raise InputError(
            f"the views do not constrain the focal length (relative 1-sigma of fx, fy "
            f"{focal[0]:.2g}, {focal[1]:.2g}): the board must be seen at different tilts (boards "
            "all parallel to each other leave the focal length and the distance indistinguishable); "
            "tilt it by 20-50 degrees in different directions")
    camera = (graph.camera if ok else lm.camera).with_parameters(p_g if ok else p_lm,
                                                                  cov if np.all(np.isfinite(cov)) else None)
    if np.any(held):  # radtan4: k3 held at 0, the camera written with k1, k2, p1, p2 (Kalibr's)
        camera = type(camera)(camera.K, camera.distortion[:4], camera.size, camera.covariance)
    n = len(labels)
    status, message, poses, rms = [], [], [], np.full(n, np.nan)
    points, residuals = [], []
    solved = {k: (T, r) for k, T, r in zip(keys, lm.poses, lm.residuals)}
    for i in range(n):
        k = found_in.get(i)
        found = ("" if k is None else f"junctions read from {first_camera}" if k == 0
                 else f"board found in pass 1 ({first_camera})" if k == 1
                 else f"board found in pass {k} (with pass {k - 1}'s camera)")
        if i in solved:
            T, r = solved[i]
            out = outliers.get(i, np.zeros(0, int))
            if out.size:
                found += (f"{'; ' if found else ''}{out.size} junction{'s' if out.size > 1 else ''} left out as "
                          f"outliers: {', '.join(str(j) for j in out)}")
            status.append("used"), message.append(found), poses.append(T)
            rms[i] = _rms(r)
            points.append(inliers[i][0]), residuals.append(r)
        elif i in rejected:
            # Its residuals against the calibration, for the report.
            from ..pose.gauss_newton import gauss_newton
            from ..pose.homography import pose_from_homography

            uv, W, _ = obs[i]
            fit = gauss_newton(uv, W, camera, guess=pose_from_homography(uv, W, camera))
            status.append("rejected"), message.append(f"{found}; {rejected[i]}"), poses.append(None)
            rms[i] = _rms(fit.residuals)
            points.append(uv), residuals.append(fit.residuals)
        else:
            status.append("unreadable" if i in (unreadable or {}) else "no board")
            message.append(why.get(i, "no board")), poses.append(None)
            points.append(np.zeros((2, 0))), residuals.append(np.zeros((2, 0)))
    used_r = np.hstack([r for r, s in zip(residuals, status) if s == "used"])
    warp_m = None if not nw else (graph.warp if ok else lm.warp).copy()
    if ok:
        summary = (f"calibrated from {len(keys)} of {n} images, {M} junctions: RMS {_rms(used_r):.3f} px, "
                   f"the solvers agree to {difference:.1e}")
        if nw:
            sag, sag_sd = sag_mm(warp_m, warp_cov)
            summary += f"; the board sags {sag:.2f} +- {sag_sd:.2f} mm at its centre"
        elif flat_why is not None:
            summary += f"; the board taken as flat by warp auto: {flat_why}"
    elif not converged:
        summary = (f"calibration failed: GTSAM {'converged' if graph.converged else 'did not converge'} "
                   f"({graph.message or graph.iterations}), the hand-written LM "
                   f"{'converged' if lm.converged else 'did not converge'} ({lm.message})")
    else:
        summary = (f"calibration failed: the two solvers disagree by {difference:.2e} of a parameter "
                   f"(tolerance {CROSS_CHECK_TOL:g})")
    return Calibration(
        camera=camera,
        cov=cov,
        parameter_names=cls.parameter_names,
        images=tuple(labels),
        status=tuple(status),
        message=tuple(message),
        poses=tuple(poses),
        image_rms_px=rms,
        points=tuple(points),
        residuals=tuple(residuals),
        rms_px=_rms(used_r),
        sigma_px=sigma,
        ok=bool(ok),
        cross_check=SolverCrossCheck(gtsam=p_g.tolist(), lm=p_lm.tolist(), max_difference=difference,
                                     tolerance=CROSS_CHECK_TOL, gtsam_converged=graph.converged,
                                     lm_converged=lm.converged),
        summary=summary,
        joint_cov=joint,
        detections=tuple(None if i not in obs else (obs[i][0], obs[i][2]) for i in range(n)),
        outliers=tuple(np.asarray(outliers.get(i, np.zeros(0, int)), dtype=int) if i in solved
                       else np.zeros(0, int) for i in range(n)),
        board_distance_m=distance,
        warp_m=warp_m,
        warp_cov=warp_cov,
        warp_note=None if nw else flat_why,
    )

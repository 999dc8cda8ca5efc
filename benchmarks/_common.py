"""What the benchmark's sections share: paths, the project camera, statistics, timing, the
memory probe, and the OpenCV adapters (the peer's calls and its pose conventions).

OpenCV is the peer only: its module comes in as the ``cv2`` argument of every adapter, so that
importing this module needs no OpenCV (``python -m benchmarks`` says how to install it).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from graphpose import K_from_params

REPO = Path(__file__).resolve().parents[1]
#: The six real 640 x 480 images of the default board, with their case file.
DATA = REPO.parent / "shared" / "data" / "rob501"
#: OpenCV's stereo samples (9 x 6 junctions, 30 mm) and their lens calibrations.
SAMPLES = REPO.parent / "shared" / "data" / "opencv_samples"
#: The real camera (640 x 480); the rendered images use it too.
K_REAL = K_from_params(564.9, 564.3, 337.3, 226.5)


def scaled_K(size, K=K_REAL):
    """``K`` (a 640-pixel-wide camera) at another resolution ``size`` = (width, height).

    Pixel (u, v) covers [u - 0.5, u + 0.5], so the principal point scales about -0.5.
    """
    s = size[0] / 640
    return K_from_params(s * K[0, 0], s * K[1, 1], s * (K[0, 2] + 0.5) - 0.5, s * (K[1, 2] + 0.5) - 0.5)


# --- statistics (NaN for an empty selection, without numpy's warning) --------------------------


def median(x) -> float:
    return float(np.median(x)) if len(x) else float("nan")


def mean(x) -> float:
    return float(np.mean(x)) if len(x) else float("nan")


def rms(x) -> float:
    """Root mean square of ``x`` (any shape)."""
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else float("nan")


def params_error(params, T_true) -> np.ndarray:
    """``params - params_from_T(T_true)`` (x, y, z, roll, pitch, yaw) with the angles wrapped to (-pi, pi]."""
    from graphpose.geometry import params_from_T

    e = np.asarray(params, dtype=float) - params_from_T(T_true)
    e[3:] = (e[3:] + np.pi) % (2 * np.pi) - np.pi
    return e


def nees(cov, e) -> float:
    """Normalised estimation error squared ``e^T cov^-1 e`` (6 on average for an honest 6-D covariance)."""
    return float(e @ np.linalg.solve(cov, e))


# --- timing and memory ---------------------------------------------------------------------------


def timed(fn):
    """(seconds, result) of one call of ``fn``."""
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def median_time(fn, repeats, cpu=False):
    """Median wall time of ``fn()`` in seconds over ``repeats`` calls after one warm-up call
    (caches, lazy imports), or (wall, process CPU time) when ``cpu``."""
    fn()
    wall, proc = [], []
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        fn()
        proc.append(time.process_time() - c)
        wall.append(time.perf_counter() - t)
    return (float(np.median(wall)), float(np.median(proc))) if cpu else float(np.median(wall))


def status_mb(field) -> float:
    """A field of /proc/self/status (``VmRSS``, ``VmHWM``, ...) in MB (2**20 bytes)."""
    with open("/proc/self/status") as f:
        line = next(line for line in f if line.startswith(field + ":"))
    return int(line.split()[1]) / 1024


def rss_mb() -> float:
    """Resident memory of this process, MB (NaN where /proc/self/statm is absent)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6
    except (OSError, ValueError, IndexError):
        return float("nan")


def single_thread_environment() -> dict:
    """This process's environment with the BLAS and OpenMP pools at one thread (for probes)."""
    return dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")


# --- OpenCV, the peer --------------------------------------------------------------------------


def opencv_classic(cv2, image, pattern, window=(5, 5), flags=None, iterations=100, eps=1e-4):
    """``findChessboardCorners`` (its default flags unless ``flags``) + ``cornerSubPix``.

    ``window`` is cornerSubPix's half-size: (5, 5) is an 11 x 11 window. Returns OpenCV's
    corners, (n, 1, 2) float32, or None when it finds no board.
    """
    if flags is None:
        ok, corners = cv2.findChessboardCorners(image, pattern)
    else:
        ok, corners = cv2.findChessboardCorners(image, pattern, flags=flags)
    if not ok:
        return None
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, iterations, eps)
    return cv2.cornerSubPix(image, corners, window, (-1, -1), criteria)


def opencv_sb(cv2, image, pattern, flags=None):
    """``findChessboardCornersSB`` (``flags``, e.g. ``cv2.CALIB_CB_ACCURACY``); (n, 1, 2) or None."""
    if flags is None:
        found, corners = cv2.findChessboardCornersSB(image, pattern)
    else:
        found, corners = cv2.findChessboardCornersSB(image, pattern, flags=flags)
    return corners if found else None


def points(corners):
    """OpenCV's corners (n, 1, 2) as our pixel points (2, n) float64; None stays None."""
    return None if corners is None else corners.reshape(-1, 2).T.astype(float)


def T_WC_from_opencv(cv2, rvec, tvec) -> np.ndarray:
    """Our T_WC (camera in the target frame) from OpenCV's target-to-camera (rvec, tvec)."""
    R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=float))
    T = np.eye(4)
    T[:3, :3] = R.T
    T[:3, 3] = -R.T @ np.asarray(tvec, dtype=float).ravel()
    return T


def opencv_from_T_WC(cv2, T_WC):
    """OpenCV's (rvec, tvec (3, 1)) of the target-to-camera transform, the inverse of ``T_WC``."""
    R_cw = T_WC[:3, :3].T
    rvec, _ = cv2.Rodrigues(R_cw)
    return rvec, (-R_cw @ T_WC[:3, 3]).reshape(3, 1)


def opencv_pnp(cv2, K, Ipts, Wpts, dist=None, guess=None) -> np.ndarray:
    """OpenCV's pose from pixels (2, n) of target points (3, n): ``solvePnP`` (IPPE) +
    ``solvePnPRefineLM``, or the refinement alone from ``guess`` (a T_WC); returns T_WC."""
    obj = np.ascontiguousarray(Wpts.T, dtype=np.float64)
    img = np.ascontiguousarray(Ipts.T, dtype=np.float64)
    if guess is None:
        _, rvec, tvec = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_IPPE)
    else:
        rvec, tvec = opencv_from_T_WC(cv2, guess)
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, K, dist, rvec, tvec)
    return T_WC_from_opencv(cv2, rvec, tvec)


def match_to(reference, corners, max_px=None):
    """``corners`` (2, m) reordered as the columns of ``reference`` (2, n), each the nearest;
    None unless one-to-one (and, with ``max_px``, each within ``max_px`` pixels)."""
    d = np.hypot(reference[0][:, None] - corners[0][None, :], reference[1][:, None] - corners[1][None, :])
    order = np.argmin(d, axis=1)
    if len(set(order.tolist())) != corners.shape[1]:
        return None
    if max_px is not None and d[np.arange(len(order)), order].max() > max_px:
        return None
    return corners[:, order]

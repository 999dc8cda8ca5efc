"""Compiled core of :mod:`graphpose.detect.refine`: the saddle refinement's pixel loops.

One call per image refines every junction (:func:`refine_grid`): for each, the smoothed patch
and its squared gradients, the gradient-weighted window about the current estimate, the
weighted least-squares quadric (Lucchese & Mitra's Eqn. 4) through its 6 x 6 normal equations,
its stationary point, the re-centring until it stops moving, and the ring test that judges the
result. Each junction's rounds depend only on its own pixels, so the junctions are refined one
after the other with one patch buffer. The lens-aware refinement reuses the patches
(:func:`smoothed_patches`), the ring test (:func:`ring_crosses`) and the fit from the pixels'
own positions (:func:`fit_through_lens`), and places the pixels and the estimates in each
patch's own frame by the polynomial through its nodes (:func:`lens_disc`, :func:`lens_centres`).

The pixel work is in single precision, as the NumPy code it replaces did it (the same
operations in the same order, so the patches and weights are bit-identical); the fit sums and
solves in double. Python's :mod:`graphpose.detect.refine` checks every input first.
"""

from libc.math cimport fabs, floor, hypot, isfinite, rint, sqrt, INFINITY, NAN

from graphpose.detect._sampling cimport _ring_score

import numpy as np

ctypedef fused pixel:
    unsigned char
    double


cdef inline Py_ssize_t _clip(Py_ssize_t i, Py_ssize_t n) noexcept nogil:
    return 0 if i < 0 else (n - 1 if i >= n else i)


cdef void _patch(const pixel[:, :] image, Py_ssize_t bu, Py_ssize_t bv, Py_ssize_t half,
                 const float[::1] kernel, float[:, ::1] raw, float[:, ::1] tmp, float[:, ::1] smooth,
                 double[:, ::1] patch, float[:, ::1] grad2) noexcept nogil:
    """The smoothed patch (P x P, P = 2 half + 1) about pixel (bu, bv), its squared gradients.

    The image's pixels (clamped at its border) are smoothed by the separable kernel, first down
    the rows then along the columns, each a 'valid' correlation accumulated tap by tap; the
    gradients are central differences; all in single precision.
    """
    cdef Py_ssize_t K = kernel.shape[0], margin = K // 2 + 1
    cdef Py_ssize_t Q = 2 * (half + margin) + 1, n1 = Q - K + 1, P = 2 * half + 1
    cdef Py_ssize_t H = image.shape[0], W = image.shape[1]
    cdef Py_ssize_t r, c, j, row
    cdef float gx, gy, k
    cdef float *out
    cdef const float *src
    cdef Py_ssize_t c0 = bu - half - margin
    for r in range(Q):
        row = _clip(bv - half - margin + r, H)
        if c0 >= 0 and c0 + Q <= W:  # the patch's columns inside the image: no clamping
            for c in range(Q):
                raw[r, c] = <float>image[row, c0 + c]
        else:
            for c in range(Q):
                raw[r, c] = <float>image[row, _clip(c0 + c, W)]
    # Each output is ``kernel[0] x`` plus ``kernel[j]`` times its j-th neighbour, added in
    # increasing j (in float32): accumulated a whole row at a time, tap by tap, so that the
    # independent outputs of a row are summed side by side (the compiler vectorises the
    # contiguous loops) in the same order of operations as one output after the other.
    for r in range(n1):
        out = &tmp[r, 0]
        src = &raw[r, 0]
        k = kernel[0]
        for c in range(Q):
            out[c] = k * src[c]
        for j in range(1, K):
            src = &raw[r + j, 0]
            k = kernel[j]
            for c in range(Q):
                out[c] = out[c] + k * src[c]
    for r in range(n1):
        out = &smooth[r, 0]
        src = &tmp[r, 0]
        k = kernel[0]
        for c in range(n1):
            out[c] = k * src[c]
        for j in range(1, K):
            k = kernel[j]
            for c in range(n1):
                out[c] = out[c] + k * src[c + j]
    for r in range(P):
        for c in range(P):
            patch[r, c] = smooth[r + 1, c + 1]
            gx = <float>0.5 * (smooth[r + 1, c + 2] - smooth[r + 1, c])
            gy = <float>0.5 * (smooth[r + 2, c + 1] - smooth[r, c + 1])
            grad2[r, c] = gx * gx + gy * gy


cdef bint _solve6(double[:, ::1] N, double[::1] b) noexcept nogil:
    """Solve N x = b in place (x in b) by Gaussian elimination with partial pivoting."""
    cdef int i, j, k, p
    cdef double t, f
    for k in range(6):
        p = k
        for i in range(k + 1, 6):
            if fabs(N[i, k]) > fabs(N[p, k]):
                p = i
        if N[p, k] == 0.0:
            return False
        if p != k:
            for j in range(6):
                t = N[k, j]; N[k, j] = N[p, j]; N[p, j] = t
            t = b[k]; b[k] = b[p]; b[p] = t
        for i in range(k + 1, 6):
            f = N[i, k] / N[k, k]
            for j in range(k, 6):
                N[i, j] -= f * N[k, j]
            b[i] -= f * b[k]
    for k in range(5, -1, -1):
        t = b[k]
        for j in range(k + 1, 6):
            t -= N[k, j] * b[j]
        b[k] = t / N[k, k]
    return True


#: Which moment x^p y^q each entry of the normal matrix sums (design x^2, x y, y^2, x, y, 1).
cdef int[6] _PX = [2, 1, 0, 1, 0, 0]
cdef int[6] _PY = [0, 1, 2, 0, 1, 0]


cdef bint _solve_moments(const double[:, ::1] mom, const double[:, ::1] rhsm, double wvv,
                         double[:, ::1] N, double[::1] c, double* rms) noexcept nogil:
    """The weighted least-squares quadric from its moments, coefficients into ``c``.

    ``mom[p, q]`` sums ``w x^p y^q`` (p + q <= 4), ``rhsm[p, q]`` sums ``w v x^p y^q``
    (p + q <= 2), ``wvv`` sums ``w v^2``. The tiny ridge (1e-12 of the trace) keeps an
    all-zero-weight fit solvable (it comes out as no saddle anyway); ``rms`` is the weighted
    RMS residual, from ``sum w r^2 = sum w v^2 - c . A^T W v``. False where even the ridged
    system is singular.
    """
    cdef int i, j
    cdef double[6] rhs
    cdef double trace = 0.0, ridge, rss = 0.0
    for i in range(6):
        for j in range(6):
            N[i, j] = mom[_PX[i] + _PX[j], _PY[i] + _PY[j]]
        c[i] = rhsm[_PX[i], _PY[i]]
        rhs[i] = c[i]
        trace += N[i, i]
    ridge = 1e-12 * trace + 1e-300
    for i in range(6):
        N[i, i] += ridge
    if not _solve6(N, c):
        return False
    for i in range(6):
        rss += c[i] * rhs[i]
    rss = wvv - rss
    rms[0] = sqrt((rss if rss > 0.0 else 0.0) / (mom[0, 0] if mom[0, 0] > 1e-300 else 1e-300))
    return True


cdef void _quadric(const double[:, ::1] mom, const double[:, ::1] rhsm, double wvv, double span,
                   double size, double[:, ::1] N, double[::1] c, double* out) noexcept nogil:
    """The fit's stationary point, saddle flag and weighted RMS into ``out`` (x, y, saddle,
    rms): x, y NaN where there is no stationary point; a saddle needs ``-det`` above the floor
    ``(1e-6 span / size^2)^2`` (``span`` the grey range, ``size`` the positions' extent),
    below which a curvature is rounding noise."""
    cdef double a, b, g, d, e, det, x, y, floor_
    out[0] = NAN; out[1] = NAN; out[2] = 0.0; out[3] = NAN
    if not _solve_moments(mom, rhsm, wvv, N, c, &out[3]):
        return
    a, b, g, d, e = c[0], c[1], c[2], c[3], c[4]
    det = 4.0 * a * g - b * b
    if det == 0.0:
        return
    x = (-2.0 * g * d + b * e) / det
    y = (b * d - 2.0 * a * e) / det
    if not (isfinite(x) and isfinite(y)):
        return
    out[0] = x
    out[1] = y
    if span > 1e-12:
        floor_ = 1e-6 * span / (size * size)
        floor_ = floor_ * floor_
    else:
        floor_ = INFINITY
    out[2] = 1.0 if -det > floor_ else 0.0


cdef inline void _clear(double[:, ::1] mom, double[:, ::1] rhsm) noexcept nogil:
    cdef int p, q
    for p in range(5):
        for q in range(5):
            mom[p, q] = 0.0
    for p in range(3):
        for q in range(3):
            rhsm[p, q] = 0.0


cdef inline void _add_pixel(double* row, double wt, double x, double v) noexcept nogil:
    """One pixel of weight ``wt`` at column offset ``x`` with grey value ``v`` into its row's
    sums: ``w x^p`` (p <= 4), then ``w v x^p`` (p <= 2), then ``w v^2``."""
    cdef double x2 = x * x, wv = wt * v
    row[0] += wt
    row[1] += wt * x
    row[2] += wt * x2
    row[3] += wt * x2 * x
    row[4] += wt * x2 * x2
    row[5] += wv
    row[6] += wv * x
    row[7] += wv * x2
    row[8] += wv * v


cdef inline void _add_row(double[:, ::1] mom, double[:, ::1] rhsm, const double* row, double y) noexcept nogil:
    """A row's sums (:func:`_add_pixel`) times the powers of its ``y`` into the moments."""
    cdef double yq = 1.0
    cdef int q
    for q in range(5):
        mom[0, q] += row[0] * yq
        if q <= 3:
            mom[1, q] += row[1] * yq
        if q <= 2:
            mom[2, q] += row[2] * yq
            rhsm[0, q] += row[5] * yq
        if q <= 1:
            mom[3, q] += row[3] * yq
            rhsm[1, q] += row[6] * yq
        if q == 0:
            mom[4, 0] += row[4]
            rhsm[2, 0] += row[7]
        yq *= y


cdef void _grid_moments(const double[:, ::1] patch, const double[:, ::1] weight, double cx, double cy,
                        double[:, ::1] mom, double[:, ::1] rhsm, double* wvv) noexcept nogil:
    """Moments of a weighted patch on its pixel grid, about (cx, cy): row by row, the sums
    over the row's columns times the powers of its y (pixels of zero weight skipped)."""
    cdef Py_ssize_t h = patch.shape[0], w = patch.shape[1], r, col
    cdef double[9] row
    cdef double u = 0.0, wt
    cdef int k
    _clear(mom, rhsm)
    for r in range(h):
        for k in range(9):
            row[k] = 0.0
        for col in range(w):
            wt = weight[r, col]
            if wt != 0.0:
                _add_pixel(row, wt, col - cx, patch[r, col])
        _add_row(mom, rhsm, row, r - cy)
        u += row[8]
    wvv[0] = u


cdef void _window_moments(const double[:, ::1] patch, const float[:, ::1] grad2, double lu, double lv,
                          double radius, double[:, ::1] mom, double[:, ::1] rhsm,
                          double* wvv) noexcept nogil:
    """The moments of the fit (as :func:`_grid_moments`, about the patch's centre) with the
    window's weights about the estimate at (lu, lv), patch pixels: the squared gradient times
    a smooth taper of the window ``radius``, over the squared distance (at least 1), in single
    precision (float32 taper and weights: the refined junctions, and the records and figures
    built on them, are defined at that precision). Rows and columns beyond the
    radius (where the taper is zero) are skipped; a column margin of one pixel keeps the
    single-precision test the judge of the edge.
    """
    cdef Py_ssize_t P = grad2.shape[0], half = P // 2, r, col, lo, hi
    cdef float inv_r2 = <float>(1.0 / (radius * radius)), one = 1.0, zero = 0.0
    cdef float dy2, r2, taper
    cdef double[9] row
    cdef double t, wt, u = 0.0
    cdef int k
    _clear(mom, rhsm)
    lo = <Py_ssize_t>floor(lu - radius) - 1
    hi = <Py_ssize_t>floor(lu + radius) + 2
    lo = 0 if lo < 0 else lo
    hi = P if hi > P else hi
    for r in range(P):
        t = r - lv
        dy2 = <float>(t * t)
        if dy2 * inv_r2 >= one:
            continue
        for k in range(9):
            row[k] = 0.0
        for col in range(lo, hi):
            t = col - lu
            r2 = dy2 + <float>(t * t)
            taper = one - r2 * inv_r2
            if taper <= zero:
                continue
            taper = taper * taper
            wt = (taper * grad2[r, col]) / (r2 if r2 > one else one)
            if wt != 0.0:
                _add_pixel(row, wt, col - half, patch[r, col])
        _add_row(mom, rhsm, row, r - half)
        u += row[8]
    wvv[0] = u


cdef bint _crosses(const double[:, ::1] patch, double cu, double cv, double radius,
                   const double[::1] cosines, const double[::1] sines) noexcept nogil:
    """The ring test of the search (:func:`graphpose.detect._sampling._ring_score`: the ChESS
    sum, opposite samples against the quarter-turned pair, must exceed twice the diff,
    opposite samples against each other) on 16 bilinear samples of the refinement's own
    double patch (clamped at its edge) on a circle about (cu, cv)."""
    cdef double[16] ring
    cdef Py_ssize_t P = patch.shape[0], k, r0, c0, r1, c1
    cdef double x, y, tx, ty, score, theta, contrast
    for k in range(16):
        x = cu + radius * cosines[k]
        y = cv + radius * sines[k]
        x = 0.0 if x < 0.0 else (P - 1.0 if x > P - 1.0 else x)
        y = 0.0 if y < 0.0 else (P - 1.0 if y > P - 1.0 else y)
        c0 = <Py_ssize_t>floor(x)
        r0 = <Py_ssize_t>floor(y)
        tx, ty = x - c0, y - r0
        c1 = c0 + 1 if c0 + 1 < P else c0
        r1 = r0 + 1 if r0 + 1 < P else r0
        ring[k] = (1.0 - ty) * ((1.0 - tx) * patch[r0, c0] + tx * patch[r0, c1]) \
            + ty * ((1.0 - tx) * patch[r1, c0] + tx * patch[r1, c1])
    _ring_score(ring, &score, &theta, &contrast)
    return score > 0.0


cdef inline bint _inside(double bu, double bv, double radius, Py_ssize_t H, Py_ssize_t W) noexcept nogil:
    return bu - radius >= 0 and bu + radius <= W - 1 and bv - radius >= 0 and bv + radius <= H - 1


cdef double _range(const double* values, Py_ssize_t n) noexcept nogil:
    """The grey range (max - min) of ``n`` contiguous values."""
    cdef Py_ssize_t k
    cdef double lo = values[0], hi = values[0]
    for k in range(1, n):
        if values[k] < lo:
            lo = values[k]
        if values[k] > hi:
            hi = values[k]
    return hi - lo


def _buffers(Py_ssize_t half, Py_ssize_t K):
    margin = K // 2 + 1
    Q = 2 * (half + margin) + 1
    n1 = Q - K + 1
    return (np.empty((Q, Q), np.float32), np.empty((n1, Q), np.float32), np.empty((n1, n1), np.float32))


def refine_grid(const pixel[:, :] image, double[:, ::1] current, const double[::1] radius,
                const float[::1] kernel, Py_ssize_t half, int max_iter, double tol, double slack,
                const double[::1] cosines, const double[::1] sines,
                unsigned char[::1] trusted, double[::1] residual):
    """Re-centred, gradient-weighted saddle fits of every junction, in place.

    Parameters
    ----------
    image : (H, W) uint8 or float64 memoryview
        Grey pixels.
    current : (2, m) float64
        Start positions (u, v), pixels; replaced by the refined ones (the last good estimate
        where a fit failed).
    radius : (m,) float64
        Window radii, pixels (>= 2, at most ``half - slack``).
    kernel : (K,) float32
        Symmetric smoothing taps.
    half : int
        Patch half-size, pixels: patches are ``2 half + 1`` square.
    max_iter, tol, slack
        At most ``max_iter`` fits per junction; converged when a step is below ``tol`` px; a
        new patch when the estimate is over ``slack - 0.5`` px from the patch's centre pixel.
    cosines, sines : (16,) float64
        The ring test's directions.
    trusted : (m,) uint8, out
        Converged, its window inside the image, and a cross-junction by the ring test (on a
        ring of 0.6 of the radius).
    residual : (m,) float64, out
        Weighted RMS residual of the last fit, the image's grey units; NaN where a fit failed.
    """
    cdef Py_ssize_t m = current.shape[1], H = image.shape[0], W = image.shape[1], P = 2 * half + 1
    raw_, tmp_, smooth_ = _buffers(half, kernel.shape[0])
    cdef float[:, ::1] raw = raw_, tmp = tmp_, smooth = smooth_
    cdef double[:, ::1] patch = np.empty((P, P))
    cdef float[:, ::1] grad2 = np.empty((P, P), np.float32)
    cdef double[:, ::1] mom = np.empty((5, 5)), rhsm = np.empty((3, 3)), N = np.empty((6, 6))
    cdef double[::1] c = np.empty(6)
    cdef double[4] fit
    cdef double wvv, span, u, v, bu, bv, nu, nv, step, res, size = P / 2.0
    cdef Py_ssize_t i, it
    cdef int state
    cdef bint inside
    with nogil:
        for i in range(m):
            u, v = current[0, i], current[1, i]
            bu, bv = rint(u), rint(v)
            _patch(image, <Py_ssize_t>bu, <Py_ssize_t>bv, half, kernel, raw, tmp, smooth, patch, grad2)
            inside = _inside(bu, bv, radius[i], H, W)
            span = _range(&patch[0, 0], P * P)
            state = 0  # moving; 1 converged, 2 failed
            res = NAN
            for it in range(max_iter):
                if fabs(u - bu) > slack - 0.5 or fabs(v - bv) > slack - 0.5:
                    bu, bv = rint(u), rint(v)
                    _patch(image, <Py_ssize_t>bu, <Py_ssize_t>bv, half, kernel, raw, tmp, smooth, patch, grad2)
                    inside = _inside(bu, bv, radius[i], H, W)
                    span = _range(&patch[0, 0], P * P)
                _window_moments(patch, grad2, u - bu + half, v - bv + half, radius[i], mom, rhsm, &wvv)
                _quadric(mom, rhsm, wvv, span, size, N, c, fit)
                res = fit[3]
                # The stationary point in patch pixels, then in the image's.
                nu = bu + (fit[0] + half) - half
                nv = bv + (fit[1] + half) - half
                step = hypot(nu - u, nv - v)
                if not (fit[2] != 0.0 and fit[0] + half >= 0 and fit[0] + half <= P - 1
                        and fit[1] + half >= 0 and fit[1] + half <= P - 1
                        and isfinite(step) and step < radius[i]):
                    state = 2
                    break
                u, v = nu, nv
                if step < tol:
                    state = 1
                    break
            current[0, i], current[1, i] = u, v
            residual[i] = NAN if state == 2 else res
            trusted[i] = state == 1 and inside and _crosses(
                patch, u - bu + half, v - bv + half, 0.6 * radius[i], cosines, sines)


def smoothed_patches(const pixel[:, :] image, const Py_ssize_t[:, ::1] base, Py_ssize_t half,
                     const float[::1] kernel, double[:, :, ::1] patches, float[:, :, ::1] grad2):
    """The smoothed patches (m, P, P) about ``base`` (2, m) and their squared gradients, in
    place (as :func:`refine_grid` makes them), for the lens-aware refinement."""
    cdef Py_ssize_t m = base.shape[1], i
    raw_, tmp_, smooth_ = _buffers(half, kernel.shape[0])
    cdef float[:, ::1] raw = raw_, tmp = tmp_, smooth = smooth_
    with nogil:
        for i in range(m):
            _patch(image, base[0, i], base[1, i], half, kernel, raw, tmp, smooth, patches[i], grad2[i])


def ring_crosses(const double[:, :, ::1] patches, const double[:, ::1] centre, const double[::1] radius,
                 const double[::1] cosines, const double[::1] sines, unsigned char[::1] out):
    """The ring test of :func:`refine_grid` on each patch about ``centre`` (2, m), patch pixels."""
    cdef Py_ssize_t i
    with nogil:
        for i in range(patches.shape[0]):
            out[i] = _crosses(patches[i], centre[0, i], centre[1, i], radius[i], cosines, sines)


def fit_weighted_grid(const double[:, :, ::1] patches, const double[:, :, ::1] weights,
                      double[:, ::1] coeffs, double[::1] rms):
    """Weighted least-squares quadrics of patches (m, h, w) on their pixel grids, about the
    patches' centres: coefficients (6, m) (alpha, beta, gamma, delta, epsilon, zeta) and the
    weighted RMS residuals (m,), in place; NaN where the normal equations are singular even
    with the ridge."""
    cdef Py_ssize_t m = patches.shape[0], h = patches.shape[1], w = patches.shape[2], i, k
    cdef double[:, ::1] mom = np.empty((5, 5)), rhsm = np.empty((3, 3)), N = np.empty((6, 6))
    cdef double[::1] c = np.empty(6)
    cdef double wvv
    with nogil:
        for i in range(m):
            _grid_moments(patches[i], weights[i], (w - 1) / 2.0, (h - 1) / 2.0, mom, rhsm, &wvv)
            if not _solve_moments(mom, rhsm, wvv, N, c, &rms[i]):
                for k in range(6):
                    c[k] = NAN
                rms[i] = NAN
            for k in range(6):
                coeffs[k, i] = c[k]


def fit_through_lens(const double[:, ::1] x, const double[:, ::1] y, const double[:, ::1] values,
                     const double[:, ::1] grad2, const Py_ssize_t[::1] act, const double[:, ::1] centre,
                     const double[::1] radius, double size, double[:, ::1] points,
                     unsigned char[::1] saddle, double[::1] rms):
    """Saddle fits with every pixel at its own (undistorted) position, for the lens-aware
    refinement: patch ``act[i]``'s pixels ``k`` at ``(x, y)[act[i], k]`` with grey values and
    squared gradients, weighted by the window of :func:`refine_grid` (in double) about
    ``centre[:, i]`` with ``radius[i]`` (no weight where the centre is not finite). Points
    (2, a) in the same coordinates (NaN where there is none), saddle flags and weighted RMS
    residuals, in place; ``size`` is the positions' extent, pixels, for the saddle's floor."""
    cdef Py_ssize_t a = act.shape[0], n = x.shape[1], i, j, k, p, q
    cdef double[:, ::1] mom = np.empty((5, 5)), rhsm = np.empty((3, 3)), N = np.empty((6, 6))
    cdef double[::1] c = np.empty(6)
    cdef double[4] fit
    cdef double[21] acc
    cdef double x1, y1, x2, y2, xy, cu, cv, inv_r2, dx, dy, r2, wt, wv, v, wvv
    cdef bint known
    with nogil:
        for i in range(a):
            j = act[i]
            cu, cv = centre[0, i], centre[1, i]
            known = isfinite(cu) and isfinite(cv)
            inv_r2 = 1.0 / (radius[i] * radius[i])
            for p in range(21):
                acc[p] = 0.0
            wvv = 0.0
            for k in range(n if known else 0):
                v = values[j, k]
                dx = x[j, k] - cu
                dy = y[j, k] - cv
                r2 = dx * dx + dy * dy
                wt = 1.0 - r2 * inv_r2
                if wt <= 0.0:
                    continue
                wt = wt * wt * grad2[j, k] / (r2 if r2 > 1.0 else 1.0)
                if wt == 0.0:
                    continue
                # The monomials as products of the squares (as the NumPy fit formed them),
                # summed in locals: weight times x^p y^q (p + q <= 4), grey value times
                # weight times x^p y^q (p + q <= 2).
                x1, y1 = x[j, k], y[j, k]
                x2, y2, xy = x1 * x1, y1 * y1, x1 * y1
                wv = wt * v
                acc[0] += wt; acc[1] += x1 * wt; acc[2] += x2 * wt; acc[3] += x2 * x1 * wt
                acc[4] += x2 * x2 * wt; acc[5] += y1 * wt; acc[6] += xy * wt; acc[7] += x2 * y1 * wt
                acc[8] += x2 * xy * wt; acc[9] += y2 * wt; acc[10] += x1 * y2 * wt
                acc[11] += x2 * y2 * wt; acc[12] += y2 * y1 * wt; acc[13] += xy * y2 * wt
                acc[14] += y2 * y2 * wt
                acc[15] += wv; acc[16] += x1 * wv; acc[17] += x2 * wv; acc[18] += y1 * wv
                acc[19] += xy * wv; acc[20] += y2 * wv
                wvv += wv * v
            mom[0, 0], mom[1, 0], mom[2, 0], mom[3, 0], mom[4, 0] = acc[0], acc[1], acc[2], acc[3], acc[4]
            mom[0, 1], mom[1, 1], mom[2, 1], mom[3, 1] = acc[5], acc[6], acc[7], acc[8]
            mom[0, 2], mom[1, 2], mom[2, 2] = acc[9], acc[10], acc[11]
            mom[0, 3], mom[1, 3], mom[0, 4] = acc[12], acc[13], acc[14]
            rhsm[0, 0], rhsm[1, 0], rhsm[2, 0] = acc[15], acc[16], acc[17]
            rhsm[0, 1], rhsm[1, 1], rhsm[0, 2] = acc[18], acc[19], acc[20]
            _quadric(mom, rhsm, wvv, _range(&values[j, 0], n), size if size > 1.0 else 1.0, N, c, fit)
            points[0, i], points[1, i] = fit[0], fit[1]
            saddle[i] = fit[2] != 0.0
            rms[i] = fit[3]


def lens_disc(const double[:, :, :, ::1] V, const double[:, ::1] L, const Py_ssize_t[::1] rows,
              const Py_ssize_t[::1] cols, const double[:, :, ::1] patches, const float[:, :, ::1] grad2,
              double[:, ::1] x, double[:, ::1] y, double[:, ::1] values, double[:, ::1] g2):
    """The disc pixels of each patch placed through the lens, for the lens-aware fit, in place.

    Pixel ``k`` of patch ``j``, at (``rows[k]``, ``cols[k]``) of its patch, goes to the
    polynomial through the patch's 5 x 5 node values ``V`` (2, m, 5, 5) [row node, column
    node] by the Lagrange basis ``L`` (5, P) at the patch's offsets, less the middle node (the
    patch's origin): ``x, y`` (m, n); its grey value and squared gradient into ``values, g2``
    (m, n). A pixel without a finite position (a node the lens does not image) gets
    position 0 and weight 0.
    """
    cdef Py_ssize_t m = V.shape[1], n = rows.shape[0], P = L.shape[1], j, k, a, b, c, r, col
    cdef double[:, :, ::1] VL = np.empty((2, 5, P))
    cdef double s, px, py, ox, oy
    with nogil:
        for j in range(m):
            # The column basis applied first: VL[c, a, col] = sum_b V[c, j, a, b] L[b, col].
            for c in range(2):
                for a in range(5):
                    for col in range(P):
                        s = 0.0
                        for b in range(5):
                            s = s + V[c, j, a, b] * L[b, col]
                        VL[c, a, col] = s
            ox, oy = V[0, j, 2, 2], V[1, j, 2, 2]
            for k in range(n):
                r, col = rows[k], cols[k]
                px = 0.0
                py = 0.0
                for a in range(5):
                    px = px + L[a, r] * VL[0, a, col]
                    py = py + L[a, r] * VL[1, a, col]
                px = px - ox
                py = py - oy
                values[j, k] = patches[j, r, col]
                if isfinite(px) and isfinite(py):
                    x[j, k], y[j, k] = px, py
                    g2[j, k] = grad2[j, r, col]
                else:
                    x[j, k], y[j, k], g2[j, k] = 0.0, 0.0, 0.0


cdef inline void _basis(double t, double half, double* L) noexcept nogil:
    """The Lagrange basis (5,) of the nodes ``linspace(-half, half, 5)`` at ``t``."""
    cdef double nodes[5]
    cdef int a, b
    for a in range(5):
        nodes[a] = -half + 0.5 * half * a
    for a in range(5):
        L[a] = 1.0
        for b in range(5):
            if b != a:
                L[a] = L[a] * (t - nodes[b]) / (nodes[a] - nodes[b])


def lens_centres(const double[:, :, :, ::1] V, const Py_ssize_t[::1] act, const double[:, ::1] offset,
                 double half, double[:, ::1] out):
    """The positions (2, a), in their patches' frames about the patches' origins, of points at
    ``offset`` (2, a) raw pixels from the bases of patches ``act`` (a,): the polynomial through
    each patch's node values ``V`` (2, m, 5, 5), as :func:`lens_disc` places the pixels."""
    cdef Py_ssize_t i, j, a, b, c
    cdef double Lu[5]
    cdef double Lv[5]
    cdef double s
    with nogil:
        for i in range(act.shape[0]):
            j = act[i]
            _basis(offset[0, i], half, Lu)
            _basis(offset[1, i], half, Lv)
            for c in range(2):
                s = 0.0
                for a in range(5):
                    for b in range(5):
                        s = s + V[c, j, a, b] * Lv[a] * Lu[b]
                out[c, i] = s - V[c, j, 2, 2]

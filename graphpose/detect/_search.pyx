"""Compiled loops of the board search (:mod:`graphpose.detect.search`): bilinear samples, the
ring test, and the saddle response with its local maxima, each a whole loop per call.

Bilinear sampling follows ``scipy.ndimage.map_coordinates(order=1, mode="nearest")``: the
coordinate is clamped to the image, the four neighbours' grey levels are weighted in double
precision in the order (row, column) ``(0, 0), (0, 1), (1, 0), (1, 1)``, and a neighbour past
the last row or column repeats it. The callers have checked shapes and lengths.
"""

from libc.math cimport atan2, cos, floor, sin, fabs, M_PI

ctypedef fused grey_t:
    unsigned char
    unsigned short
    float
    double


cdef double _COS[16]
cdef double _SIN[16]
cdef double _COS2[16]
cdef double _SIN2[16]
cdef int _q
for _q in range(16):
    _COS[_q] = cos(_q * (M_PI / 8))
    _SIN[_q] = sin(_q * (M_PI / 8))
    _COS2[_q] = cos(2 * _q * (M_PI / 8))
    _SIN2[_q] = sin(2 * _q * (M_PI / 8))


cdef inline double _bilinear(const grey_t[:, :] a, double x, double y) noexcept nogil:
    """One sample of ``a`` at column ``x``, row ``y`` (see the module docstring)."""
    cdef Py_ssize_t h = a.shape[0], w = a.shape[1]
    cdef Py_ssize_t i0, j0, i1, j1
    cdef double fx, fy
    if x < 0:
        x = 0
    elif x > w - 1:
        x = w - 1
    if y < 0:
        y = 0
    elif y > h - 1:
        y = h - 1
    j0 = <Py_ssize_t>floor(x)
    i0 = <Py_ssize_t>floor(y)
    fx = x - j0
    fy = y - i0
    j1 = j0 + 1 if j0 + 1 < w else w - 1
    i1 = i0 + 1 if i0 + 1 < h else h - 1
    return (a[i0, j0] * (1.0 - fy) * (1.0 - fx) + a[i0, j1] * (1.0 - fy) * fx
            + a[i1, j0] * fy * (1.0 - fx) + a[i1, j1] * fy * fx)


def bilinear(const grey_t[:, :] a, const double[::1] x, const double[::1] y, double[::1] out):
    """``out[k]`` = the bilinear sample of ``a`` at column ``x[k]``, row ``y[k]``."""
    cdef Py_ssize_t k
    with nogil:
        for k in range(x.shape[0]):
            out[k] = _bilinear(a, x[k], y[k])


def bilinear_mean3x3(const grey_t[:, :] a, const double[::1] x, const double[::1] y, double reach, double[::1] out):
    """``out[k]`` = the mean of the 3 x 3 bilinear samples of ``a`` ``reach`` apart around
    column ``x[k]``, row ``y[k]`` (rows outer, columns inner, summed in that order)."""
    cdef Py_ssize_t k
    cdef int p, q
    cdef double total
    with nogil:
        for k in range(x.shape[0]):
            total = 0.0
            for p in range(-1, 2):
                for q in range(-1, 2):
                    total += _bilinear(a, x[k] + q * reach, y[k] + p * reach)
            out[k] = total / 9.0
    return None


cdef inline void _ring_score(double *ring, double *score, double *theta, double *contrast) noexcept nogil:
    """The ring test on 16 samples (see :func:`graphpose.detect.search.ring_test`)."""
    cdef double mean = 0.0, total = 0.0, diff = 0.0, s2 = 0.0, c2 = 0.0, lo, hi, d
    cdef int q
    for q in range(16):
        mean += ring[q]
    mean /= 16.0
    lo = hi = ring[0] - mean
    for q in range(16):
        ring[q] -= mean
        if ring[q] < lo:
            lo = ring[q]
        if ring[q] > hi:
            hi = ring[q]
        s2 += ring[q] * _SIN2[q]
        c2 += ring[q] * _COS2[q]
    for q in range(4):
        total += fabs(ring[q] + ring[q + 8] - ring[q + 4] - ring[q + 12])
    for q in range(8):
        diff += fabs(ring[q] - ring[q + 8])
    d = total + diff
    if d < 1e-12:
        d = 1e-12
    score[0] = (total - 2 * diff) / d
    theta[0] = 0.5 * atan2(s2, c2)
    contrast[0] = hi - lo


def ring_image(const float[:, :] a, const double[::1] x, const double[::1] y, const double[::1] radius,
               double[::1] score, double[::1] theta, double[::1] contrast):
    """The ring test at centres (``x[k]``, ``y[k]``) of ``a``, radius ``radius[k]``, all in
    ``a``'s pixels."""
    cdef double ring[16]
    cdef Py_ssize_t k
    cdef int q
    with nogil:
        for k in range(x.shape[0]):
            for q in range(16):
                ring[q] = <float>_bilinear(a, x[k] + radius[k] * _COS[q], y[k] + radius[k] * _SIN[q])
            _ring_score(ring, &score[k], &theta[k], &contrast[k])


def ring_patches(const float[:, :, :] patches, const double[::1] x, const double[::1] y, const double[::1] radius,
                 double[::1] score, double[::1] theta, double[::1] contrast):
    """The ring test of patch ``k`` of a stack (m, h, w) at its own column ``x[k]``, row
    ``y[k]``, radius ``radius[k]``, in patch pixels."""
    cdef double ring[16]
    cdef Py_ssize_t k
    cdef int q
    with nogil:
        for k in range(x.shape[0]):
            for q in range(16):
                ring[q] = <float>_bilinear(patches[k], x[k] + radius[k] * _COS[q], y[k] + radius[k] * _SIN[q])
            _ring_score(ring, &score[k], &theta[k], &contrast[k])


def saddle_peaks(const float[:, ::1] S, float[:, ::1] r, float[:, ::1] rowmax, long[::1] rows, long[::1] cols):
    """The saddle response of :func:`graphpose.detect.search.find_candidates` and its peaks.

    ``r`` (h - 2, w - 2) gets ``Ixy^2 - Ixx Iyy`` of the smoothed image ``S`` (h, w) at its
    interior pixels, in float32 with NumPy's order of operations (``Ixx = (S[x+1] - 2 S) +
    S[x-1]``, ``Ixy = 0.25 (((S[+,+] - S[+,-]) - S[-,+]) + S[-,-])``); ``rowmax`` (as ``r``)
    is scratch for its 1 x 3 maxima; ``rows``/``cols`` (each at least r's pixel count long)
    get the pixels of ``r`` above 0 that no pixel of their 3 x 3 neighbourhood (edges
    repeated) exceeds, row-major. Returns their count.
    """
    cdef Py_ssize_t h = r.shape[0], w = r.shape[1], i, j, n = 0, i0, i1
    cdef float ixx, iyy, ixy, c, m, two = 2.0, quarter = 0.25
    with nogil:
        for i in range(h):
            for j in range(w):
                ixx = (S[i + 1, j + 2] - two * S[i + 1, j + 1]) + S[i + 1, j]
                iyy = (S[i + 2, j + 1] - two * S[i + 1, j + 1]) + S[i, j + 1]
                ixy = quarter * (((S[i + 2, j + 2] - S[i + 2, j]) - S[i, j + 2]) + S[i, j])
                r[i, j] = ixy * ixy - ixx * iyy
            for j in range(w):
                m = r[i, j]
                if j > 0 and r[i, j - 1] > m:
                    m = r[i, j - 1]
                if j + 1 < w and r[i, j + 1] > m:
                    m = r[i, j + 1]
                rowmax[i, j] = m
        for i in range(h):
            i0 = i - 1 if i > 0 else 0
            i1 = i + 1 if i + 1 < h else h - 1
            for j in range(w):
                c = r[i, j]
                if c > 0 and rowmax[i, j] <= c and rowmax[i0, j] <= c and rowmax[i1, j] <= c:
                    rows[n] = i
                    cols[n] = j
                    n += 1
    return n

"""Compiled loops of the board search (:mod:`graphpose.detect.search`): bilinear samples, the
ring test, and the saddle response with its local maxima, each a whole loop per call.

Bilinear sampling and the ring test's arithmetic are ``_sampling.pxd``'s (shared with
``_lattice.pyx``). The callers have checked shapes and lengths.
"""

from graphpose.detect._sampling cimport grey_t, _COS, _SIN, _bilinear, _ring_score


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

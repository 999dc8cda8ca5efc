"""Compiled loops of the board search (:mod:`graphpose.detect.search`): bilinear samples, the
ring test, and the saddle response with its local maxima, each a whole loop per call.

Bilinear sampling and the ring test's arithmetic are ``_sampling.pxd``'s (shared with
``_lattice.pyx``). The callers have checked shapes and lengths.
"""

from graphpose.detect._sampling cimport grey_t, _bilinear, _ring_at


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
    cdef Py_ssize_t k
    with nogil:
        for k in range(x.shape[0]):
            _ring_at(a, x[k], y[k], radius[k], &score[k], &theta[k], &contrast[k])


def saddle_peaks(const float[:, ::1] S, float[:, ::1] r, float[:, ::1] rowmax, unsigned char[:, ::1] peak):
    """The saddle response of :func:`graphpose.detect.search.find_candidates` and its peaks.

    ``r`` (h - 2, w - 2) gets ``Ixy^2 - Ixx Iyy`` of the smoothed image ``S`` (h, w) at its
    interior pixels, in float32 with NumPy's order of operations (``Ixx = (S[x+1] - 2 S) +
    S[x-1]``, ``Ixy = 0.25 (((S[+,+] - S[+,-]) - S[-,+]) + S[-,-])``); ``rowmax`` (as ``r``)
    is scratch for its 1 x 3 maxima; ``peak`` (as ``r``) gets 1 at the pixels of ``r`` above
    0 that no pixel of their 3 x 3 neighbourhood (edges repeated) exceeds, else 0. Each row
    is a plain loop over contiguous floats, which the compiler vectorises.
    """
    cdef Py_ssize_t h = r.shape[0], w = r.shape[1], i, j
    cdef const float *s0
    cdef const float *s1
    cdef const float *s2
    cdef float *ri
    cdef float *mi
    cdef const float *m0
    cdef const float *m2
    cdef unsigned char *pi
    cdef float ixx, iyy, ixy, c, m, two = 2.0, quarter = 0.25
    if h < 1 or w < 1:
        return
    with nogil:
        for i in range(h):
            s0, s1, s2, ri, mi = &S[i, 0], &S[i + 1, 0], &S[i + 2, 0], &r[i, 0], &rowmax[i, 0]
            for j in range(w):
                ixx = (s1[j + 2] - two * s1[j + 1]) + s1[j]
                iyy = (s2[j + 1] - two * s1[j + 1]) + s0[j + 1]
                ixy = quarter * (((s2[j + 2] - s2[j]) - s0[j + 2]) + s0[j])
                ri[j] = ixy * ixy - ixx * iyy
            mi[0] = ri[0] if w == 1 or ri[0] >= ri[1] else ri[1]
            for j in range(1, w - 1):
                m = ri[j - 1] if ri[j - 1] > ri[j] else ri[j]
                mi[j] = m if m >= ri[j + 1] else ri[j + 1]
            if w > 1:
                mi[w - 1] = ri[w - 1] if ri[w - 1] >= ri[w - 2] else ri[w - 2]
        for i in range(h):
            ri, pi = &r[i, 0], &peak[i, 0]
            m0 = &rowmax[i - 1 if i > 0 else 0, 0]
            mi = &rowmax[i, 0]
            m2 = &rowmax[i + 1 if i + 1 < h else h - 1, 0]
            for j in range(w):
                c = ri[j]
                pi[j] = (c > 0) & (mi[j] <= c) & (m0[j] <= c) & (m2[j] <= c)

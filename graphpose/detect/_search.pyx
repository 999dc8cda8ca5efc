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


cdef inline void _peak_row(const float *ri, const float *m0, const float *mi, const float *m2, unsigned char *pi,
                           Py_ssize_t w) noexcept nogil:
    """One row of the peaks: 1 where ``ri`` is above 0 and no 1 x 3 maximum of the rows above
    (``m0``), its own (``mi``) and below (``m2``) exceeds it."""
    cdef Py_ssize_t j
    cdef float c
    for j in range(w):
        c = ri[j]
        pi[j] = (c > 0) & (mi[j] <= c) & (m0[j] <= c) & (m2[j] <= c)


def saddle_peaks(const float[:, ::1] S, float[:, ::1] r, float[:, ::1] rowmax, unsigned char[:, ::1] peak):
    """The saddle response of :func:`graphpose.detect.search.find_candidates` and its peaks.

    ``r`` (h - 2, w - 2) gets ``Ixy^2 - Ixx Iyy`` of the smoothed image ``S`` (h, w) at its
    interior pixels, in float32 with NumPy's order of operations (``Ixx = (S[x+1] - 2 S) +
    S[x-1]``, ``Ixy = 0.25 (((S[+,+] - S[+,-]) - S[-,+]) + S[-,-])``); ``rowmax`` (3, w - 2)
    is scratch for the 1 x 3 maxima of three rows of it at a time; ``peak`` (as ``r``) gets 1
    at the pixels of ``r`` above 0 that no pixel of their 3 x 3 neighbourhood (edges
    repeated) exceeds, else 0. Row by row, each a plain loop over contiguous floats, which the
    compiler vectorises: a row's peaks are written once the row below it has its maxima.
    """
    cdef Py_ssize_t h = r.shape[0], w = r.shape[1], i, j
    cdef const float *s0
    cdef const float *s1
    cdef const float *s2
    cdef float *ri
    cdef float *mi
    cdef float ixx, iyy, ixy, m, two = 2.0, quarter = 0.25
    if h < 1 or w < 1:
        return
    with nogil:
        for i in range(h):
            s0, s1, s2, ri, mi = &S[i, 0], &S[i + 1, 0], &S[i + 2, 0], &r[i, 0], &rowmax[i % 3, 0]
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
            if i >= 1:  # row i - 1 has the maxima of the rows on either side now
                _peak_row(&r[i - 1, 0], &rowmax[(i - 2 if i >= 2 else 0) % 3, 0], &rowmax[(i - 1) % 3, 0], mi,
                          &peak[i - 1, 0], w)
        # The last row: the row below it is itself (edges repeated).
        _peak_row(&r[h - 1, 0], &rowmax[(h - 2 if h >= 2 else 0) % 3, 0], &rowmax[(h - 1) % 3, 0],
                  &rowmax[(h - 1) % 3, 0], &peak[h - 1, 0], w)


cdef inline Py_ssize_t _reflect(Py_ssize_t k, Py_ssize_t n) noexcept nogil:
    """Index ``k`` folded into [0, n) by reflection about the edges' outer half-pixel
    (``d c b a | a b c d | d c b a``), for kernels no longer than the line."""
    while k < 0 or k >= n:
        if k < 0:
            k = -k - 1
        else:
            k = 2 * n - k - 1
    return k


def gaussian_smooth(const float[:, ::1] a, const double[::1] taps, float[:, ::1] out, double[::1] line):
    """Separable smoothing of ``a`` (h, w) by the symmetric kernel whose centre and one side
    are ``taps`` (``taps[0]`` the centre, ``taps[k]`` the weight k pixels away), edges
    reflected about their outer half-pixel; down the columns (rounded to float32), then along
    the rows into ``out`` (float32), each sum in double precision. ``line`` is scratch of
    length ``2 w + 2 (taps.shape[0] - 1)``.

    Each pass sums the centre first, then the pairs ``k`` pixels either side in increasing
    ``k``, over a whole line at a time (contiguous, which the compiler vectorises). One output
    row at a time: its column sums, rounded to float32, padded by reflection, then summed
    along the row (no image-sized intermediate).
    """
    cdef Py_ssize_t h = a.shape[0], w = a.shape[1], r = taps.shape[0] - 1, i, j, k
    cdef double t
    cdef const float *up
    cdef const float *down
    cdef float *o
    cdef double *acc
    cdef double *pad
    if h == 0 or w == 0:
        return  # nothing to smooth (and no line to reflect about)
    acc = &line[0]
    pad = &line[w]
    with nogil:
        for i in range(h):
            # Down the columns: the output row is a weighted sum of whole input rows.
            up = &a[i, 0]
            for j in range(w):
                acc[j] = taps[0] * up[j]
            for k in range(1, r + 1):
                up = &a[_reflect(i - k, h), 0]
                down = &a[_reflect(i + k, h), 0]
                t = taps[k]
                for j in range(w):
                    acc[j] = acc[j] + t * (<double>up[j] + <double>down[j])
            # Rounded to float32 (as a float32 intermediate image holds it), padded by
            # reflection after the accumulator in ``line``, then summed along the row.
            for j in range(w):
                pad[j + r] = <float>acc[j]
            for j in range(-r, 0):
                pad[j + r] = pad[_reflect(j, w) + r]
            for j in range(w, w + r):
                pad[j + r] = pad[_reflect(j, w) + r]
            for j in range(w):
                acc[j] = taps[0] * pad[j + r]
            for k in range(1, r + 1):
                t = taps[k]
                for j in range(w):
                    acc[j] = acc[j] + t * (pad[j + r - k] + pad[j + r + k])
            o = &out[i, 0]
            for j in range(w):
                o[j] = <float>acc[j]


def noise_response(const grey_t[:, :] image, Py_ssize_t s, float[::1] out):
    """|Immerkaer's mask| at every ``s``-th row and column of ``image`` (h, w), row-major
    into ``out`` (``ceil((h - 2) / s) * ceil((w - 2) / s)``), in float32 with
    :func:`graphpose.detect.noise.estimate_noise`'s order: each row's ``(a - 2 b) + c``, then
    ``(d0 - 2 d1) + d2`` down the three rows."""
    cdef Py_ssize_t h = image.shape[0], w = image.shape[1], i, j, n = 0, k
    cdef float d[3]
    cdef float x0, x1, x2, v, two = 2.0
    with nogil:
        i = 0
        while i < h - 2:
            j = 0
            while j < w - 2:
                for k in range(3):
                    x0 = <float>image[i + k, j]
                    x1 = <float>image[i + k, j + 1]
                    x2 = <float>image[i + k, j + 2]
                    d[k] = (x0 - two * x1) + x2
                v = (d[0] - two * d[1]) + d[2]
                out[n] = v if v >= 0 else -v
                n += 1
                j += s
            i += s


def noise_median_u8(const unsigned char[:, :] image, Py_ssize_t s, Py_ssize_t[::1] counts):
    """The ``n // 2``-th smallest (0-based) of :func:`noise_response`'s ``n`` values on an
    8-bit image, by counting: they are whole numbers in [0, 16 x 255], ``counts`` scratch of
    that length plus one. The value ``np.partition`` would put there; -1 when n is 0."""
    cdef Py_ssize_t h = image.shape[0], w = image.shape[1], i, j, k, n = 0, v, d0, d1, d2, seen
    with nogil:
        for k in range(counts.shape[0]):
            counts[k] = 0
        i = 0
        while i < h - 2:
            j = 0
            while j < w - 2:
                d0 = (<Py_ssize_t>image[i, j] - 2 * <Py_ssize_t>image[i, j + 1]) + image[i, j + 2]
                d1 = (<Py_ssize_t>image[i + 1, j] - 2 * <Py_ssize_t>image[i + 1, j + 1]) + image[i + 1, j + 2]
                d2 = (<Py_ssize_t>image[i + 2, j] - 2 * <Py_ssize_t>image[i + 2, j + 1]) + image[i + 2, j + 2]
                v = (d0 - 2 * d1) + d2
                counts[v if v >= 0 else -v] += 1
                n += 1
                j += s
            i += s
        seen, v = 0, -1
        for k in range(counts.shape[0]):
            seen += counts[k]
            if seen > n // 2:
                v = k
                break
    return v if n > 0 else -1


cdef double _select(double *v, Py_ssize_t n, Py_ssize_t k) noexcept nogil:
    """The ``k``-th smallest (0-based) of ``v[:n]``, which is reordered (Hoare's selection:
    ``v[:k]`` ends at most it, ``v[k + 1:]`` at least it)."""
    cdef Py_ssize_t lo = 0, hi = n - 1, i, j
    cdef double pivot, t
    while lo < hi:
        pivot = v[(lo + hi) // 2]
        i, j = lo, hi
        while i <= j:
            while v[i] < pivot:
                i += 1
            while v[j] > pivot:
                j -= 1
            if i <= j:
                t = v[i]
                v[i] = v[j]
                v[j] = t
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    return v[k]


def median(const double[::1] x, double[::1] scratch):
    """The median of ``x`` as ``np.median`` gives it: the middle value, the mean of the middle
    two for even n, NaN if any value is NaN or n is 0. ``scratch`` holds n values."""
    cdef Py_ssize_t n = x.shape[0], k
    cdef double a, b
    if n == 0:
        return float("nan")
    for k in range(n):
        if x[k] != x[k]:
            return float("nan")
        scratch[k] = x[k]
    with nogil:
        b = _select(&scratch[0], n, n // 2)
        if n % 2 == 0:
            a = scratch[0]  # the largest of scratch[:n // 2], all at most b
            for k in range(1, n // 2):
                if scratch[k] > a:
                    a = scratch[k]
            b = (a + b) / 2.0
    return b


def kth_grey_u8(const unsigned char[:, :] image, Py_ssize_t s, const Py_ssize_t[::1] ks, Py_ssize_t[::1] out):
    """``out[q]``: the ``ks[q]``-th smallest (0-based) of the pixels at every ``s``-th row and
    column of the 8-bit ``image`` (``image[::s, ::s]``), by counting its 256 grey levels;
    each of ``ks`` below the count of those pixels."""
    cdef Py_ssize_t counts[256]
    cdef Py_ssize_t h = image.shape[0], w = image.shape[1], i, j, g, q = 0, seen = 0
    with nogil:
        for g in range(256):
            counts[g] = 0
        i = 0
        while i < h:
            j = 0
            while j < w:
                counts[image[i, j]] += 1
                j += s
            i += s
        for q in range(ks.shape[0]):
            seen = 0
            for g in range(256):
                seen += counts[g]
                if seen > ks[q]:
                    out[q] = g
                    break


def block_means_u8(const unsigned char[:, ::1] image, int level, float scale, float[:, ::1] out,
                   unsigned short[::1] rows):
    """``out[i, j]``: the sum of the 8-bit ``image``'s 2^level x 2^level block (i, j), exact in
    integers (``level`` <= 4), times ``scale`` (``4^-level``) in float32, for the ``out.shape``
    whole blocks; ``rows`` is scratch of ``out.shape[1] * 2^level`` sums. The block row's
    image rows are summed into ``rows`` first (whole contiguous rows, which the compiler
    vectorises), then each block's columns."""
    cdef Py_ssize_t s = 1 << level, h = out.shape[0], w = out.shape[1], n = w << level, i, j, p, q, x
    cdef const unsigned char *row
    cdef unsigned short *acc = &rows[0]
    cdef unsigned int total
    cdef const unsigned char *below
    cdef float *o
    with nogil:
        if s == 2:  # half resolution, the VGA search's level: the four pixels at once
            for i in range(h):
                row, below, o = &image[2 * i, 0], &image[2 * i + 1, 0], &out[i, 0]
                for j in range(w):
                    o[j] = <float>(<unsigned int>row[2 * j] + row[2 * j + 1] + below[2 * j] + below[2 * j + 1]) * scale
        else:
            for i in range(h):
                row = &image[i * s, 0]
                for x in range(n):
                    acc[x] = row[x]
                for p in range(1, s):
                    row = &image[i * s + p, 0]
                    for x in range(n):
                        acc[x] = acc[x] + row[x]
                for j in range(w):
                    total = 0
                    for q in range(s):
                        total = total + acc[j * s + q]
                    out[i, j] = <float>total * scale


cdef inline bint _in_polygon(const double[:, ::1] poly, double x, double y) noexcept nogil:
    """Whether (x, y) lies inside the closed polygon ``poly`` (2, V) or on its boundary.

    The crossing-number test of O'Rourke, *Computational Geometry in C* (2nd ed., 1998),
    section 7.4: with the point as origin, count the edges that cross the ray to +x (right)
    and those that cross the ray to -x (left); an odd right count is inside, and counts of
    different parity put the point on an edge. A vertex within 1e-12 of the point counts as
    on the boundary. (The test and its tolerance are scikit-image's ``points_in_poly``, which
    this replaced, so the verdicts are the same.)"""
    cdef Py_ssize_t i, n = poly.shape[1]
    cdef double x0, y0, x1 = poly[0, n - 1] - x, y1 = poly[1, n - 1] - y
    cdef unsigned int right = 0, left = 0
    for i in range(n):
        x0 = poly[0, i] - x
        y0 = poly[1, i] - y
        if -1e-12 < x0 < 1e-12 and -1e-12 < y0 < 1e-12:
            return True
        if (y0 > 0) != (y1 > 0) and (x0 * y1 - x1 * y0) / (y1 - y0) > 0:
            right += 1
        if (y0 < 0) != (y1 < 0) and (x0 * y1 - x1 * y0) / (y1 - y0) < 0:
            left += 1
        x1 = x0
        y1 = y0
    return (right & 1) or (left & 1)


def in_polygon(const double[:, ::1] points, const double[:, ::1] poly, unsigned char[::1] out):
    """``out[k]``: 1 where point ``points[:, k]`` ((2, N), (u, v)) lies inside the polygon
    ``poly`` (2, V) or on its boundary, else 0 (:func:`_in_polygon`)."""
    cdef Py_ssize_t k
    with nogil:
        for k in range(points.shape[1]):
            out[k] = _in_polygon(poly, points[0, k], points[1, k])

"""Inline sampling shared by the detect kernels (``_search.pyx``, ``_lattice.pyx``): one
bilinear sample and the ring test's arithmetic on 16 samples. Declarations only, compiled
into each kernel that cimports them (no module of its own)."""

from libc.math cimport atan2, fabs, floor

ctypedef fused grey_t:
    unsigned char
    unsigned short
    float
    double


cdef extern from *:
    """
    /* cos and sin of the ring's 16 angles q pi / 8, and of twice them (Python's repr, exact) */
    static const double GP_RING_COS[16] = {1.0, 0.9238795325112867, 0.7071067811865476, 0.38268343236508984, 6.123233995736766e-17, -0.3826834323650897, -0.7071067811865475, -0.9238795325112867, -1.0, -0.9238795325112868, -0.7071067811865477, -0.38268343236509034, -1.8369701987210297e-16, 0.38268343236509, 0.7071067811865474, 0.9238795325112865};
    static const double GP_RING_SIN[16] = {0.0, 0.3826834323650898, 0.7071067811865475, 0.9238795325112867, 1.0, 0.9238795325112867, 0.7071067811865476, 0.3826834323650899, 1.2246467991473532e-16, -0.38268343236508967, -0.7071067811865475, -0.9238795325112865, -1.0, -0.9238795325112866, -0.7071067811865477, -0.3826834323650904};
    static const double GP_RING_COS2[16] = {1.0, 0.7071067811865476, 6.123233995736766e-17, -0.7071067811865475, -1.0, -0.7071067811865477, -1.8369701987210297e-16, 0.7071067811865474, 1.0, 0.7071067811865477, 3.061616997868383e-16, -0.7071067811865467, -1.0, -0.7071067811865471, -4.286263797015736e-16, 0.7071067811865466};
    static const double GP_RING_SIN2[16] = {0.0, 0.7071067811865475, 1.0, 0.7071067811865476, 1.2246467991473532e-16, -0.7071067811865475, -1.0, -0.7071067811865477, -2.4492935982947064e-16, 0.7071067811865474, 1.0, 0.7071067811865483, 3.6739403974420594e-16, -0.7071067811865479, -1.0, -0.7071067811865485};
    """
    const double _COS "GP_RING_COS"[16]
    const double _SIN "GP_RING_SIN"[16]
    const double _COS2 "GP_RING_COS2"[16]
    const double _SIN2 "GP_RING_SIN2"[16]


cdef inline double _bilinear(const grey_t[:, :] a, double x, double y) noexcept nogil:
    """One bilinear sample of ``a`` at column ``x``, row ``y``, as
    ``scipy.ndimage.map_coordinates(order=1, mode="nearest")``: the coordinate clamped to the
    image, the four neighbours weighted in double precision in the order (row, column)
    ``(0, 0), (0, 1), (1, 0), (1, 1)``, a neighbour past the last row or column repeating it."""
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




cdef inline void _ring_at(const float[:, :] a, double x, double y, double radius, double *score, double *theta,
                          double *contrast) noexcept nogil:
    """The ring test on ``a`` around column ``x``, row ``y`` at ``radius`` (pixels of ``a``):
    16 bilinear samples, each rounded to float32 (as ``map_coordinates`` on a float32 image
    gives them), then :func:`_ring_score`."""
    cdef double ring[16]
    cdef int q
    for q in range(16):
        ring[q] = <float>_bilinear(a, x + radius * _COS[q], y + radius * _SIN[q])
    _ring_score(ring, score, theta, contrast)


cdef inline double _median(double *v, int n) noexcept nogil:
    """Median of ``v[:n]`` (n >= 1; mean of the middle two for even n), sorting ``v`` in place."""
    cdef int p, q
    cdef double t
    for p in range(1, n):  # insertion sort: n is a handful
        t = v[p]
        q = p - 1
        while q >= 0 and v[q] > t:
            v[q + 1] = v[q]
            q -= 1
        v[q + 1] = t
    return v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])

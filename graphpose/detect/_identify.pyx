"""Compiled evidence of the identification (:mod:`graphpose.detect.identify`): the verdict
on one lattice side from its grey samples, in one call.

Means are taken left to right (NumPy's pairwise sums of these few values may associate
differently, in the last bit: the verdict compares them with thresholds far from those bits).
"""

from libc.math cimport NAN, isfinite
from libc.stdint cimport int64_t

#: Verdicts, as identify's ``_side`` names them.
UNKNOWN, CONTINUES, EDGE = 0, 1, 2


def side_verdict(const double[:, :, ::1] P, const double[:, ::1] value, const double[::1] expect,
                 const int64_t[::1] rows, const int64_t[::1] square, double width, double height, double mid,
                 double contrast, double alternates, double plain):
    """The verdict on one side (see ``identify._side``): :data:`UNKNOWN`, :data:`CONTINUES`
    or :data:`EDGE`.

    ``P`` (m, 2, D) are the sample points (u, v) of the m rows along the side at D depths,
    ``value`` (m, D) their grey levels, ``expect`` (m,) +1 where a row's outer square is
    dark, -1 where light, ``rows`` (m,) the rows' lattice coordinates (ascending),
    ``square`` (D,) the square each depth lies in (0 the outer one); ``width``, ``height``
    the image's; ``mid`` and ``contrast`` the board's mid grey and dark-light contrast.
    """
    cdef Py_ssize_t m = P.shape[0], D = P.shape[2], p, d, n_pairs = 0, finite = 0, alternating = 0
    cdef Py_ssize_t k, seen, valid, high
    cdef double dark_pd, o, total, mean, sign
    cdef double[:, ::1] dark
    cdef double[:, ::1] per_square
    import numpy as np
    dark = np.empty((m, D))
    per_square = np.empty((4, m))
    for p in range(m):
        for d in range(D):
            if P[p, 0, d] >= 0 and P[p, 1, d] >= 0 and P[p, 0, d] <= width - 1 and P[p, 1, d] <= height - 1:
                dark_pd = (mid - value[p, d]) / (0.5 * contrast)
                dark[p, d] = -1.0 if dark_pd < -1.0 else (1.0 if dark_pd > 1.0 else dark_pd)
            else:
                dark[p, d] = NAN
        o = dark[p, 0] * expect[p]
        if isfinite(o):
            finite += 1
        if o > alternates:
            alternating += 1
    if finite < 2 or alternating / <double>m < 0.75:
        return UNKNOWN
    # Pairs of neighbouring rows: where the board goes on, their darkness differs as the pattern says.
    for p in range(m - 1):
        if rows[p + 1] - rows[p] != 1:
            continue
        for k in range(1, 4):
            total, seen = 0.0, 0
            for d in range(D):
                if square[d] != k:
                    continue
                sign = -1.0 if square[d] % 2 == 1 else 1.0
                o = 0.5 * (dark[p, d] - dark[p + 1, d]) * expect[p] * sign
                if isfinite(o):
                    total += o
                    seen += 1
            per_square[k, n_pairs] = total / seen if seen >= 2 else NAN
        n_pairs += 1
    # The square beyond: alternating (the board goes on), or plain but for one pair in four.
    total, valid, high = 0.0, 0, 0
    for p in range(n_pairs):
        if isfinite(per_square[1, p]):
            total += per_square[1, p]
            valid += 1
            high += per_square[1, p] > alternates
    if valid == 0:
        return UNKNOWN
    mean = total / valid
    if mean > alternates:
        return CONTINUES
    if not (mean < plain and high <= valid // 4):
        return UNKNOWN
    # Farther out the squares must not come back (a bar or a fold lying across the board).
    for k in range(2, 4):
        total, valid, high = 0.0, 0, 0
        for p in range(n_pairs):
            if isfinite(per_square[k, p]):
                total += per_square[k, p]
                valid += 1
                high += per_square[k, p] > alternates
        if valid and (total / valid > plain or high > (1 if valid // 3 < 1 else valid // 3)):
            return UNKNOWN
    return EDGE

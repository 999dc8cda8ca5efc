"""Compiled evidence of the identification (:mod:`graphpose.detect.identify`): the verdict
on one lattice side from its grey samples, and whether the board's junctions come back on the
lines beyond a side (their ring tests through the lattice's homography), each in one call.

Means are taken left to right (NumPy's pairwise sums of these few values may associate
differently, in the last bit: the verdict compares them with thresholds far from those bits).
"""

from libc.math cimport NAN, cos, hypot, isfinite
from libc.stdint cimport int64_t

from graphpose.detect._sampling cimport _ring_at

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
    the image's; ``mid`` and ``contrast`` the board's mid grey and dark-light contrast. An
    edge is plain over the square beyond it on average and at each of that square's depths.
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
    # Plain at each depth of the square beyond, not only on average over it: a bar narrower
    # than a square lying along the line of junctions beyond the lattice hides that line, and
    # the board's next squares show on one side of it within the square beyond. At each of its
    # depths the pairs' mean stays under ``plain`` (a real edge's clutter catches a pair or two).
    for d in range(D):
        if square[d] != 1:
            continue
        total, seen = 0.0, 0
        for p in range(m - 1):
            if rows[p + 1] - rows[p] != 1:
                continue
            o = -0.5 * (dark[p, d] - dark[p + 1, d]) * expect[p]
            if isfinite(o):
                total += o
                seen += 1
        if seen >= 2 and total / seen > plain:
            return UNKNOWN
    return EDGE


def side_geometry(const double[:, :, ::1] grid, int64_t oi, int64_t oj, const int64_t[:, ::1] keys, int axis,
                  int direction, const double[::1] depths, double flat_side, int64_t dark_parity,
                  double[:, :, ::1] P, int64_t[::1] rows, double[::1] expect, double[::1] steps):
    """The sample points of one lattice side (see ``identify._side``), or -1 where the side is
    not an edge line of the lattice (fewer than ``flat_side`` of its lattice lines reach it).

    ``grid`` is a :class:`graphpose.detect.lattice.KeyGrid`'s array (NaN where no node), key
    ``(i, j)`` at ``grid[i - oi, j - oj]``; ``keys`` (M, 2) the lattice's nodes; the side is
    the lowest (``direction`` -1) or highest (+1) ``keys[:, axis]``. For each node on it, in
    ascending order of its other coordinate ``b``, whose outer-band square (``b`` to ``b + 1``
    along the side, one key inwards) has all four nodes, in order: ``rows`` gets ``b``,
    ``expect`` +1 where that square's parity is ``dark_parity`` (else -1), ``steps`` the
    length of one square outwards, and ``P[p, :, d]`` (u, v) the point ``depths[d]`` squares
    outwards from the side's midpoint of the square. Returns how many rows were written
    (the buffers hold M).
    """
    cdef Py_ssize_t M = keys.shape[0], D = depths.shape[0], k, d, m = 0, n_lines = 0, reach_end = 0
    cdef Py_ssize_t gi = grid.shape[0], gj = grid.shape[1]
    cdef int64_t extreme, lo_b, hi_b, a, b, inward = -direction, q
    cdef int64_t ii[4]
    cdef int64_t jj[4]
    cdef double c[4][2]
    cdef double eu, ev, su, sv
    cdef int64_t[::1] ends
    cdef unsigned char[::1] on_side
    cdef int corner, whole
    import numpy as np
    if M == 0:
        return -1
    extreme, lo_b, hi_b = keys[0, axis], keys[0, 1 - axis], keys[0, 1 - axis]
    for k in range(M):
        a, b = keys[k, axis], keys[k, 1 - axis]
        if (direction < 0 and a < extreme) or (direction > 0 and a > extreme):
            extreme = a
        lo_b = b if b < lo_b else lo_b
        hi_b = b if b > hi_b else hi_b
    # Each lattice line across the side ends where its farthest node along ``axis`` is.
    ends = np.empty(hi_b - lo_b + 1, dtype=np.int64)
    on_side = np.zeros(hi_b - lo_b + 1, dtype=np.uint8)
    for k in range(hi_b - lo_b + 1):
        ends[k] = 0
    for k in range(M):
        a, b = keys[k, axis], keys[k, 1 - axis] - lo_b
        if not on_side[b]:
            on_side[b] = 1
            ends[b] = a
            n_lines += 1
        elif (direction < 0 and a < ends[b]) or (direction > 0 and a > ends[b]):
            ends[b] = a
    for k in range(hi_b - lo_b + 1):
        if on_side[k] and ends[k] == extreme:
            reach_end += 1
    if reach_end / <double>n_lines < flat_side:
        return -1
    # The nodes on the side (ascending b) whose outer-band square is whole.
    for b in range(lo_b, hi_b + 1):
        if not (on_side[b - lo_b] and ends[b - lo_b] == extreme):
            continue
        whole = 1
        for corner in range(4):
            q = extreme + (inward if corner >= 2 else 0)
            if axis == 0:
                ii[corner], jj[corner] = q - oi, b + (corner % 2) - oj
            else:
                ii[corner], jj[corner] = b + (corner % 2) - oi, q - oj
            if ii[corner] < 0 or jj[corner] < 0 or ii[corner] >= gi or jj[corner] >= gj:
                whole = 0
                break
            c[corner][0], c[corner][1] = grid[ii[corner], jj[corner], 0], grid[ii[corner], jj[corner], 1]
            if not (isfinite(c[corner][0]) and isfinite(c[corner][1])):
                whole = 0
                break
        if not whole:
            continue
        rows[m] = b
        expect[m] = 1.0 if ((extreme + (direction - 1) // 2 + b) % 2 + 2) % 2 == dark_parity else -1.0
        eu, ev = 0.5 * (c[0][0] + c[1][0]), 0.5 * (c[0][1] + c[1][1])
        su, sv = eu - 0.5 * (c[2][0] + c[3][0]), ev - 0.5 * (c[2][1] + c[3][1])
        steps[m] = hypot(su, sv)
        for d in range(D):
            P[m, 0, d] = eu + su * depths[d]
            P[m, 1, d] = ev + sv * depths[d]
        m += 1
    return m


def whole_squares(const double[:, :, ::1] grid, int64_t oi, int64_t oj, const int64_t[:, ::1] keys,
                  double[:, ::1] centres, double[::1] steps, int64_t[::1] parity):
    """The lattice squares whose upper-left node is a key of ``keys`` (M, 2) and whose four
    nodes (``(i, j)``, ``(i + 1, j)``, ``(i, j + 1)``, ``(i + 1, j + 1)``) are all on ``grid``
    (a :class:`graphpose.detect.lattice.KeyGrid`'s array, key ``(i, j)`` at
    ``grid[i - oi, j - oj]``), in the order of ``keys``: ``centres[:, m]`` the mean of the four
    nodes (summed in that order), ``steps[m]`` the first side's length (node to the next along
    ``i``), ``parity[m]`` ``(i + j) mod 2``. Returns how many were written (the buffers hold M)."""
    cdef Py_ssize_t M = keys.shape[0], gi = grid.shape[0], gj = grid.shape[1], k, c, m = 0
    cdef int64_t a, b
    cdef double u[4]
    cdef double v[4]
    cdef int whole
    for k in range(M):
        whole = 1
        for c in range(4):
            a, b = keys[k, 0] + (c % 2) - oi, keys[k, 1] + (c // 2) - oj
            if a < 0 or b < 0 or a >= gi or b >= gj:
                whole = 0
                break
            u[c], v[c] = grid[a, b, 0], grid[a, b, 1]
            if not (isfinite(u[c]) and isfinite(v[c])):
                whole = 0
                break
        if not whole:
            continue
        centres[0, m] = (((u[0] + u[1]) + u[2]) + u[3]) / 4
        centres[1, m] = (((v[0] + v[1]) + v[2]) + v[3]) / 4
        steps[m] = hypot(u[1] - u[0], v[1] - v[0])
        parity[m] = ((keys[k, 0] + keys[k, 1]) % 2 + 2) % 2
        m += 1
    return m


cdef bint _project(const double[:, ::1] H, double k0, double k1, double *u, double *v, double *w) noexcept nogil:
    """``H (k0, k1, 1)``: (u, v) the image point, ``w`` its third coordinate; False where ``w``
    is 0 or not finite."""
    w[0] = H[2, 0] * k0 + H[2, 1] * k1 + H[2, 2]
    if not (isfinite(w[0]) and w[0] != 0):
        return False
    u[0] = (H[0, 0] * k0 + H[0, 1] * k1 + H[0, 2]) / w[0]
    v[0] = (H[1, 0] * k0 + H[1, 1] * k1 + H[1, 2]) / w[0]
    return True


def line_returns(const float[:, :] smooth, int level, double width, double height, const double[:, ::1] H,
                 const int64_t[:, ::1] keys, int axis, int64_t line, int direction, int64_t first, int64_t last,
                 double theta0, double ring_fraction, double min_score, double parity_cos):
    """The first ``out`` in ``first .. last`` at which the board's junctions come back beyond a
    lattice side (see ``identify._check_border``), or 0.

    The side is the lattice line ``keys[:, axis] == line`` (``keys`` (M, 2) the lattice's
    nodes); ``direction`` (-1 or +1) points outwards. For each ``out``, the keys of the line
    ``line + out direction`` over the same span are projected through the lattice's
    homography ``H`` (3, 3); the line comes back when two neighbouring keys pass the ring test
    on ``smooth`` (the search's smoothed image at ``level``, ``_sampling._ring_at``) at radius
    ``ring_fraction`` of the local step (the distance to the prediction one line inwards),
    with a score above ``min_score`` and the parity their keys demand (``cos 2 (theta -
    theta0)`` above ``parity_cos`` for an even key sum, below ``-parity_cos`` for an odd one).
    A line is not looked at where a prediction lies beyond the homography's horizon (its
    third coordinate not of one sign over the line), and a key is left out where its ring
    does not fit in the ``width`` x ``height`` image or its step is under 4 pixels.
    """
    cdef Py_ssize_t M = keys.shape[0], n = 0, k, p
    cdef int64_t out, b, t
    cdef double s = <double>(1 << level), at, back, u, v, w, u2, v2, w2, step, margin, score, theta, contrast
    cdef double pos = 0.0, neg = 0.0, turn
    cdef bint ok, back_ok, passed, before
    cdef int64_t[::1] span
    cdef double[::1] pu, pv, ps
    cdef unsigned char[::1] inside
    import numpy as np
    span = np.empty(max(M, 1), dtype=np.int64)
    # The line's span: its keys' other coordinates, ascending, each once.
    for k in range(M):
        if keys[k, axis] != line:
            continue
        b = keys[k, 1 - axis]
        p = n
        while p > 0 and span[p - 1] > b:
            span[p] = span[p - 1]
            p -= 1
        span[p] = b
        n += 1
    p = 0
    for k in range(n):
        if k == 0 or span[k] != span[p - 1]:
            span[p] = span[k]
            p += 1
    n = p
    if n == 0:
        return 0
    pu, pv, ps = np.empty(n), np.empty(n), np.empty(n)
    inside = np.empty(n, dtype=np.uint8)
    for out in range(first, last + 1):
        at = <double>(line + out * direction)
        back = at - (1.0 if out * direction > 0 else -1.0)  # one line inwards
        ok = True
        pos = neg = 0
        for k in range(n):
            if axis == 0:
                ok = _project(H, at, <double>span[k], &u, &v, &w)
                back_ok = _project(H, back, <double>span[k], &u2, &v2, &w2)
            else:
                ok = _project(H, <double>span[k], at, &u, &v, &w)
                back_ok = _project(H, <double>span[k], back, &u2, &v2, &w2)
            if not ok:
                break
            if w > 0:
                pos += 1
            else:
                neg += 1
            step = hypot(u - u2, v - v2) if back_ok else NAN  # NAN: the key is left out
            margin = ring_fraction * step + 1.0
            pu[k], pv[k], ps[k] = u, v, step
            inside[k] = (u >= margin and v >= margin and u <= width - 1 - margin and v <= height - 1 - margin
                         and step >= 4.0)
        if not ok or (pos > 0 and neg > 0):
            continue  # beyond the board's horizon
        t = 0
        for k in range(n):
            t += inside[k]
        if t < 2:
            continue
        before = False
        for k in range(n):
            passed = False
            if inside[k]:
                _ring_at(smooth, (pu[k] - 0.5 * (s - 1)) / s, (pv[k] - 0.5 * (s - 1)) / s,
                         ring_fraction * ps[k] / s, &score, &theta, &contrast)
                turn = cos(2 * (theta - theta0))
                t = ((<int64_t>at + span[k]) % 2 + 2) % 2
                passed = score > min_score and (turn > parity_cos if t == 0 else turn < -parity_cos)
            if passed and before and span[k] - span[k - 1] == 1:
                return out
            before = passed
    return 0

"""Compiled loops of the lattice growth (:mod:`graphpose.detect.lattice`): the predictions of
one growth round, and the choice of a seed's cross among its neighbours.

Node positions live on a dense grid ``(ni, nj, 2)`` over keys (a
:class:`graphpose.detect.lattice.KeyGrid`'s array: key ``(i, j)`` at ``(i - oi, j - oj)``),
NaN where there is no node; keys off the grid have none. The arithmetic is that of the Python
it replaces, in the same order, so the positions are the same to the last bit.
"""

from libc.math cimport NAN, hypot, cos, fabs, floor, sqrt, M_PI
from libc.stdint cimport int64_t

from graphpose.detect._sampling cimport _median, _ring_at

cdef int _DI[4]
cdef int _DJ[4]
_DI[:] = [1, -1, 0, 0]
_DJ[:] = [0, 0, 1, -1]


cdef inline bint _get(const double[:, :, ::1] grid, int64_t oi, int64_t oj, int64_t i, int64_t j, double *u, double *v) noexcept nogil:
    """Position of key (i, j) into u, v; False where there is no node."""
    cdef int64_t a = i - oi, b = j - oj
    if a < 0 or b < 0 or a >= grid.shape[0] or b >= grid.shape[1]:
        return False
    u[0] = grid[a, b, 0]
    v[0] = grid[a, b, 1]
    return u[0] == u[0]


cdef inline bint _predict(const double[:, :, ::1] grid, int64_t oi, int64_t oj, int64_t i, int64_t j,
                          double *pu, double *pv, double *step) noexcept nogil:
    """:func:`graphpose.detect.lattice.predict` of key (i, j); False where it gives None."""
    cdef double su = 0.0, sv = 0.0, au, av, bu, bv, cu, cv, b1u, b1v, b2u, b2v, t
    cdef double steps[8]
    cdef int n = 0, s, e, p, q
    cdef int64_t di, dj, ei, ej
    for s in range(4):
        di, dj = _DI[s], _DJ[s]
        if not _get(grid, oi, oj, i - di, j - dj, &au, &av) or not _get(grid, oi, oj, i - 2 * di, j - 2 * dj, &bu, &bv):
            continue
        if not _get(grid, oi, oj, i - 3 * di, j - 3 * dj, &cu, &cv):
            su += 2 * au - bu
            sv += 2 * av - bv
        else:
            su += 3 * au - 3 * bu + cu
            sv += 3 * av - 3 * bv + cv
        steps[n] = hypot(au - bu, av - bv)
        n += 1
    if n == 0:
        for s in range(4):
            di, dj = _DI[s], _DJ[s]
            if not _get(grid, oi, oj, i - di, j - dj, &au, &av):
                continue
            for e in range(4):
                ei, ej = _DI[e], _DJ[e]
                if ei * di + ej * dj:
                    continue
                if (_get(grid, oi, oj, i - di + ei, j - dj + ej, &b1u, &b1v)
                        and _get(grid, oi, oj, i + ei, j + ej, &b2u, &b2v)):
                    su += au + b2u - b1u
                    sv += av + b2v - b1v
                    steps[n] = hypot(b2u - b1u, b2v - b1v)
                    n += 1
    if n == 0:
        return False
    step[0] = _median(steps, n)
    pu[0] = su / n
    pv[0] = sv / n
    return True


cpdef Py_ssize_t predict_round(const double[:, :, ::1] grid, int64_t oi, int64_t oj, const int64_t[:, ::1] fresh,
                               int[:, ::1] stamp, int mark, int64_t[:, ::1] keys, double[:, ::1] guess,
                               double[::1] step) noexcept nogil:
    """The predictions of one growth round: for each key of ``fresh`` (m, 2) in order, its
    four neighbours (the lattice's step order) that hold no node and were not looked at
    this round (``stamp`` (ni, nj) != ``mark``; set to it here) and that a prediction
    reaches, into ``keys`` (4 m, 2), ``guess`` (4 m, 2) and ``step`` (4 m,). Every such key
    must lie on the grid. Returns their count."""
    cdef Py_ssize_t k, n = 0
    cdef int s
    cdef int64_t i, j, a, b
    for k in range(fresh.shape[0]):
        for s in range(4):
            i = fresh[k, 0] + _DI[s]
            j = fresh[k, 1] + _DJ[s]
            a, b = i - oi, j - oj
            if grid[a, b, 0] == grid[a, b, 0] or stamp[a, b] == mark:
                continue
            stamp[a, b] = mark
            if _predict(grid, oi, oj, i, j, &guess[n, 0], &guess[n, 1], &step[n]):
                keys[n, 0] = i
                keys[n, 1] = j
                n += 1
    return n


def predict_one(const double[:, :, ::1] grid, int64_t oi, int64_t oj, int64_t i, int64_t j):
    """:func:`graphpose.detect.lattice.predict` of key (i, j): ``((u, v), step)`` or None."""
    cdef double u, v, step
    if not _predict(grid, oi, oj, i, j, &u, &v, &step):
        return None
    return (u, v), step


cdef inline int64_t _along(const double *vx, const double *vy, const double *length, const int64_t *pool, Py_ssize_t m,
                        double dx, double dy, double cos_limit) noexcept nogil:
    """The entry of ``pool`` (m of them) nearest the direction (dx, dy) within 15 degrees and
    0.7-1.4 of its length, or -1."""
    cdef double size = hypot(dx, dy), c, ratio, err, best_err = 0.0
    cdef int64_t n, best = -1
    cdef Py_ssize_t k
    for k in range(m):
        n = pool[k]
        c = (dx * vx[n] + dy * vy[n]) / (size * (length[n] if length[n] > 1e-12 else 1e-12))
        ratio = length[n] / size
        if not (c > cos_limit and ratio > 0.7 and ratio < 1.4):
            continue
        err = hypot(vx[n] - dx, vy[n] - dy)
        if best < 0 or err < best_err:
            best, best_err = n, err
    return best


cdef int _pick(const double *vx, const double *vy, const double *length, const int64_t *opposite, Py_ssize_t m,
               int64_t *out) noexcept nogil:
    """:func:`pick_cross` on C arrays."""
    cdef double cos_limit = cos(15.0 * (M_PI / 180.0))
    cdef Py_ssize_t p, k
    cdef int64_t a, b, c, d, n
    cdef int count, best = 0
    for p in range(m if m < 3 else 3):
        a = opposite[p]
        b = _along(vx, vy, length, opposite, m, -vx[a], -vy[a], cos_limit)
        c = -1
        for k in range(m):
            n = opposite[k]
            if n == a or n == b:
                continue
            if fabs(vx[a] * vy[n] - vy[a] * vx[n]) > 0.5 * length[a] * length[n]:
                c = n
                break
        if c < 0:
            continue
        d = _along(vx, vy, length, opposite, m, -vx[c], -vy[c], cos_limit)
        count = 3 + (b >= 0) + (d >= 0)
        if count >= 4 and count > best:
            best = count
            out[0], out[1], out[2], out[3] = a, b, c, d
    return best


def pick_cross(const double[:, ::1] vec, const double[::1] length, const int64_t[::1] opposite, int64_t[::1] out):
    """The arms of a seed's cross among its neighbours at ``vec`` (2, m) from it, ``length``
    (m,) away, those of opposite parity ``opposite``: neighbour indices ``(a, b, c, d)`` for
    keys (1, 0), (-1, 0), (0, 1), (0, -1) into ``out`` (-1 where absent). Each of the first
    three opposite neighbours is tried as arm (1, 0): its opposite arm is the neighbour
    nearest the reverse direction (:func:`_along`), arm (0, 1) the first opposite neighbour
    well off its line, and (0, -1) the one opposite that; the cross with most nodes (at least
    four, the first of equals) wins. Returns its node count (0: none)."""
    cdef int64_t arms[4]
    cdef int count = _pick(&vec[0, 0], &vec[1, 0], &length[0], &opposite[0], opposite.shape[0], arms)
    if count:
        for k in range(4):
            out[k] = arms[k]
    return count


def seed_cross(const double[:, ::1] points, const double[::1] theta, const int64_t[::1] nb, int64_t k,
               const float[:, :] smooth, int level, double parity_cos, double ring_fraction, double min_score,
               int64_t[::1] arms, double[::1] theta0):
    """The cross of five (or four) nodes around candidate ``k`` (see
    :func:`graphpose.detect.lattice._seed_cross`), in one call.

    ``points`` (2, N) and ``theta`` (N,) are the candidates', ``nb`` (m <= 12,) its nearest
    neighbours (itself excluded), nearest first; ``smooth`` the search image at ``level``
    that the ring test reads. On success ``arms`` gets the candidate indices of keys
    (1, 0), (-1, 0), (0, 1), (0, -1) (-1 where absent), ``arms[4]`` 1 where the keys must
    swap ``(i, j) -> (j, i)`` to turn like ``(u, v)``, and ``theta0[0]`` the seed's
    bright-bisector direction. Returns the node count, 0 where there is no cross.
    """
    cdef double vx[12]
    cdef double vy[12]
    cdef double length[12]
    cdef int64_t opposite[12]
    cdef int64_t pick[4]
    cdef int64_t node[5]
    cdef double d[4]
    cdef double score, th, contrast, t0, step, t, x, y, rad, s = 1 << level, c
    cdef Py_ssize_t m = nb.shape[0], n, q, p, r, count = 0, nodes
    cdef double cu = points[0, k], cv = points[1, k]
    if m > 12:
        m = 12
    for n in range(m):
        vx[n] = points[0, nb[n]] - cu
        vy[n] = points[1, nb[n]] - cv
        length[n] = hypot(vx[n], vy[n])
        if cos(2 * (theta[nb[n]] - theta[k])) < -parity_cos:
            opposite[count] = n
            count += 1
    if count < 3:
        return 0
    nodes = _pick(vx, vy, length, opposite, count, pick)
    if not nodes:
        return 0
    for q in range(4):
        arms[q] = nb[pick[q]] if pick[q] >= 0 else -1
    arms[4] = 1 if vx[pick[0]] * vy[pick[2]] - vy[pick[0]] * vx[pick[2]] < 0 else 0
    # The median distance of the arms from the seed, in key order (it does not matter for a median).
    p = 0
    for q in range(4):
        if pick[q] >= 0:
            d[p] = length[pick[q]]
            p += 1
    step = _median(d, <int>p)
    # The ring test at the seed and its arms: every one a cross-junction, of the parity its key demands.
    node[0] = k
    p = 1
    for q in range(4):
        if arms[q] >= 0:
            node[p] = arms[q]
            p += 1
    rad = ring_fraction * step / s
    for q in range(p):
        x = (points[0, node[q]] - 0.5 * (s - 1)) / s
        y = (points[1, node[q]] - 0.5 * (s - 1)) / s
        _ring_at(smooth, x, y, rad, &score, &th, &contrast)
        if score < min_score:
            return 0
        if q == 0:
            t0 = th
        else:
            c = cos(2 * (th - t0))
            if not c < -parity_cos:
                return 0
    theta0[0] = t0
    return nodes


cdef inline int64_t _nearest(const double[:, ::1] points, const int64_t[::1] start, const int64_t[::1] items, int64_t nx, int64_t ny,
                          double cell, double x, double y, double reach) noexcept nogil:
    """The candidate nearest (x, y) if it lies within ``reach`` (Euclidean, as a k-d tree
    measures it), else -1; candidates are bucketed in square cells of side ``cell``
    (``items[start[c]:start[c + 1]]`` in cell ``c = cy nx + cx``)."""
    cdef int64_t cx0 = <int64_t>floor((x - reach) / cell), cx1 = <int64_t>floor((x + reach) / cell)
    cdef int64_t cy0 = <int64_t>floor((y - reach) / cell), cy1 = <int64_t>floor((y + reach) / cell)
    cdef int64_t cx, cy, c, best = -1, n
    cdef Py_ssize_t q
    cdef double dx, dy, d, best_d = 0.0
    if cx0 < 0:
        cx0 = 0
    if cy0 < 0:
        cy0 = 0
    if cx1 > nx - 1:
        cx1 = nx - 1
    if cy1 > ny - 1:
        cy1 = ny - 1
    for cy in range(cy0, cy1 + 1):
        for cx in range(cx0, cx1 + 1):
            c = cy * nx + cx
            for q in range(start[c], start[c + 1]):
                n = items[q]
                dx = points[0, n] - x
                dy = points[1, n] - y
                d = sqrt(dx * dx + dy * dy)
                if d < reach and (best < 0 or d < best_d or (d == best_d and n < best)):
                    best, best_d = n, d
    return best


def grow(double[:, :, ::1] grid, int64_t oi, int64_t oj, int[:, ::1] stamp, int64_t[:, ::1] order, int64_t[:, ::1] fresh,
         int64_t[::1] state, int64_t max_nodes, const double[:, ::1] points, const int64_t[::1] start, const int64_t[::1] items,
         int64_t nx, int64_t ny, double cell, const float[:, :] smooth, int level, double width, double height,
         double theta0, double ring_fraction, double snap_fraction, double min_score, double parity_cos,
         int64_t[:, ::1] keys, double[:, ::1] guess, double[::1] step):
    """The growth rounds of :func:`graphpose.detect.lattice._grow`, compiled.

    ``order`` holds the nodes' keys in the order they joined, ``fresh`` those the next round
    starts from; ``state`` is ``(len(order), len(fresh), full, mark)``, updated here. Each
    round predicts the free neighbours (:func:`predict_round`, into the scratch ``keys``,
    ``guess``, ``step``), keeps those whose prediction lies inside the image by the ring's
    margin and whose point (the nearest candidate within ``snap_fraction`` of the step,
    else the prediction) passes the ring test with its key's parity, and adds them to
    ``grid`` and ``order``. Returns 0 when growth has ended, 1 when a new node lies within
    one key of the grid's edge (grow the grid, then call again).
    """
    cdef int64_t n_order = state[0], n_fresh = state[1], full = state[2]
    cdef int mark = <int>state[3]
    cdef Py_ssize_t n, q, r, good
    cdef int64_t a, b, cand, ni = grid.shape[0], nj = grid.shape[1]
    cdef double s = 1 << level, margin, qx, qy, x, y, rad, score, th, contrast, c
    cdef bint edge = False
    with nogil:
        while n_order < max_nodes:
            if n_fresh == 0:
                if full:
                    break
                for q in range(n_order):
                    fresh[q, 0], fresh[q, 1] = order[q, 0], order[q, 1]
                n_fresh, full = n_order, 1
            mark += 1
            n = predict_round(grid, oi, oj, fresh[:n_fresh], stamp, mark, keys, guess, step)
            if n == 0:
                if full:
                    break
                n_fresh = 0
                continue
            good = 0
            for q in range(n):
                margin = ring_fraction * step[q] + 1.0
                if not (guess[q, 0] > margin and guess[q, 1] > margin and guess[q, 0] < width - 1 - margin
                        and guess[q, 1] < height - 1 - margin):
                    continue
                cand = _nearest(points, start, items, nx, ny, cell, guess[q, 0], guess[q, 1], snap_fraction * step[q])
                if cand >= 0:
                    qx, qy = points[0, cand], points[1, cand]
                else:
                    qx, qy = guess[q, 0], guess[q, 1]
                x = (qx - 0.5 * (s - 1)) / s
                y = (qy - 0.5 * (s - 1)) / s
                rad = ring_fraction * step[q] / s
                _ring_at(smooth, x, y, rad, &score, &th, &contrast)
                if not score > min_score:
                    continue
                c = cos(2 * (th - theta0))
                if (keys[q, 0] + keys[q, 1]) % 2 == 0:
                    if not c > parity_cos:
                        continue
                elif not c < -parity_cos:
                    continue
                a, b = keys[q, 0] - oi, keys[q, 1] - oj
                grid[a, b, 0], grid[a, b, 1] = qx, qy
                if a < 1 or b < 1 or a > ni - 2 or b > nj - 2:
                    edge = True
                order[n_order, 0], order[n_order, 1] = keys[q, 0], keys[q, 1]
                fresh[good, 0], fresh[good, 1] = keys[q, 0], keys[q, 1]
                n_order += 1
                good += 1
            n_fresh = good
            full = full and good == 0
            if edge:
                break
    state[0], state[1], state[2], state[3] = n_order, n_fresh, full, mark
    return 1 if edge else 0


def step_lengths(const double[:, :, ::1] grid, int64_t oi, int64_t oj, const int64_t[:, ::1] keys, double[::1] out):
    """``out[k]``: the mean distance from node ``keys[k]`` to its lattice neighbours
    (``(i +- 1, j)``, ``(i, j +- 1)``, summed in that order), NaN where it has none; ``grid``
    a :class:`graphpose.detect.lattice.KeyGrid`'s array, key ``(i, j)`` at
    ``grid[i - oi, j - oj]``."""
    cdef Py_ssize_t k, s
    cdef double u, v, un, vn, total
    cdef int count
    with nogil:
        for k in range(keys.shape[0]):
            total, count = 0.0, 0
            if _get(grid, oi, oj, keys[k, 0], keys[k, 1], &u, &v):
                for s in range(4):
                    if _get(grid, oi, oj, keys[k, 0] + _DI[s], keys[k, 1] + _DJ[s], &un, &vn):
                        total = total + hypot(un - u, vn - v)
                        count += 1
            out[k] = total / count if count > 0 else NAN


def nearest(const double[:, ::1] points, const int64_t[::1] queries, int64_t[:, ::1] out):
    """``out[q]``: the ``out.shape[1]`` candidates nearest candidate ``queries[q]`` (among
    ``points`` (2, N), itself included), nearest first, equal distances in index order; a
    brute-force pass (a few hundred candidates, a few queries at a time). The squared
    distances are ``du * du + dv * dv``, as a k-d tree sums them."""
    cdef Py_ssize_t q, i, s, m = out.shape[1], filled
    cdef double best[64]
    cdef double d, du, dv, qu, qv
    if m > 64:
        raise ValueError(f"at most 64 neighbours, got {m}")
    with nogil:
        for q in range(queries.shape[0]):
            qu, qv = points[0, queries[q]], points[1, queries[q]]
            filled = 0
            for i in range(points.shape[1]):
                du = points[0, i] - qu
                dv = points[1, i] - qv
                d = du * du + dv * dv
                if filled == m and not d < best[m - 1]:
                    continue
                s = filled if filled < m else m - 1
                while s > 0 and d < best[s - 1]:  # insertion: an equal distance stays after
                    best[s] = best[s - 1]
                    out[q, s] = out[q, s - 1]
                    s -= 1
                best[s] = d
                out[q, s] = i
                if filled < m:
                    filled += 1

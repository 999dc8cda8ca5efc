"""Compiled loops of the lattice growth (:mod:`graphpose.detect.lattice`): the predictions of
one growth round, and the choice of a seed's cross among its neighbours.

Node positions live on a dense grid ``(ni, nj, 2)`` over keys (a
:class:`graphpose.detect.lattice.KeyGrid`'s array: key ``(i, j)`` at ``(i - oi, j - oj)``),
NaN where there is no node; keys off the grid have none. The arithmetic is that of the Python
it replaces, in the same order, so the positions are the same to the last bit.
"""

from libc.math cimport hypot, cos, M_PI

cdef int _DI[4]
cdef int _DJ[4]
_DI[:] = [1, -1, 0, 0]
_DJ[:] = [0, 0, 1, -1]


cdef inline bint _get(const double[:, :, ::1] grid, long oi, long oj, long i, long j, double *u, double *v) noexcept nogil:
    """Position of key (i, j) into u, v; False where there is no node."""
    cdef long a = i - oi, b = j - oj
    if a < 0 or b < 0 or a >= grid.shape[0] or b >= grid.shape[1]:
        return False
    u[0] = grid[a, b, 0]
    v[0] = grid[a, b, 1]
    return u[0] == u[0]


cdef inline bint _predict(const double[:, :, ::1] grid, long oi, long oj, long i, long j,
                          double *pu, double *pv, double *step) noexcept nogil:
    """:func:`graphpose.detect.lattice.predict` of key (i, j); False where it gives None."""
    cdef double su = 0.0, sv = 0.0, au, av, bu, bv, cu, cv, b1u, b1v, b2u, b2v, t
    cdef double steps[8]
    cdef int n = 0, s, e, p, q
    cdef long di, dj, ei, ej
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
    for p in range(1, n):  # insertion sort of at most 8 steps
        t = steps[p]
        q = p - 1
        while q >= 0 and steps[q] > t:
            steps[q + 1] = steps[q]
            q -= 1
        steps[q + 1] = t
    step[0] = steps[n // 2] if n % 2 else 0.5 * (steps[n // 2 - 1] + steps[n // 2])
    pu[0] = su / n
    pv[0] = sv / n
    return True


def predict_round(const double[:, :, ::1] grid, long oi, long oj, const long[:, ::1] fresh, int[:, ::1] stamp,
                  int mark, long[:, ::1] keys, double[:, ::1] guess, double[::1] step):
    """The predictions of one growth round: for each key of ``fresh`` (m, 2) in order, its
    four neighbours (the lattice's step order) that hold no node and were not looked at
    this round (``stamp`` (ni, nj) != ``mark``; set to it here) and that a prediction
    reaches, into ``keys`` (4 m, 2), ``guess`` (4 m, 2) and ``step`` (4 m,). Every such key
    must lie on the grid. Returns their count."""
    cdef Py_ssize_t k, n = 0
    cdef int s
    cdef long i, j, a, b
    cdef double u, v
    with nogil:
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


def predict_one(const double[:, :, ::1] grid, long oi, long oj, long i, long j):
    """:func:`graphpose.detect.lattice.predict` of key (i, j): ``((u, v), step)`` or None."""
    cdef double u, v, step
    if not _predict(grid, oi, oj, i, j, &u, &v, &step):
        return None
    return (u, v), step


cdef inline long _along(const double[:, ::1] vec, const double[::1] length, const long[::1] pool,
                        double dx, double dy, double cos_limit) noexcept nogil:
    """:func:`graphpose.detect.lattice._along`: the entry of ``pool`` nearest the direction
    (dx, dy) within 15 degrees and 0.7-1.4 of its length, or -1."""
    cdef double size = hypot(dx, dy), c, ratio, err, best_err = 0.0
    cdef long n, best = -1
    cdef Py_ssize_t k
    for k in range(pool.shape[0]):
        n = pool[k]
        c = (dx * vec[0, n] + dy * vec[1, n]) / (size * (length[n] if length[n] > 1e-12 else 1e-12))
        ratio = length[n] / size
        if not (c > cos_limit and ratio > 0.7 and ratio < 1.4):
            continue
        err = hypot(vec[0, n] - dx, vec[1, n] - dy)
        if best < 0 or err < best_err:
            best, best_err = n, err
    return best


def pick_cross(const double[:, ::1] vec, const double[::1] length, const long[::1] opposite, long[::1] out):
    """The arms of a seed's cross (see :func:`graphpose.detect.lattice._seed_cross`) among its
    neighbours at ``vec`` (2, m) from it, ``length`` (m,) away, those of opposite parity
    ``opposite``: neighbour indices ``(a, b, c, d)`` for keys (1, 0), (-1, 0), (0, 1),
    (0, -1) into ``out`` (-1 where absent). Returns the cross's node count (0: none)."""
    cdef double cos_limit = cos(15.0 * (M_PI / 180.0))
    cdef Py_ssize_t p, k
    cdef long a, b, c, d, n
    cdef int count, best = 0
    with nogil:
        for p in range(opposite.shape[0] if opposite.shape[0] < 3 else 3):
            a = opposite[p]
            b = _along(vec, length, opposite, -vec[0, a], -vec[1, a], cos_limit)
            c = -1
            for k in range(opposite.shape[0]):
                n = opposite[k]
                if n == a or n == b:
                    continue
                if abs(vec[0, a] * vec[1, n] - vec[1, a] * vec[0, n]) > 0.5 * length[a] * length[n]:
                    c = n
                    break
            if c < 0:
                continue
            d = _along(vec, length, opposite, -vec[0, c], -vec[1, c], cos_limit)
            count = 3 + (b >= 0) + (d >= 0)
            if count >= 4 and count > best:
                best = count
                out[0], out[1], out[2], out[3] = a, b, c, d
    return best

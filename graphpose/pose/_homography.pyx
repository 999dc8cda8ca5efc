"""Compiled core of :mod:`graphpose.pose.homography`: the homography split into a first pose.

One call takes the plane-to-image homography ``H ~ K [r1 r2 t_CW]`` apart: ``K^-1 H`` by back
substitution (``K`` is upper triangular), scaled by the mean norm of its first two columns, its
sign chosen so that every target point is in front of the camera, and the rotation
``[r1 r2 r1 x r2]`` made orthonormal: its orthogonal polar factor (the rotation nearest to it
in the Frobenius norm, what ``U V^T`` of its SVD gives; a rotation, since its determinant
``|r1 x r2|^2`` is positive), by the scaled Newton iteration ``X <- (g X + X^-T / g) / 2``
(Higham, Functions of Matrices, 2008, sec. 8.6). The caller checks every input first.
"""

from libc.math cimport sqrt

#: Newton iterations at most, and the change (Frobenius norm, relative) at which they stop.
cdef int _POLAR_ITERATIONS = 100
cdef double _POLAR_TOL = 1e-15


cdef double _inverse_transpose(const double[3][3] X, double[3][3] Y) noexcept nogil:
    """Y = X^-T (by the cofactors); returns det X."""
    cdef double det
    cdef int i, k
    Y[0][0] = X[1][1] * X[2][2] - X[1][2] * X[2][1]
    Y[0][1] = X[1][2] * X[2][0] - X[1][0] * X[2][2]
    Y[0][2] = X[1][0] * X[2][1] - X[1][1] * X[2][0]
    Y[1][0] = X[0][2] * X[2][1] - X[0][1] * X[2][2]
    Y[1][1] = X[0][0] * X[2][2] - X[0][2] * X[2][0]
    Y[1][2] = X[0][1] * X[2][0] - X[0][0] * X[2][1]
    Y[2][0] = X[0][1] * X[1][2] - X[0][2] * X[1][1]
    Y[2][1] = X[0][2] * X[1][0] - X[0][0] * X[1][2]
    Y[2][2] = X[0][0] * X[1][1] - X[0][1] * X[1][0]
    det = X[0][0] * Y[0][0] + X[0][1] * Y[0][1] + X[0][2] * Y[0][2]
    for i in range(3):
        for k in range(3):
            Y[i][k] /= det
    return det


cdef void _polar(double[3][3] X) noexcept nogil:
    """X replaced by its orthogonal polar factor (X nonsingular)."""
    cdef double Y[3][3]
    cdef double nx, ny, gamma, change, size, new
    cdef int it, i, k
    for it in range(_POLAR_ITERATIONS):
        _inverse_transpose(X, Y)
        nx, ny = 0.0, 0.0
        for i in range(3):
            for k in range(3):
                nx += X[i][k] * X[i][k]
                ny += Y[i][k] * Y[i][k]
        gamma = sqrt(sqrt(ny / nx))  # the scaling that balances X and X^-T
        change, size = 0.0, 0.0
        for i in range(3):
            for k in range(3):
                new = 0.5 * (gamma * X[i][k] + Y[i][k] / gamma)
                change += (new - X[i][k]) * (new - X[i][k])
                size += new * new
                X[i][k] = new
        if change <= _POLAR_TOL * _POLAR_TOL * size:
            return


def homography_pose(const double[:, ::1] K, const double[:, ::1] H, const double[:, ::1] W,
                    double[:, ::1] T):
    """The camera pose T_WC (4, 4) from the homography of the target plane, in place.

    Parameters
    ----------
    K : (3, 3) float64
        Intrinsics, pixels (upper triangular).
    H : (3, 3) float64
        ``[u, v, 1]^T ~ H [x, y, 1]^T`` for target points ``(x, y, 0)``.
    W : (2, n) float64
        The target points' x and y, metres.
    T : (4, 4) float64, out
        The pose; written only when the call returns True.

    Returns
    -------
    bool
        False when the target points lie on both sides of the camera (no sign of the
        decomposition puts them all in front).
    """
    cdef bint ok
    with nogil:
        ok = _decompose(K, H, W, T)
    return ok


cdef bint _decompose(const double[:, ::1] K, const double[:, ::1] H, const double[:, ::1] W,
                     double[:, ::1] T) noexcept nogil:
    """:func:`homography_pose`'s work."""
    cdef double M[3][3]
    cdef double X[3][3]
    cdef double t[3]
    cdef double scale, depth
    cdef Py_ssize_t n = W.shape[1], j
    cdef int c, i, k, before = 0, behind = 0
    for c in range(3):  # K M = H, K upper triangular
        M[2][c] = H[2, c] / K[2, 2]
        M[1][c] = (H[1, c] - K[1, 2] * M[2][c]) / K[1, 1]
        M[0][c] = (H[0, c] - K[0, 1] * M[1][c] - K[0, 2] * M[2][c]) / K[0, 0]
    scale = 2.0 / (sqrt(M[0][0] * M[0][0] + M[1][0] * M[1][0] + M[2][0] * M[2][0])
                   + sqrt(M[0][1] * M[0][1] + M[1][1] * M[1][1] + M[2][1] * M[2][1]))
    for j in range(n):
        depth = M[2][0] * W[0, j] + M[2][1] * W[1, j] + M[2][2]
        if depth > 0:
            before += 1
        elif depth < 0:
            behind += 1
    if behind == n:
        scale = -scale
    elif before != n:
        return False
    for i in range(3):
        X[i][0] = scale * M[i][0]
        X[i][1] = scale * M[i][1]
        t[i] = scale * M[i][2]
    X[0][2] = X[1][0] * X[2][1] - X[2][0] * X[1][1]
    X[1][2] = X[2][0] * X[0][1] - X[0][0] * X[2][1]
    X[2][2] = X[0][0] * X[1][1] - X[1][0] * X[0][1]
    _polar(X)
    for i in range(3):  # C = R^T, t_WC = -R^T t_CW
        T[i, 3] = 0.0
        for k in range(3):
            T[i, k] = X[k][i]
            T[i, 3] -= X[k][i] * t[k]
        T[3, i] = 0.0
    T[3, 3] = 1.0
    return True

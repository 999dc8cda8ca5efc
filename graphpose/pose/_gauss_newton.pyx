"""Compiled core of :mod:`graphpose.pose.gauss_newton`: residuals and analytic Jacobians.

One call projects every target point through the pose ``(x, y, z, roll, pitch, yaw)``, with
``C = Cz(yaw) Cy(pitch) Cx(roll)`` and ``p_C = C^T (p_W - t)``, and stacks its residual and its
2 x 6 Jacobian: the pose's derivative of the camera-frame point (``dp_C/dt = -C^T``,
``dp_C/d(angle) = (dC/d(angle))^T (p_W - t)``) chained with ``d uv / d p_C``, written out for
the pinhole (:func:`pinhole_residuals`) or given by the camera's model
(:func:`camera_points`, :func:`chain_jacobians`). For the pinhole, :func:`pinhole_normal_equations`
sums each point's rows straight into the 6 x 6 normal equations of a Gauss-Newton step (with
the Huber kernel's weights), so the stacked Jacobian is never formed. The callers check every
input first.
"""

from cython.view cimport array as cvarray
from libc.math cimport INFINITY, NAN, cos, isfinite, sin, sqrt


#: The camera models the compiled loop knows (:func:`gauss_newton_loop`).
cdef enum:
    _PINHOLE = 0
    _RADTAN = 1
PINHOLE = _PINHOLE
RADTAN = _RADTAN
cdef double[::1] _NO_COEFFICIENTS = cvarray(shape=(8,), itemsize=sizeof(double), format="d")


cdef void _rotation_and_partials(const double[::1] p, double[:, :, ::1] R) noexcept nogil:
    """C and its partials by roll, pitch, yaw into R (4, 3, 3), as
    multiplied out so that one pass builds them all (entries 1, 2, 3: Cz Cy dCx, Cz dCy Cx, dCz Cy Cx)."""
    cdef double cr = cos(p[3]), sr = sin(p[3]), cp = cos(p[4]), sp = sin(p[4])
    cdef double cy = cos(p[5]), sy = sin(p[5])
    cdef double spcr = sp * cr, spsr = sp * sr
    R[0, 0, 0] = cy * cp; R[0, 0, 1] = cy * spsr - sy * cr; R[0, 0, 2] = cy * spcr + sy * sr
    R[0, 1, 0] = sy * cp; R[0, 1, 1] = sy * spsr + cy * cr; R[0, 1, 2] = sy * spcr - cy * sr
    R[0, 2, 0] = -sp; R[0, 2, 1] = cp * sr; R[0, 2, 2] = cp * cr
    R[1, 0, 0] = 0.0; R[1, 0, 1] = cy * spcr + sy * sr; R[1, 0, 2] = -cy * spsr + sy * cr
    R[1, 1, 0] = 0.0; R[1, 1, 1] = sy * spcr - cy * sr; R[1, 1, 2] = -sy * spsr - cy * cr
    R[1, 2, 0] = 0.0; R[1, 2, 1] = cp * cr; R[1, 2, 2] = -cp * sr
    R[2, 0, 0] = -cy * sp; R[2, 0, 1] = cy * cp * sr; R[2, 0, 2] = cy * cp * cr
    R[2, 1, 0] = -sy * sp; R[2, 1, 1] = sy * cp * sr; R[2, 1, 2] = sy * cp * cr
    R[2, 2, 0] = -cp; R[2, 2, 1] = -spsr; R[2, 2, 2] = -spcr
    R[3, 0, 0] = -sy * cp; R[3, 0, 1] = -sy * spsr - cy * cr; R[3, 0, 2] = -sy * spcr + cy * sr
    R[3, 1, 0] = cy * cp; R[3, 1, 1] = cy * spsr - sy * cr; R[3, 1, 2] = cy * spcr + sy * sr
    R[3, 2, 0] = 0.0; R[3, 2, 1] = 0.0; R[3, 2, 2] = 0.0


cdef void _points(const double[::1] p, const double[:, ::1] W, double[:, :, ::1] R,
                  double[:, ::1] A) noexcept nogil:
    """Rows 0-2 of A (12, n): p_C = C^T (p_W - t); rows 3k + 3 .. 3k + 5: dC_k^T (p_W - t)."""
    cdef Py_ssize_t n = W.shape[1], j
    cdef int k, i
    cdef double d0, d1, d2
    _rotation_and_partials(p, R)
    for j in range(n):
        d0, d1, d2 = W[0, j] - p[0], W[1, j] - p[1], W[2, j] - p[2]
        for k in range(4):
            for i in range(3):
                A[3 * k + i, j] = R[k, 0, i] * d0 + R[k, 1, i] * d1 + R[k, 2, i] * d2


cdef inline void _chain_rows(const double[:, :, ::1] R, const double[:, ::1] A, Py_ssize_t j,
                             double g00, double g01, double g02, double g10, double g11, double g12,
                             double* J) noexcept nogil:
    """d(u, v)/d(p_C) (the g's) times d(p_C)/d(params) into a (2, 6) row-major buffer: row 0
    (u) in J[0:6], row 1 (v) in J[6:12]."""
    cdef int c
    for c in range(3):  # dp_C / dt = -C^T: its column c is -C[c, :]
        J[c] = -(g00 * R[0, c, 0] + g01 * R[0, c, 1] + g02 * R[0, c, 2])
        J[6 + c] = -(g10 * R[0, c, 0] + g11 * R[0, c, 1] + g12 * R[0, c, 2])
    for c in range(3):
        J[3 + c] = g00 * A[3 + 3 * c, j] + g01 * A[4 + 3 * c, j] + g02 * A[5 + 3 * c, j]
        J[9 + c] = g10 * A[3 + 3 * c, j] + g11 * A[4 + 3 * c, j] + g12 * A[5 + 3 * c, j]


cdef inline void _chain(const double[:, :, ::1] R, const double[:, ::1] A, Py_ssize_t j,
                        double g00, double g01, double g02, double g10, double g11, double g12,
                        double[:, ::1] J) noexcept nogil:
    """Rows 2j, 2j + 1 of J: d(u, v)/d(p_C) (the g's) times d(p_C)/d(params)."""
    cdef double rows[12]
    cdef int c
    _chain_rows(R, A, j, g00, g01, g02, g10, g11, g12, rows)
    for c in range(6):
        J[2 * j, c] = rows[c]
        J[2 * j + 1, c] = rows[6 + c]


cdef inline void _pinhole_point(const double[:, ::1] K, const double[:, :, ::1] R, const double[:, ::1] A,
                                const double[:, ::1] I, Py_ssize_t j, double[::1] r, double[::1] z,
                                double* rows) noexcept nogil:
    """Point j through a pinhole: its depth into z, its residual into r and, unless ``rows`` is
    NULL, its two Jacobian rows into that (2, 6) buffer (:func:`_chain_rows`), with
    ``du/dp_C = (fx, s, cx - u) / z_C`` and ``dv/dp_C = (0, fy, cy - v) / z_C``."""
    cdef double x = A[0, j], y = A[1, j], zc = A[2, j], u, v, iz
    u = (K[0, 0] * x + K[0, 1] * y + K[0, 2] * zc) / zc
    v = (K[1, 0] * x + K[1, 1] * y + K[1, 2] * zc) / zc
    z[j] = zc
    r[2 * j] = I[0, j] - u
    r[2 * j + 1] = I[1, j] - v
    if rows != NULL:
        iz = 1.0 / zc
        _chain_rows(R, A, j, K[0, 0] * iz, K[0, 1] * iz, (K[0, 2] - u) * iz,
                    0.0, K[1, 1] * iz, (K[1, 2] - v) * iz, rows)


cdef inline void _radtan_point(const double[:, ::1] K, const double[::1] c, const double[:, :, ::1] R,
                               const double[:, ::1] A, const double[:, ::1] I, Py_ssize_t j, double[::1] r,
                               double[::1] z, double* rows) noexcept nogil:
    """Point j through OpenCV's radial-tangential lens (rational model included) with the
    focal lengths and centre of ``K`` (no skew) and ``c`` = (k1, k2, p1, p2, k3, k4, k5, k6):
    :class:`graphpose.camera_models.RadTanCamera`'s projection and Jacobian, written out (a
    point at or behind z = 0 gives NaN, as the model does)."""
    cdef double X = A[0, j], Y = A[1, j], Zc = A[2, j]
    cdef double Z = Zc if Zc > 0.0 else NAN
    cdef double x = X / Z, y = Y / Z, r2, a, b, g, xd, yd, da, db, dg, d00, d01, d11, iz, fx = K[0, 0], fy = K[1, 1]
    cdef double k1 = c[0], k2 = c[1], p1 = c[2], p2 = c[3], k3 = c[4], k4 = c[5], k5 = c[6], k6 = c[7]
    cdef bint rational = k4 != 0.0 or k5 != 0.0 or k6 != 0.0
    r2 = x * x + y * y
    a = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    if rational:
        b = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
        g = a / b
    else:
        g = a
    xd = x * g + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * g + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    z[j] = Zc
    r[2 * j] = I[0, j] - (fx * xd + K[0, 2])
    r[2 * j + 1] = I[1, j] - (fy * yd + K[1, 2])
    if rows != NULL:
        da = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
        if rational:
            db = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
            dg = (da * b - a * db) / (b * b)
        else:
            dg = da
        d00 = g + 2.0 * x * x * dg + 2.0 * p1 * y + 6.0 * p2 * x
        d01 = 2.0 * x * y * dg + 2.0 * p1 * x + 2.0 * p2 * y
        d11 = g + 2.0 * y * y * dg + 6.0 * p1 * y + 2.0 * p2 * x
        iz = 1.0 / Z
        _chain_rows(R, A, j, fx * d00 * iz, fx * d01 * iz, -fx * (d00 * x + d01 * y) * iz,
                    fy * d01 * iz, fy * d11 * iz, -fy * (d01 * x + d11 * y) * iz, rows)


def pinhole_residuals(const double[:, ::1] K, const double[::1] p, const double[:, ::1] I,
                      const double[:, ::1] W, double[:, :, ::1] R, double[:, ::1] A, double[::1] r,
                      double[::1] z, double[:, ::1] J, bint jacobian):
    """Residuals, depths and Jacobians of a pinhole camera, in place.

    Parameters
    ----------
    K : (3, 3) float64
        Intrinsics, pixels.
    p : (6,) float64
        The pose parameters, metres and radians.
    I, W : (2, n), (3, n) float64
        Measured pixels and target points, metres.
    R, A : (4, 3, 3), (12, n) float64
        Work space: the rotation and its partials, the camera-frame points and theirs.
    r : (2n,) float64, out
        Measured minus predicted, stacked ``(u0, v0, u1, v1, ...)``.
    z : (n,) float64, out
        Depths (points at or behind z = 0 give meaningless pixels: the caller checks).
    J : (2n, 6) float64, out
        Rows ``2j``, ``2j + 1``: ``d(u_j, v_j) / d(x, y, z, roll, pitch, yaw)``; filled only
        when ``jacobian``.
    """
    cdef Py_ssize_t n = W.shape[1], j
    cdef double rows[12]
    cdef int c
    with nogil:
        _points(p, W, R, A)
        for j in range(n):
            if jacobian:
                _pinhole_point(K, R, A, I, j, r, z, rows)
                for c in range(6):
                    J[2 * j, c] = rows[c]
                    J[2 * j + 1, c] = rows[6 + c]
            else:
                _pinhole_point(K, R, A, I, j, r, z, NULL)


def camera_points(const double[::1] p, const double[:, ::1] W, double[:, :, ::1] R, double[:, ::1] A):
    """The camera-frame points (rows 0-2 of A, (12, n)) and their partials by the angles, for
    a camera whose projection the model gives; R (4, 3, 3) gets C and its partials."""
    with nogil:
        _points(p, W, R, A)


def chain_jacobians(const double[:, :, ::1] G, const double[:, :, ::1] R, const double[:, ::1] A,
                    double[:, ::1] J):
    """The stacked Jacobians (2n, 6) from the model's ``d uv / d p_C`` (n, 2, 3) and
    :func:`camera_points`' R and A, in place."""
    cdef Py_ssize_t j
    with nogil:
        for j in range(G.shape[0]):
            _chain(R, A, j, G[j, 0, 0], G[j, 0, 1], G[j, 0, 2], G[j, 1, 0], G[j, 1, 1], G[j, 1, 2], J)


cdef (double, double) _normal_equations(int model, const double[::1] c, const double[:, ::1] K,
                                        const double[::1] p, const double[:, ::1] I,
                                        const double[:, ::1] W, double huber_px, double[:, :, ::1] R,
                                        double[:, ::1] A, double[::1] r, double[::1] z, double[:, ::1] H,
                                        double[::1] g) noexcept nogil:
    """The body of :func:`normal_equations`: (cost, chi2), the rest in place."""
    cdef Py_ssize_t n = W.shape[1], j
    cdef int a, b
    cdef double du, dv, e, w, cost = 0.0, chi2 = 0.0
    cdef double J[12]
    for a in range(6):
        g[a] = 0.0
        for b in range(6):
            H[a, b] = 0.0
    _points(p, W, R, A)
    for j in range(n):
        if model == _RADTAN:
            _radtan_point(K, c, R, A, I, j, r, z, J)
        else:
            _pinhole_point(K, R, A, I, j, r, z, J)
        du, dv = r[2 * j], r[2 * j + 1]
        w = 1.0
        e = du * du + dv * dv
        if huber_px > 0.0:
            e = sqrt(e)
            if e <= huber_px:
                cost += 0.5 * e * e
            else:
                w = huber_px / e
                cost += huber_px * (e - 0.5 * huber_px)
        else:
            cost += 0.5 * e
        chi2 += w * (du * du + dv * dv)
        for a in range(6):
            g[a] += w * (J[a] * du + J[6 + a] * dv)
            for b in range(a, 6):
                H[a, b] += w * (J[a] * J[b] + J[6 + a] * J[6 + b])
    for a in range(6):
        for b in range(a):
            H[a, b] = H[b, a]
    return cost, chi2


def pinhole_normal_equations(const double[:, ::1] K, const double[::1] p, const double[:, ::1] I,
                             const double[:, ::1] W, double huber_px, double[:, :, ::1] R,
                             double[:, ::1] A, double[::1] r, double[::1] z, double[:, ::1] H,
                             double[::1] g):
    """Residuals, depths, the cost and the weighted normal equations of a pinhole camera, in place.

    Parameters
    ----------
    K, p, I, W, R, A, r, z
        As :func:`pinhole_residuals`.
    huber_px : float
        Huber threshold on each point's 2-D error norm, pixels; 0 for plain least squares.
    H : (6, 6) float64, out
        ``J^T diag(w) J``, with ``J`` the stacked Jacobian of :func:`pinhole_residuals` and
        ``w`` each point's weight (1, or ``huber_px / e`` beyond the threshold).
    g : (6,) float64, out
        ``J^T diag(w) r``.

    Returns
    -------
    cost : float
        ``1/2 sum r^2``, or with ``huber_px`` the Huber cost ``sum rho(e_j)``
        (:func:`graphpose.pose.gauss_newton.reprojection_cost`).
    chi2 : float
        ``sum w r^2``.
    """
    cdef (double, double) out
    with nogil:
        out = _normal_equations(_PINHOLE, _NO_COEFFICIENTS, K, p, I, W, huber_px, R, A, r, z, H, g)
    return out


def normal_equations(int model, const double[::1] c, const double[:, ::1] K, const double[::1] p,
                     const double[:, ::1] I, const double[:, ::1] W, double huber_px, double[:, :, ::1] R,
                     double[:, ::1] A, double[::1] r, double[::1] z, double[:, ::1] H, double[::1] g):
    """:func:`pinhole_normal_equations` for the camera ``model`` (:data:`PINHOLE`, or
    :data:`RADTAN` with its eight coefficients ``c``; ``K`` its focal lengths and centre)."""
    cdef (double, double) out
    with nogil:
        out = _normal_equations(model, c, K, p, I, W, huber_px, R, A, r, z, H, g)
    return out


cdef int _solve6(const double[:, ::1] H, double lam, const double[::1] g, double* x) noexcept nogil:
    """x = (H + lam diag(H))^-1 g for a 6 x 6 H by Gaussian elimination with partial pivoting
    (LAPACK's dgesv's algorithm); 1 where a pivot is exactly zero (singular), else 0."""
    cdef double M[6][7]
    cdef int i, j, k, piv
    cdef double big, t, f
    for i in range(6):
        for j in range(6):
            M[i][j] = H[i, j]
        M[i][i] += lam * H[i, i]
        M[i][6] = g[i]
    for k in range(6):
        piv, big = k, -1.0
        for i in range(k, 6):
            t = M[i][k] if M[i][k] >= 0.0 else -M[i][k]
            if t > big or t != t:  # the first largest (a NaN is taken, as idamax would not fail)
                piv, big = i, t
                if t != t:
                    break
        if M[piv][k] == 0.0:
            return 1
        if piv != k:
            for j in range(k, 7):
                t = M[k][j]; M[k][j] = M[piv][j]; M[piv][j] = t
        for i in range(k + 1, 6):
            f = M[i][k] / M[k][k]
            for j in range(k + 1, 7):
                M[i][j] -= f * M[k][j]
    for i in range(5, -1, -1):
        t = M[i][6]
        for j in range(i + 1, 6):
            t -= M[i][j] * x[j]
        x[i] = t / M[i][i]
    return 0


def gauss_newton_loop(int model, const double[::1] c, const double[:, ::1] K, double[::1] p, const double[:, ::1] I,
                         const double[:, ::1] W, double huber_px, double cost, double chi2,
                         double[:, :, ::1] R, double[:, ::1] A, double[::1] r, double[::1] z,
                         double[:, ::1] H, double[::1] g, double[::1] r2, double[::1] z2,
                         double[:, ::1] H2, double[::1] g2, double tol, int max_iterations,
                         double min_depth, double cost_rtol, int max_polish_steps, double lambda_max):
    """The damped Gauss-Newton loop of :func:`graphpose.pose.gauss_newton.gauss_newton` for a
    camera ``model`` (:data:`PINHOLE`, or :data:`RADTAN` with its coefficients ``c``; see
    :func:`normal_equations`), every step in compiled code; the same rules, in the same order.

    ``p`` (6,) holds the start and gets the answer; ``cost``, ``chi2``, ``r``, ``z``, ``H``, ``g``
    come in as :func:`normal_equations` gave them at the start and leave as at the
    answer; ``r2``, ``z2``, ``H2``, ``g2`` are work space of the same shapes for a trial step.

    Returns
    -------
    status : int
        0 the iteration cap, 1 converged (the undamped step below ``tol``), 2 converged at the
        cost's rounding limit, 3 the normal equations singular, 4 damped steps cannot lower the
        cost, 5 the damped system singular (the caller raises as ``numpy.linalg.solve`` would).
    iterations, cost, chi2
        At the answer.
    """
    cdef Py_ssize_t n = W.shape[1], j
    cdef int it = 0, polish_steps = 0, status = 0, i, a, b, polishing, in_front
    cdef double lam = 0.0, step, promise, cost_new, chi2_new, t
    cdef double delta_gn[6]
    cdef double delta[6]
    cdef double p_new[6]
    cdef double[::1] pn = p_new
    with nogil:
        while it < max_iterations:
            it += 1
            if _solve6(H, 0.0, g, delta_gn):
                status = 3
                break
            step, promise = 0.0, 0.0
            for i in range(6):
                t = delta_gn[i] if delta_gn[i] >= 0.0 else -delta_gn[i]
                if t > step or t != t:
                    step = t
                promise += g[i] * delta_gn[i]
            if step < tol:
                status = 1
                break
            polishing = 0.5 * promise <= cost_rtol * cost
            if polishing:
                polish_steps += 1
                if polish_steps > max_polish_steps:
                    status = 2
                    break
            if lam == 0.0 or polishing:
                for i in range(6):
                    delta[i] = delta_gn[i]
            elif _solve6(H, lam, g, delta):
                status = 5
                break
            for i in range(6):
                p_new[i] = p[i] + delta[i]
            cost_new, chi2_new = _normal_equations(model, c, K, pn, I, W, huber_px, R, A, r2, z2, H2, g2)
            in_front = 1
            for j in range(n):
                if not (z2[j] > min_depth):  # (NaN depths fail too)
                    in_front = 0
            if not in_front:
                cost_new = INFINITY
            if not isfinite(cost_new):
                cost_new = INFINITY
            if cost_new < cost or (polishing and cost_new <= cost * (1.0 + 100 * cost_rtol)):
                for i in range(6):
                    p[i] = p_new[i]
                for j in range(2 * n):
                    r[j] = r2[j]
                for j in range(n):
                    z[j] = z2[j]
                for a in range(6):
                    g[a] = g2[a]
                    for b in range(6):
                        H[a, b] = H2[a, b]
                cost, chi2 = cost_new, chi2_new
                lam = 0.0 if lam < 1e-6 else lam / 10.0
            else:
                lam = 1e-4 if lam == 0.0 else lam * 10.0
                if lam > lambda_max:
                    status = 4
                    break
    return status, it, cost, chi2

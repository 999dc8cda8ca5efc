"""Compiled core of :func:`graphpose.track.factors.resection_factor`: the error and the
Jacobian of a frame's junctions, the camera's projection of fixed target points, in one call.

The pose is ``T_WC`` with GTSAM's right perturbation ``T Exp(omega, v)`` (rotation first), so
``p_C = C^T (p_W - t)`` moves by ``dp_C = [p_C]_x omega - v`` and a pixel row ``g`` of
``d uv / d p_C`` gives the Jacobian row ``(g x p_C, -g)``. A point at or behind the camera
(``z_C <= 0``) gives the constant error ``behind`` in both rows and a zero Jacobian, as GTSAM's
own projection factors do. :func:`pinhole_resection` writes the pinhole's projection out;
:func:`camera_frame` and :func:`model_resection` serve a camera whose projection and
``d uv / d p_C`` the model gives. The caller checks every input first.
"""


cdef inline void _rows(Py_ssize_t j, double p0, double p1, double p2, double u, double v,
                       double g00, double g01, double g02, double g10, double g11, double g12,
                       const double[:, ::1] I, double[::1] e, double[:, ::1] J, bint jacobian) noexcept nogil:
    """Rows 2j, 2j + 1 of the error and (when asked) of the Jacobian, for a point in front."""
    e[2 * j] = u - I[0, j]
    e[2 * j + 1] = v - I[1, j]
    if jacobian:
        J[2 * j, 0] = g01 * p2 - g02 * p1
        J[2 * j, 1] = g02 * p0 - g00 * p2
        J[2 * j, 2] = g00 * p1 - g01 * p0
        J[2 * j, 3], J[2 * j, 4], J[2 * j, 5] = -g00, -g01, -g02
        J[2 * j + 1, 0] = g11 * p2 - g12 * p1
        J[2 * j + 1, 1] = g12 * p0 - g10 * p2
        J[2 * j + 1, 2] = g10 * p1 - g11 * p0
        J[2 * j + 1, 3], J[2 * j + 1, 4], J[2 * j + 1, 5] = -g10, -g11, -g12


cdef inline void _behind(Py_ssize_t j, double behind, double[::1] e, double[:, ::1] J,
                         bint jacobian) noexcept nogil:
    """Rows 2j, 2j + 1 for a point at or behind the camera: the constant error, no Jacobian."""
    cdef int c
    e[2 * j] = behind
    e[2 * j + 1] = behind
    if jacobian:
        for c in range(6):
            J[2 * j, c] = 0.0
            J[2 * j + 1, c] = 0.0


def pinhole_resection(const double[:, :] T, const double[:, ::1] W, const double[:, ::1] I,
                      const double[:, ::1] K, double behind, double[::1] e, double[:, ::1] J,
                      bint jacobian):
    """The pinhole's resection error and Jacobian, in place.

    Parameters
    ----------
    T : (4, 4) float64, any strides
        The pose ``T_WC`` (GTSAM's ``Pose3.matrix()``).
    W, I : (3, m), (2, m) float64
        Target points, metres, and measured pixels.
    K : (3, 3) float64
        Intrinsics, pixels (skew allowed).
    behind : float
        The error of a point at or behind the camera, pixels.
    e : (2m,) float64, out
        Predicted minus measured, stacked ``(u0, v0, u1, v1, ...)``.
    J : (2m, 6) float64, out
        ``d e / d (omega, v)``; written only when ``jacobian``.
    """
    cdef Py_ssize_t m = W.shape[1], j
    cdef double d0, d1, d2, p0, p1, p2, iz, x, y
    cdef double fx = K[0, 0], s = K[0, 1], cx = K[0, 2], fy = K[1, 1], cy = K[1, 2]
    with nogil:
        for j in range(m):
            d0, d1, d2 = W[0, j] - T[0, 3], W[1, j] - T[1, 3], W[2, j] - T[2, 3]
            p0 = T[0, 0] * d0 + T[1, 0] * d1 + T[2, 0] * d2
            p1 = T[0, 1] * d0 + T[1, 1] * d1 + T[2, 1] * d2
            p2 = T[0, 2] * d0 + T[1, 2] * d1 + T[2, 2] * d2
            if not p2 > 0:
                _behind(j, behind, e, J, jacobian)
                continue
            iz = 1.0 / p2
            x, y = p0 / p2, p1 / p2
            # d(u, v) / d p_C: K's top rows times d(x, y) / d p_C = [[1, 0, -x], [0, 1, -y]] / z.
            _rows(j, p0, p1, p2, fx * x + s * y + cx, fy * y + cy,
                  fx * iz, s * iz, fx * (-x / p2) + s * (-y / p2), 0.0, fy * iz, fy * (-y / p2), I, e, J, jacobian)


def camera_frame(const double[:, :] T, const double[:, ::1] W, double[:, ::1] P):
    """The target points in the camera frame, ``P = C^T (p_W - t)`` (3, m), in place."""
    cdef Py_ssize_t j
    cdef double d0, d1, d2
    with nogil:
        for j in range(W.shape[1]):
            d0, d1, d2 = W[0, j] - T[0, 3], W[1, j] - T[1, 3], W[2, j] - T[2, 3]
            P[0, j] = T[0, 0] * d0 + T[1, 0] * d1 + T[2, 0] * d2
            P[1, j] = T[0, 1] * d0 + T[1, 1] * d1 + T[2, 1] * d2
            P[2, j] = T[0, 2] * d0 + T[1, 2] * d1 + T[2, 2] * d2


def model_resection(const double[:, ::1] P, const double[:, ::1] uv, const double[:, :, ::1] G,
                    const double[:, ::1] I, double behind, double[::1] e, double[:, ::1] J, bint jacobian):
    """The resection error and Jacobian from a camera model's pixels ``uv`` (2, m) and
    ``d uv / d p_C`` ``G`` (m, 2, 3) of the camera-frame points ``P`` (:func:`camera_frame`),
    in place (``G`` is read only when ``jacobian``)."""
    cdef Py_ssize_t j
    with nogil:
        for j in range(P.shape[1]):
            if not P[2, j] > 0:
                _behind(j, behind, e, J, jacobian)
            elif jacobian:
                _rows(j, P[0, j], P[1, j], P[2, j], uv[0, j], uv[1, j], G[j, 0, 0], G[j, 0, 1], G[j, 0, 2],
                      G[j, 1, 0], G[j, 1, 1], G[j, 1, 2], I, e, J, True)
            else:
                _rows(j, P[0, j], P[1, j], P[2, j], uv[0, j], uv[1, j], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, I, e, J, False)

"""The board's regions as a distorting lens images them: curved outlines traced as polylines.

Under a pinhole camera a planar polygon images to the polygon of its projected corners, which
is how :mod:`graphpose.synth.render` draws the board. Through lens distortion
(:class:`graphpose.RadTanCamera`, :class:`graphpose.FisheyeCamera`) its straight edges image
to curves. :func:`region_edges` traces each curve as a polyline of points projected through
the camera, splitting a piece until the image of its parametric midpoint lies within
``tol_px`` of its chord (the chord's sagitta), so the polyline is within about ``tol_px`` of
the true outline and its area within ``tol_px`` per pixel of outline. The exact-area
rasteriser then treats the polyline's segments as it treats a polygon's edges.

What the model can image
------------------------
A camera model images the rays within a cone about its optical axis (:func:`view_limit`):
the fisheye up to its ``theta_max`` (where ``theta_d`` stops growing, beyond 90 degrees for
a wide lens), the radial-tangential model up to the radius where its radial map folds back
(or, when it never folds, up to a radius far outside the image). Outside, ``project``
returns points that fold back into the picture, or no points at all. Every region is
clipped to that cone before it is drawn: its outline is the part of the polygon's edges
inside the cone plus the part of the cone's rim (a closed curve in the image) that sees the
polygon. Both are oriented positively (the shoelace sum of ``u0 v1 - u1 v0`` over an
outline is twice the area it encloses), which is what Green's theorem needs: the boundary
of ``A ∩ B`` is ``(∂A ∩ B) + (∂B ∩ A)``, whatever the topology (a board that straddles the
rim, a rim inside a large board). The plane's image keeps the orientation of the board's
front when the camera is in front of it (the central projection onto the hemisphere of
rays facing the plane, then a lens map that preserves orientation up to its fold) and
reverses it from behind.
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import Polynomial

from ..geometry import to_camera

#: Chords longer than this (pixels) near the image are split whatever their sagitta, so that
#: the midpoint test is never trusted over a long stretch (it cannot see an inflection).
MAX_CHORD_PX = 8.0
#: Halvings of a piece's parameter interval before it is accepted as it is.
MAX_DEPTH = 40
#: Initial pieces per traced curve.
INITIAL_PIECES = 8
#: Without a fold, the radial-tangential cone ends where its rim lies this many image
#: diagonals (plus 50 px) from the principal point: far outside any window that is drawn.
FAR_DIAGONALS = 4.0
#: The largest undistorted radius (x^2 + y^2)^(1/2) considered, 89.94 degrees off the axis.
MAX_RADIUS = 1e3


def view_limit(camera, size) -> float:
    """Half-angle of the cone of rays about the optical axis that the camera images, radians.

    Parameters
    ----------
    camera : Camera
        A :mod:`graphpose.camera_models` camera.
    size : (int, int)
        Image ``(width, height)``, pixels (it sets how far out a model that never folds is
        followed).

    Returns
    -------
    limit : float
        Fisheye: ``theta_max`` (at most pi less 1e-6, the backward axis having no image).
        Radial-tangential and pinhole: the angle of the undistorted radius where the radial
        map ``r g(r)`` stops growing (its first turning point or pole; tangential terms are
        ignored there), or, if the map grows past it, where its image lies
        :data:`FAR_DIAGONALS` image diagonals from the principal point; always below 90
        degrees.
    """
    if camera.model == "fisheye":
        return float(min(camera.theta_max, np.pi - 1e-6))
    width, height = size
    far = FAR_DIAGONALS * (np.hypot(width, height) + 50.0) / min(camera.fx, camera.fy)
    if camera.model == "radtan":
        k1, k2, _, _, k3, k4, k5, k6 = camera.coefficients
    else:
        k1 = k2 = k3 = k4 = k5 = k6 = 0.0
    a, b, t = Polynomial([1.0, k1, k2, k3]), Polynomial([1.0, k4, k5, k6]), Polynomial([0.0, 1.0])
    # d(r a/b)/dr = [a b + 2 t (a' b - a b')] / b^2 with t = r^2: its first positive root, or a
    # pole of g (a root of b), ends the one-to-one range.
    turning = a * b + 2.0 * t * (a.deriv() * b - a * b.deriv())
    ends = [MAX_RADIUS**2]
    for poly in (turning, b):
        if poly.degree() > 0:
            roots = poly.roots()
            real = roots[np.abs(roots.imag) <= 1e-9 * np.maximum(1.0, np.abs(roots))].real
            ends.extend(real[real > 0])
    r_end = float(np.sqrt(min(ends)))

    def rho(r):
        return r * a(r * r) / b(r * r)

    if rho(r_end) > far:  # the rim would be nearer than `far` otherwise: stop where it is far
        lo, hi = 0.0, r_end
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if rho(mid) < far else (lo, mid)
            if hi - lo <= 1e-12 * hi:
                break
        r_end = hi
    return float(np.arctan(r_end))


def in_view(P_C, limit: float) -> np.ndarray:
    """Which camera-frame points lie strictly inside the cone of half-angle ``limit``.

    Parameters
    ----------
    P_C : (3, N) ndarray
        Points in the camera frame, metres.
    limit : float
        Half-angle about the optical axis, radians (from :func:`view_limit`).

    Returns
    -------
    inside : (N,) ndarray of bool
    """
    P_C = np.asarray(P_C, dtype=float)
    return P_C[2] > np.cos(limit) * np.linalg.norm(P_C, axis=0)


def region_edges(camera, T_WC, polygons, gains, window, tol_px: float, limit: float):
    """Oriented boundary segments, in pixels, of planar regions imaged through a lens.

    Parameters
    ----------
    camera : Camera
        A :mod:`graphpose.camera_models` camera.
    T_WC : (4, 4) ndarray
        Camera pose in the target frame.
    polygons : sequence of (3, m) ndarray
        Convex polygons in the target plane z = 0, metres (either orientation).
    gains : sequence of float
        One weight per polygon, carried to its segments.
    window : (float, float, float, float)
        ``(u_min, v_min, u_max, v_max)``, pixels: where the outlines must be traced to
        ``tol_px``; pieces wholly outside are kept as coarse chords (they still close the
        outlines, and a chord stays outside when its curve does).
    tol_px : float
        Largest sagitta of an accepted chord near the window, pixels.
    limit : float
        Half-angle of the cone of rays that is drawn (:func:`view_limit`), radians.

    Returns
    -------
    segments : (4, n) ndarray
        ``(u0, v0, u1, v1)`` of every segment; together the closed outlines of each
        polygon's image clipped to the cone, each with its region on the positive side
        (the orientation of :func:`graphpose.synth.raster.polygon_coverage`'s polygons after
        their shoelace test: ``u0 v1 - u1 v0`` sums to twice the area).
    weights : (n,) ndarray
        The gain of each segment's polygon.
    """
    T_WC = np.asarray(T_WC, dtype=float)
    t_z = T_WC[2, 3]
    if t_z == 0.0:  # the camera lies in the board's plane: the board has no area in the image
        return np.zeros((4, 0)), np.zeros(0)
    sign = -np.sign(t_z)  # +1 when the camera sees the board's front (z into the board)
    R_WC = T_WC[:3, :3]
    cos_limit = np.cos(limit)

    # ---- every polygon edge, in the camera frame: P(s) = (1 - s) O + s E, s in [0, 1] ----
    worlds, O, E, owner = [], [], [], []
    for k, P in enumerate(polygons):
        P = np.asarray(P, dtype=float)
        x, y = P[0], P[1]
        if np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) < 0:
            P = P[:, ::-1]
        worlds.append(P[:2])
        start = to_camera(T_WC, P)
        O.append(start)
        E.append(np.roll(start, -1, axis=1))
        owner.append(np.full(P.shape[1], k))
    O, E, owner = np.concatenate(O, axis=1), np.concatenate(E, axis=1), np.concatenate(owner)
    D = E - O
    gains = np.asarray(gains, dtype=float)

    # Where each edge meets the cone's surface: Z(s)^2 = cos^2 |P(s)|^2, a quadratic in s.
    c2 = cos_limit**2
    q2 = D[2] ** 2 - c2 * np.sum(D * D, axis=0)
    q1 = 2.0 * (O[2] * D[2] - c2 * np.sum(O * D, axis=0))
    q0 = O[2] ** 2 - c2 * np.sum(O * O, axis=0)
    roots = _quadratic_roots(q2, q1, q0)  # (2, E), NaN where absent
    ok = np.isfinite(roots) & (roots >= -1e-12) & (roots <= 1.0 + 1e-12)
    roots = np.where(ok, np.clip(roots, 0.0, 1.0), np.nan)

    # Pieces of the edges inside the cone: split [0, 1] at the roots, keep inside intervals.
    cuts = np.sort(np.where(np.isfinite(roots), roots, 1.0), axis=0)
    bounds = np.vstack([np.zeros(owner.size), cuts, np.ones(owner.size)])  # (4, E)
    lo, hi = bounds[:-1].ravel(), bounds[1:].ravel()  # interval-major: 3 per edge
    edge = np.tile(np.arange(owner.size), 3)
    mid = 0.5 * (lo + hi)
    inside = (hi > lo) & in_view(O[:, edge] + mid * D[:, edge], limit)
    edge, lo, hi = edge[inside], lo[inside], hi[inside]

    def on_edges(ids, s):  # exact at the corners, so that consecutive edges meet exactly
        return (1.0 - s) * O[:, ids] + s * E[:, ids]

    u_a, u_b, ids = _trace(camera, on_edges, edge, lo, hi, window, tol_px)
    if sign < 0:
        u_a, u_b = u_b, u_a
    segments = [np.vstack([u_a, u_b])]
    weights = [gains[owner[ids]]]

    # ---- the cone's rim where it sees a polygon -----------------------------------------
    sin_limit = np.sin(limit)

    def on_rim(ids, phi):
        return np.stack([sin_limit * np.cos(phi), sin_limit * np.sin(phi), np.full(phi.shape, cos_limit)])

    normal = R_WC[2]  # z_W = normal . P_C + t_z

    def sees(k, phi):
        """Whether the rim's ray at azimuth phi meets polygon k (in front of the camera)."""
        d = on_rim(None, np.atleast_1d(phi))
        with np.errstate(divide="ignore", invalid="ignore"):
            s = -t_z / (normal @ d)
        W = R_WC[:2] @ (s * d) + T_WC[:2, 3:4]
        V = worlds[k]
        e = np.roll(V, -1, axis=1) - V
        cross = e[0][:, None] * (W[1] - V[1][:, None]) - e[1][:, None] * (W[0] - V[0][:, None])
        return (s > 0) & np.all(cross > 0, axis=0)

    crossing = O[:, None, :] + roots[None] * D[:, None, :]  # (3, 2, E)
    azimuth = np.arctan2(crossing[1], crossing[0])  # NaN where no root
    arc_owner, arc_lo, arc_hi = [], [], []
    for k in range(len(worlds)):
        phi = np.sort(azimuth[:, owner == k].ravel())
        phi = phi[np.isfinite(phi)]
        if phi.size == 0:
            if sees(k, 0.0)[0]:
                arc_owner.append(k), arc_lo.append(0.0), arc_hi.append(2 * np.pi)
            continue
        start, stop = phi, np.append(phi[1:], phi[0] + 2 * np.pi)
        keep = (stop - start > 1e-15) & sees(k, 0.5 * (start + stop))
        arc_owner.extend([k] * int(keep.sum())), arc_lo.extend(start[keep]), arc_hi.extend(stop[keep])
    if arc_owner:
        a_a, a_b, ids = _trace(camera, on_rim, np.array(arc_owner), np.array(arc_lo), np.array(arc_hi),
                               window, tol_px)
        segments.append(np.vstack([a_a, a_b]))
        weights.append(gains[ids])
    return np.concatenate(segments, axis=1), np.concatenate(weights)


def _quadratic_roots(q2, q1, q0):
    """Real roots of ``q2 s^2 + q1 s + q0`` per column, (2, n), NaN where absent (stable form)."""
    scale = np.maximum(np.maximum(np.abs(q2), np.abs(q1)), np.abs(q0))
    scale = np.where(scale > 0, scale, 1.0)
    q2, q1, q0 = q2 / scale, q1 / scale, q0 / scale
    disc = q1 * q1 - 4.0 * q2 * q0
    root = np.sqrt(np.where(disc >= 0, disc, np.nan))
    q = -0.5 * (q1 + np.where(q1 >= 0, root, -root))
    with np.errstate(divide="ignore", invalid="ignore"):
        first = np.where(q2 != 0, q / q2, np.nan)
        second = np.where(q != 0, q0 / q, np.nan)
        linear = np.abs(q2) <= 1e-14
        first = np.where(linear, np.where(q1 != 0, -q0 / q1, np.nan), first)
        second = np.where(linear, np.nan, second)
    return np.stack([first, second])


def _trace(camera, point, ids, lo, hi, window, tol_px):
    """Polyline of curves ``camera.project(point(ids, t))``, ``t`` from ``lo`` to ``hi``.

    Returns the start and end pixels of every accepted chord, (2, n) each, in increasing
    ``t``, and the curve index of each.
    """
    n = INITIAL_PIECES
    k = np.tile(np.arange(n), ids.size)
    ids = np.repeat(ids, n)
    lo, hi = np.repeat(lo, n), np.repeat(hi, n)
    a = np.where(k == 0, lo, lo + (hi - lo) * k / n)
    b = np.where(k == n - 1, hi, lo + (hi - lo) * (k + 1) / n)
    uv_a = camera.project(point(ids, a))
    uv_b = camera.project(point(ids, b))
    u0, v0, u1, v1 = window
    done_a, done_b, done_ids = [], [], []
    for depth in range(MAX_DEPTH + 1):
        if ids.size == 0:
            break
        m = 0.5 * (a + b)
        uv_m = camera.project(point(ids, m))
        chord = uv_b - uv_a
        length = np.hypot(*chord)
        off = uv_m - uv_a
        with np.errstate(divide="ignore", invalid="ignore"):
            sagitta = np.where(length > 0, np.abs(chord[0] * off[1] - chord[1] * off[0]) / length,
                               np.hypot(*off))
        # Near the window: the chord's box grown by what the curve may stray from it.
        grow = 3.0 * sagitta + 0.5 * length + 1.0
        near = ((np.maximum(uv_a[0], uv_b[0]) + grow >= u0) & (np.minimum(uv_a[0], uv_b[0]) - grow <= u1)
                & (np.maximum(uv_a[1], uv_b[1]) + grow >= v0) & (np.minimum(uv_a[1], uv_b[1]) - grow <= v1))
        split = near & ((sagitta > tol_px) | (length > MAX_CHORD_PX)) & (depth < MAX_DEPTH)
        keep = ~split
        done_a.append(uv_a[:, keep]), done_b.append(uv_b[:, keep]), done_ids.append(ids[keep])
        ids = np.concatenate([ids[split], ids[split]])
        a, b = np.concatenate([a[split], m[split]]), np.concatenate([m[split], b[split]])
        uv_a = np.concatenate([uv_a[:, split], uv_m[:, split]], axis=1)
        uv_b = np.concatenate([uv_m[:, split], uv_b[:, split]], axis=1)
    return np.concatenate(done_a, axis=1), np.concatenate(done_b, axis=1), np.concatenate(done_ids)

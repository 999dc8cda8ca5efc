"""Lattices of cross-junctions grown over the image from junction candidates.

A seed candidate and its nearest neighbours of the opposite parity form a cross of five
nodes, lattice keys ``(0, 0), (+-1, 0), (0, +-1)``. The lattice then grows one ring of
keys at a time: every free key next to a node is predicted by extrapolating the lattice
lines through it (quadratic along a line of three known nodes, linear along two, or by
completing a parallelogram), which follows perspective and moderate lens distortion
alike. A prediction is snapped to a candidate within a quarter of the local step, and
the result must pass the ring test (:func:`graphpose.detect.search.ring_test`, at about a
third of the local square) with the parity its key demands: ``theta`` as the seed's on
keys with ``i + j`` even, a quarter turn from it on the others. So growth follows the
board's junctions, recovers junctions the candidate search missed, and stops at the
board's edge, where the outer squares' corners are L-shaped and fail the test. Keys are
right-handed in the image (``i`` to ``j`` turns clockwise on the screen, as ``u`` to
``v``), so a board seen from its front maps to them by a rotation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree
from skimage.measure import points_in_poly

from ..errors import BoardNotFoundError
from .grid import fit_homography
from .search import Candidates

_STEPS = ((1, 0), (-1, 0), (0, 1), (0, -1))
#: Ring-test radius as a fraction of the local lattice step.
RING_FRACTION = 0.35
#: Smallest ring-test score that counts as a cross-junction.
MIN_SCORE = 0.1
#: ``cos(2 (theta - theta0))`` beyond which two junctions have the same (or opposite) parity.
PARITY_COS = 0.5
#: A prediction is snapped to a candidate within this fraction of the local step.
SNAP_FRACTION = 0.25


@dataclass(frozen=True)
class Lattice:
    """A grown lattice of cross-junctions.

    Attributes
    ----------
    keys : (M, 2) ndarray of int
        Lattice coordinates ``(i, j)`` of the nodes, right-handed in the image.
    points : (2, M) ndarray of float64
        Their positions (u, v), full-image pixels, to about half a pixel.
    theta0 : float
        Bright-bisector direction of the nodes with ``i + j`` even, radians.
    """

    keys: np.ndarray
    points: np.ndarray
    theta0: float

    def as_dict(self) -> dict:
        """``{(i, j): (2,) position}``."""
        return {(int(i), int(j)): self.points[:, k] for k, (i, j) in enumerate(self.keys)}


def grow_lattices(cands: Candidates, *, max_seeds: int = 60, max_nodes: int = 2000, min_nodes: int = 4):
    """Lattices grown from the strongest candidates, each from a seed no earlier lattice holds.

    Parameters
    ----------
    cands : Candidates
        From :func:`graphpose.detect.search.find_candidates`.
    max_seeds : int
        Seeds tried at most.
    max_nodes : int
        A lattice stops growing at this many nodes (a tiled floor is not a board).
    min_nodes : int
        Smaller lattices are not yielded.

    Yields
    ------
    strength : float
        The seed's saddle response (seeds come strongest first).
    lattice : Lattice or None
        The peeled (:func:`peel`) lattice the seed grew, or None where it grew none (so a
        caller can stop once the seeds grow weak).
    """
    if cands.points.shape[1] < 3:
        return
    tree = cKDTree(cands.points.T)
    taken = ~cands.seed
    tried = 0
    for k in np.argsort(cands.strength)[::-1]:
        if tried >= max_seeds:
            return
        if taken[k]:
            continue
        tried += 1
        strength = float(cands.strength[k])
        cross = _seed_cross(cands, tree, k)
        if cross is None:
            yield strength, None
            continue
        nodes, theta0 = cross
        nodes = peel(_grow(cands, tree, nodes, theta0, max_nodes))
        if len(nodes) < min_nodes:
            yield strength, None
            continue
        keys = np.array(list(nodes), dtype=int)
        points = np.array(list(nodes.values())).T
        taken |= _within(cands.points, points, keys)
        yield strength, Lattice(keys, points, theta0)


def _within(P: np.ndarray, points: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Candidates (2, N) inside the lattice's key box grown by 1.5 steps, mapped to the image
    by a homography fitted to the nodes (its own board: its junctions, corners and margin
    are no seeds of another lattice)."""
    lo, hi = keys.min(axis=0) - 1.5, keys.max(axis=0) + 1.5
    box = np.array([[lo[0], hi[0], hi[0], lo[0]], [lo[1], lo[1], hi[1], hi[1]]])
    try:
        H = fit_homography(keys.T.astype(float), points)
    except BoardNotFoundError:  # collinear nodes fix no homography and hold no area
        return np.zeros(P.shape[1], dtype=bool)
    q = H @ np.vstack([box, np.ones(4)])
    if not (np.all(q[2] > 0) or np.all(q[2] < 0)):  # the box crosses the horizon
        return np.zeros(P.shape[1], dtype=bool)
    return points_in_poly(P.T, (q[:2] / q[2]).T)


def peel(nodes: dict) -> dict:
    """Drop, repeatedly, nodes with fewer than two lattice neighbours (strays beyond an edge)."""
    nodes = dict(nodes)
    while True:
        drop = [key for key in nodes if sum((key[0] + a, key[1] + b) in nodes for a, b in _STEPS) < 2]
        if not drop:
            return nodes
        for key in drop:
            del nodes[key]


def step_lengths(nodes: dict, keys) -> np.ndarray:
    """Typical lattice step (pixels) at each key: the mean distance to its lattice neighbours."""
    grid = KeyGrid(nodes)
    K = np.asarray(keys, dtype=int).reshape(-1, 2)
    here = grid.at(K)
    d = np.stack([np.hypot(*(grid.at(K + step) - here)) for step in _STEPS])  # (4, n), NaN: none
    with np.errstate(invalid="ignore"):
        count = np.sum(np.isfinite(d), axis=0)
        return np.where(count > 0, np.nansum(d, axis=0) / np.maximum(count, 1), np.nan)


class KeyGrid:
    """Node positions on a dense array over their key box (NaN where no node), for
    looking up many keys and their neighbours at once.

    Parameters
    ----------
    nodes : dict
        ``{(i, j): (u, v)}``.
    reach : int
        Margin of NaN kept around the nodes' key box (keys beyond it read NaN too, a
        little slower).
    """

    def __init__(self, nodes: dict, reach: int = 4):
        K = np.array(list(nodes), dtype=int).reshape(-1, 2)
        self.origin = K.min(axis=0) - reach
        shape = K.max(axis=0) - self.origin + reach + 1
        self.array = np.full((shape[0], shape[1], 2), np.nan)
        self.array[K[:, 0] - self.origin[0], K[:, 1] - self.origin[1]] = np.array(list(nodes.values()), dtype=float)

    def at(self, keys: np.ndarray) -> np.ndarray:
        """Positions (2, n) of keys (n, 2); NaN where there is no node."""
        idx = keys - self.origin
        shape = self.array.shape
        inside = (idx[:, 0] >= 0) & (idx[:, 1] >= 0) & (idx[:, 0] < shape[0]) & (idx[:, 1] < shape[1])
        if inside.all():
            return self.array[idx[:, 0], idx[:, 1]].T
        out = np.full((2, keys.shape[0]), np.nan)
        out[:, inside] = self.array[idx[inside, 0], idx[inside, 1]].T
        return out


def predict(nodes: dict, key) -> tuple | None:
    """Predicted position ``(u, v)`` of a free key from the lattice lines through it, and the
    local step length (pixels); None when no line or parallelogram reaches it.

    ``nodes`` maps keys to ``(u, v)`` tuples of floats (plain floats: this runs per key).
    """
    i, j = key
    su = sv = 0.0
    steps = []
    for di, dj in _STEPS:
        a = nodes.get((i - di, j - dj))
        b = nodes.get((i - 2 * di, j - 2 * dj))
        if a is None or b is None:
            continue
        c = nodes.get((i - 3 * di, j - 3 * dj))
        if c is None:
            su += 2 * a[0] - b[0]
            sv += 2 * a[1] - b[1]
        else:
            su += 3 * a[0] - 3 * b[0] + c[0]
            sv += 3 * a[1] - 3 * b[1] + c[1]
        steps.append(math.hypot(a[0] - b[0], a[1] - b[1]))
    if not steps:
        for di, dj in _STEPS:
            a = nodes.get((i - di, j - dj))
            if a is None:
                continue
            for ei, ej in _STEPS:
                if ei * di + ej * dj:
                    continue
                b1 = nodes.get((i - di + ei, j - dj + ej))
                b2 = nodes.get((i + ei, j + ej))
                if b1 is not None and b2 is not None:
                    su += a[0] + b2[0] - b1[0]
                    sv += a[1] + b2[1] - b1[1]
                    steps.append(math.hypot(b2[0] - b1[0], b2[1] - b1[1]))
    if not steps:
        return None
    n = len(steps)
    steps.sort()
    step = steps[n // 2] if n % 2 else 0.5 * (steps[n // 2 - 1] + steps[n // 2])
    return (su / n, sv / n), step


def _seed_cross(cands: Candidates, tree: cKDTree, k: int):
    """A cross of five (or four) nodes around candidate ``k``, and theta0; None if none."""
    centre = cands.points[:, k]
    count = min(13, cands.points.shape[1])
    _, nb = tree.query(centre, k=count)
    nb = nb[1:]
    vec = cands.points[:, nb] - centre[:, None]
    length = np.hypot(*vec)
    opposite = np.flatnonzero(np.cos(2 * (cands.theta[nb] - cands.theta[k])) < -PARITY_COS)
    if opposite.size < 3:
        return None
    best = None
    for a in opposite[:3]:
        v1 = vec[:, a]
        b = _along(vec, length, opposite, -v1)
        sideways = [n for n in opposite if n not in (a, b)
                    and abs(v1[0] * vec[1, n] - v1[1] * vec[0, n]) > 0.5 * length[a] * length[n]]
        if not sideways:
            continue
        c = sideways[0]
        d = _along(vec, length, opposite, -vec[:, c])
        nodes = {(0, 0): centre, (1, 0): cands.points[:, nb[a]], (0, 1): cands.points[:, nb[c]]}
        if b is not None:
            nodes[(-1, 0)] = cands.points[:, nb[b]]
        if d is not None:
            nodes[(0, -1)] = cands.points[:, nb[d]]
        if len(nodes) >= 4 and (best is None or len(nodes) > len(best)):
            best = nodes
    if best is None:
        return None
    v1, v2 = best[(1, 0)] - centre, best[(0, 1)] - centre
    if v1[0] * v2[1] - v1[1] * v2[0] < 0:  # make (i, j) turn like (u, v)
        best = {(j, i): p for (i, j), p in best.items()}
    keys = list(best)
    P = np.array(list(best.values())).T
    step = np.median([np.hypot(*(p - centre)) for key, p in best.items() if key != (0, 0)])
    score, theta, _ = cands.view.ring_test(P, RING_FRACTION * step)
    theta0 = theta[keys.index((0, 0))]
    parity = np.array([(i + j) % 2 for i, j in keys])
    if np.any(score < MIN_SCORE) or not np.all(_parity_ok(theta, theta0, parity)):
        return None
    return best, theta0


def _along(vec, length, pool, direction):
    """Index in ``pool`` of the neighbour closest to ``direction`` (within 15 degrees and
    0.7-1.4 of its length), or None."""
    size = np.hypot(*direction)
    cos = (direction @ vec[:, pool]) / (size * np.maximum(length[pool], 1e-12))
    ratio = length[pool] / size
    ok = (cos > np.cos(np.radians(15))) & (ratio > 0.7) & (ratio < 1.4)
    if not ok.any():
        return None
    err = np.hypot(*(vec[:, pool[ok]] - direction[:, None]))
    return pool[ok][np.argmin(err)]


def _parity_ok(theta, theta0, parity):
    c = np.cos(2 * (theta - theta0))
    return np.where(parity == 0, c > PARITY_COS, c < -PARITY_COS)


def _grow(cands: Candidates, tree: cKDTree, nodes: dict, theta0: float, max_nodes: int) -> dict:
    """Grow ``nodes`` ring by ring until no free neighbouring key passes (see the module).

    Each round looks only at the free neighbours of the nodes added in the round before
    (a key refused once is looked at again when a new neighbour can predict it better);
    when that adds nothing, one round looks at every free neighbour, whose predictions
    now rest on more of the lattice.
    """
    nodes = {key: (float(p[0]), float(p[1])) for key, p in nodes.items()}
    height, width = cands.view.shape
    fresh, full = list(nodes), False
    while len(nodes) < max_nodes:
        if not fresh:
            if full:
                break
            fresh, full = list(nodes), True
        keys, guesses, steps = [], [], []
        seen = set()
        for i, j in fresh:
            for di, dj in _STEPS:
                key = (i + di, j + dj)
                if key in nodes or key in seen:
                    continue
                seen.add(key)
                guess = predict(nodes, key)
                if guess is not None:
                    keys.append(key)
                    guesses.append(guess[0])
                    steps.append(guess[1])
        if not keys:
            if full:
                break
            fresh = []
            continue
        P = np.array(guesses).T
        step = np.array(steps)
        margin = RING_FRACTION * step + 1.0
        inside = (P[0] > margin) & (P[1] > margin) & (P[0] < width - 1 - margin) & (P[1] < height - 1 - margin)
        dist, idx = tree.query(P.T)
        snap = dist < SNAP_FRACTION * step
        Q = np.where(snap, cands.points[:, np.minimum(idx, cands.points.shape[1] - 1)], P)
        score, theta, _ = cands.view.ring_test(Q, RING_FRACTION * step)
        parity = np.array([(i + j) % 2 for i, j in keys])
        good = np.flatnonzero(inside & (score > MIN_SCORE) & _parity_ok(theta, theta0, parity))
        fresh = [keys[n] for n in good]
        full = full and not fresh
        for n in good:
            nodes[keys[n]] = (float(Q[0, n]), float(Q[1, n]))
    return {key: np.array(p) for key, p in nodes.items()}

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

from dataclasses import dataclass

import numpy as np

from ..errors import BoardNotFoundError
from . import _lattice
from .grid import fit_homography
from .search import Candidates, in_polygon

#: Ring-test radius as a fraction of the local lattice step.
RING_FRACTION = 0.35
#: Smallest ring-test score that counts as a cross-junction.
MIN_SCORE = 0.1
#: ``cos(2 (theta - theta0))`` beyond which two junctions have the same (or opposite) parity.
PARITY_COS = 0.5
#: A prediction is snapped to a candidate within this fraction of the local step.
SNAP_FRACTION = 0.25
#: Seeds whose neighbours are looked up together (the next ones not yet on a lattice).
_QUERY_AHEAD = 16


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
    homography : (3, 3) ndarray or None
        Key-to-image homography fitted to the nodes (:func:`graphpose.detect.grid.fit_homography`
        of ``(i, j)`` to ``(u, v)``), as :func:`grow_lattices` fitted it; None where it fitted
        none (collinear nodes) or the lattice was made elsewhere.
    """

    keys: np.ndarray
    points: np.ndarray
    theta0: float
    homography: np.ndarray | None = None

    def as_dict(self) -> dict:
        """``{(i, j): (2,) position}``."""
        return {(int(i), int(j)): self.points[:, k] for k, (i, j) in enumerate(self.keys)}

    def step_lengths(self) -> np.ndarray:
        """:func:`step_lengths` at every node (M,), pixels, from the arrays themselves."""
        return _step_lengths(KeyGrid.of(self.keys, self.points), self.keys)


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
    buckets = _buckets(cands.points)
    taken = ~cands.seed
    tried = 0
    order = np.argsort(cands.strength)[::-1]
    count = min(13, cands.points.shape[1])
    neighbours = {}  # candidate -> its nearest neighbours, queried for several seeds at once
    for rank, k in enumerate(order):
        if tried >= max_seeds:
            return
        if taken[k]:
            continue
        tried += 1
        strength = float(cands.strength[k])
        if k not in neighbours:
            ahead = [n for n in order[rank:rank + 4 * _QUERY_AHEAD] if not taken[n]][:_QUERY_AHEAD]
            nb = np.empty((len(ahead), count), dtype=np.int64)
            _lattice.nearest(cands.points, np.array(ahead, dtype=np.int64), nb)
            neighbours.update(zip(ahead, nb[:, 1:]))
        cross = _seed_cross(cands, neighbours[k], k)
        if cross is None:
            yield strength, None
            continue
        nodes, theta0 = cross
        keys, rows = _grow(cands, buckets, nodes, theta0, max_nodes)
        kept = _peeled(keys)
        if kept.sum() < min_nodes:
            yield strength, None
            continue
        keys, points = keys[kept].astype(int), rows[kept].T
        within, H = _within(cands.points, points, keys)
        taken |= within
        yield strength, Lattice(keys, points, theta0, H)


def _within(P: np.ndarray, points: np.ndarray, keys: np.ndarray) -> tuple:
    """Candidates (2, N) inside the lattice's key box grown by 1.5 steps, mapped to the image
    by a homography fitted to the nodes (its own board: its junctions, corners and margin
    are no seeds of another lattice): the mask (N,) and that homography (None if none)."""
    lo, hi = keys.min(axis=0) - 1.5, keys.max(axis=0) + 1.5
    box = np.array([[lo[0], hi[0], hi[0], lo[0]], [lo[1], lo[1], hi[1], hi[1]]])
    try:
        H = fit_homography(keys.T.astype(float), points)
    except BoardNotFoundError:  # collinear nodes fix no homography and hold no area
        return np.zeros(P.shape[1], dtype=bool), None
    q = H @ np.vstack([box, np.ones(4)])
    if not (np.all(q[2] > 0) or np.all(q[2] < 0)):  # the box crosses the horizon
        return np.zeros(P.shape[1], dtype=bool), H
    return in_polygon(P, q[:2] / q[2]), H


def peel(nodes: dict) -> dict:
    """Drop, repeatedly, nodes with fewer than two lattice neighbours (strays beyond an edge)."""
    keys = list(nodes)
    kept = _peeled(np.array(keys, dtype=np.int64).reshape(-1, 2))
    return {key: nodes[key] for key, keep in zip(keys, kept) if keep}


def _peeled(keys: np.ndarray) -> np.ndarray:
    """Which of the (distinct) keys (M, 2) :func:`peel` keeps, (M,) bool: the nodes of two
    lattice neighbours or more, by rounds on an occupancy array over their key box."""
    kept = np.ones(len(keys), dtype=bool)
    if not len(keys):
        return kept
    idx = keys - keys.min(axis=0) + 1
    occupied = np.zeros(tuple(idx.max(axis=0) + 2), dtype=bool)
    occupied[idx[:, 0], idx[:, 1]] = True
    i, j = idx[:, 0], idx[:, 1]
    while True:
        count = (occupied[i + 1, j].astype(np.int8) + occupied[i - 1, j] + occupied[i, j + 1] + occupied[i, j - 1])
        drop = kept & (count < 2)
        if not drop.any():
            return kept
        kept &= ~drop
        occupied[i[drop], j[drop]] = False


def step_lengths(nodes: dict, keys) -> np.ndarray:
    """Typical lattice step (pixels) at each key: the mean distance to its lattice neighbours."""
    return _step_lengths(KeyGrid(nodes), keys)


def _step_lengths(grid, keys) -> np.ndarray:
    """:func:`step_lengths` of ``keys`` on a :class:`KeyGrid` of the nodes: one compiled
    pass (``_lattice.step_lengths``); NaN for a key that is no node or has no neighbour."""
    K = np.ascontiguousarray(np.asarray(keys).reshape(-1, 2), dtype=np.int64)
    out = np.empty(len(K))
    _lattice.step_lengths(grid.array, int(grid.origin[0]), int(grid.origin[1]), K, out)
    return out


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
        self._fill(K, np.array(list(nodes.values()), dtype=float), reach)

    @classmethod
    def of(cls, keys: np.ndarray, points: np.ndarray, reach: int = 4) -> "KeyGrid":
        """The grid of nodes given as arrays: keys (M, 2) at points (2, M), no dict made."""
        grid = cls.__new__(cls)
        grid._fill(np.asarray(keys, dtype=int).reshape(-1, 2), np.asarray(points, dtype=float).T, reach)
        return grid

    def _fill(self, K: np.ndarray, rows: np.ndarray, reach: int) -> None:
        self.reach = reach
        self.origin = K.min(axis=0) - reach
        shape = K.max(axis=0) - self.origin + reach + 1
        self.array = np.full((shape[0], shape[1], 2), np.nan)
        self.array[K[:, 0] - self.origin[0], K[:, 1] - self.origin[1]] = rows

    def cover(self, keys: np.ndarray) -> None:
        """Grow the array (by ``2 reach`` keys) where any of ``keys`` (n, 2) would lie within
        one key of its edge, so that every free neighbour of a node lies on it (as the
        compiled growth needs)."""
        if not len(keys):
            return
        idx = keys - self.origin
        shape = np.array(self.array.shape[:2])
        if np.any(idx.min(axis=0) < 1) or np.any(idx.max(axis=0) > shape - 2):
            lo = np.minimum(self.origin, keys.min(axis=0) - 2 * self.reach)
            hi = np.maximum(self.origin + shape - 1, keys.max(axis=0) + 2 * self.reach)
            array = np.full((hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, 2), np.nan)
            start = self.origin - lo
            array[start[0]:start[0] + shape[0], start[1]:start[1] + shape[1]] = self.array
            self.array, self.origin = array, lo

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

    Along each lattice line through the key whose two nearer nodes are known, the line is
    extrapolated (quadratically where a third node is known, else linearly); where no line
    reaches it, parallelograms over a neighbour complete it. The prediction is the mean of
    these, the step the median of their step lengths. ``nodes`` maps keys to ``(u, v)``.
    """
    grid = KeyGrid(nodes)
    return _lattice.predict_one(grid.array, int(grid.origin[0]), int(grid.origin[1]), int(key[0]), int(key[1]))


def _seed_cross(cands: Candidates, nb: np.ndarray, k: int):
    """A cross of five (or four) nodes around candidate ``k``, and theta0; None if none.

    ``nb`` are its nearest neighbours, itself excluded. Those of the opposite parity make
    the arms (:func:`graphpose.detect._lattice.pick_cross`), turned so that ``(i, j)`` turns
    like ``(u, v)``; the seed and every arm must pass the ring test at
    :data:`RING_FRACTION` of the arms' median length, with the parity its key demands. One
    compiled call (``_lattice.seed_cross``).
    """
    arms, theta0 = np.empty(5, dtype=np.int64), np.empty(1)
    if not _lattice.seed_cross(cands.points, cands.theta, np.ascontiguousarray(nb, dtype=np.int64), int(k),
                               cands.view.smooth, cands.view.level, PARITY_COS, RING_FRACTION, MIN_SCORE,
                               arms, theta0):
        return None
    a, b, c, d, swap = (int(n) for n in arms)
    best = {(0, 0): cands.points[:, k], (1, 0): cands.points[:, a], (0, 1): cands.points[:, c]}
    if b >= 0:
        best[(-1, 0)] = cands.points[:, b]
    if d >= 0:
        best[(0, -1)] = cands.points[:, d]
    if swap:  # make (i, j) turn like (u, v)
        best = {(j, i): p for (i, j), p in best.items()}
    return best, float(theta0[0])


def _grow(cands: Candidates, buckets: tuple, nodes: dict, theta0: float, max_nodes: int) -> tuple:
    """Grow ``nodes`` ring by ring until no free neighbouring key passes (see the module).

    Each round looks only at the free neighbours of the nodes added in the round before
    (a key refused once is looked at again when a new neighbour can predict it better);
    when that adds nothing, one round looks at every free neighbour, whose predictions
    now rest on more of the lattice. A prediction snaps to the nearest candidate within
    :data:`SNAP_FRACTION` of the local step (``buckets``: :func:`_buckets`). The rounds are
    one compiled call (``_lattice.grow``), again only when the lattice outgrows its grid.
    Returns the keys (M, 2) of int64 in the order they were added and their positions
    (M, 2), pixels.
    """
    grid = KeyGrid(nodes, reach=8)
    start_keys = np.array(list(nodes), dtype=np.int64)
    capacity = 5 * max(max_nodes, len(nodes)) + 8
    order, fresh = np.zeros((capacity, 2), dtype=np.int64), np.zeros((capacity, 2), dtype=np.int64)
    order[:len(start_keys)] = fresh[:len(start_keys)] = start_keys
    keys, guess, step = np.empty((4 * capacity, 2), dtype=np.int64), np.empty((4 * capacity, 2)), np.empty(4 * capacity)
    state = np.array([len(start_keys), len(start_keys), 0, 0], dtype=np.int64)
    height, width = cands.view.shape
    start, items, nx, ny, cell = buckets
    while True:
        stamp = np.zeros(grid.array.shape[:2], dtype=np.int32)
        if not _lattice.grow(grid.array, int(grid.origin[0]), int(grid.origin[1]), stamp, order, fresh, state,
                             max_nodes, cands.points, start, items, nx, ny, cell, cands.view.smooth, cands.view.level,
                             float(width), float(height), float(theta0), RING_FRACTION, SNAP_FRACTION, MIN_SCORE,
                             PARITY_COS, keys, guess, step):
            break
        grid.cover(order[:state[0]])
    order = order[:state[0]]
    return order, grid.at(order).T.copy()


def _buckets(points: np.ndarray, cell: float = 16.0) -> tuple:
    """Candidates (2, N) sorted into square cells of ``cell`` pixels, for the growth's
    nearest-candidate look-ups: ``(start, items, nx, ny, cell)``, the candidates of cell
    ``cy nx + cx`` being ``items[start[c]:start[c + 1]]``."""
    cx = np.floor(np.maximum(points[0], 0.0) / cell).astype(np.int64)
    cy = np.floor(np.maximum(points[1], 0.0) / cell).astype(np.int64)
    nx, ny = int(cx.max()) + 1, int(cy.max()) + 1
    c = cy * nx + cx
    items = np.argsort(c, kind="stable").astype(np.int64)
    start = np.searchsorted(c[items], np.arange(nx * ny + 1)).astype(np.int64)
    return start, items, nx, ny, float(cell)

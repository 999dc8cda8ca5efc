"""Helpers the tests share: random poses in front of the board, central differences, the
project's camera as a command-line option.

One home for what several test files need: a test imports these from here (the fixtures and
the data folders stay in :mod:`tests.conftest`). Each helper draws from the ``rng`` it is
given, in a fixed order, so a seed gives a test the same poses run after run.
"""

import numpy as np

from graphpose.geometry import C_from_rpy, T_from_params
from tests.conftest import BOARD_WPTS, PROJECT_K

#: The project's camera as the CLI's ``--K fx,fy,cx,cy`` option (the bundled example's).
PROJECT_K_OPTION = ",".join(repr(float(v)) for v in (PROJECT_K[0, 0], PROJECT_K[1, 1], PROJECT_K[0, 2],
                                                     PROJECT_K[1, 2]))


def random_pose(rng) -> np.ndarray:
    """``T_WC`` (4, 4) of a camera 0.6-1.5 m in front of the board's centre, looking along its
    optical axis at it, tilted up to about 35 degrees (roll and pitch up to 0.6 rad) and turned
    up to 0.35 rad about the board's normal (yaw).
    """
    params = [0, 0, 0, rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), rng.uniform(-0.35, 0.35)]
    C = T_from_params(params)[:3, :3]
    T = np.eye(4)
    T[:3, :3] = C
    T[:3, 3] = BOARD_WPTS.mean(axis=1) - rng.uniform(0.6, 1.5) * C[:, 2]
    return T


def facing_pose(rng, distance=(0.6, 1.5), max_tilt_deg=35.0) -> np.ndarray:
    """``T_WC`` (4, 4) of a camera like the real images': ``distance`` (m) from the board's
    centre, its position up to ``max_tilt_deg`` off the board's normal in a random direction,
    looking at a point within a few cm of the centre, turned up to 20 degrees about its axis.
    """
    centre = BOARD_WPTS.mean(axis=1)
    tilt, az = np.radians(rng.uniform(0, max_tilt_deg)), rng.uniform(0, 2 * np.pi)
    c = centre + rng.uniform(*distance) * np.array(
        [np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), -np.cos(tilt)])
    z = centre + rng.normal(0, 0.03, 3) * [1, 1, 0] - c
    z /= np.linalg.norm(z)
    x = np.array([1.0, 0.0, 0.0]) - z[0] * z
    x /= np.linalg.norm(x)
    C = np.column_stack([x, np.cross(z, x), z])
    C = C @ C_from_rpy(0, 0, np.radians(rng.uniform(-20, 20)))
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = C, c
    return T


def central_difference(f, x, h=1e-6, relative=False) -> np.ndarray:
    """The Jacobian of ``f`` at ``x`` by central differences, one component of ``x`` at a time.

    ``x`` is (k,) (a parameter vector) or (k, N) (N points, each column moved together: the
    columns must be independent, as points projected one by one); ``f`` returns (2, N).
    ``relative``: the step is ``h * max(1, |x_i|)`` (for a 1-D ``x`` of mixed scales), else
    ``h``. Returns (N, 2, k).
    """
    x = np.asarray(x, dtype=float)
    J = []
    for i in range(x.shape[0]):
        step = h * max(1.0, abs(x[i])) if relative else h
        d = np.zeros_like(x)
        d[i] = step
        J.append(((f(x + d) - f(x - d)) / (2 * step)).T)
    return np.stack(J, axis=-1)


def wavy_trajectory(n):
    """``(t, poses)``: ``n`` frames at 30 fps, (n,) seconds, and ``T_WC`` (n, 4, 4) of a camera
    swaying about a pose 0.9 m in front of the board (smooth sines in every parameter)."""
    t = np.arange(n) / 30.0
    params = np.column_stack([0.22 + 0.1 * np.sin(t), 0.16 + 0.05 * np.sin(1.3 * t), -0.9 + 0.2 * np.sin(0.7 * t),
                              0.1 * np.sin(0.9 * t), 0.1 * np.sin(1.1 * t), 0.05 * np.sin(0.5 * t)])
    return t, np.array([T_from_params(p) for p in params])

"""The old positional ``rng`` of the synthetic-scene functions, still accepted.

Randomness comes through a keyword ``rng`` (``f(..., *, rng=None)``) everywhere in graphpose.
The public functions of :mod:`graphpose.synth` that used to take it positionally
(``random_pose(rng, camera)``, ``perturb_pose(rng, T_WC)``, ``loose_polygon(rendering, rng)``,
``random_scene(rng, K)``, ``HandHeldMotion(rng, K, ...)``) still accept those calls:
:func:`rng_was_positional` moves a seed found at the old position into the keyword, so callers
written for the old signatures keep working while new ones write ``rng=``.
"""

from __future__ import annotations

import functools

import numpy as np

#: What a seed may be: numpy.random.default_rng's accepted inputs (None included).
_SEEDS = (int, np.integer, np.random.Generator, np.random.BitGenerator, np.random.SeedSequence)


def is_seed(value) -> bool:
    """Whether ``value`` is a source of randomness (a Generator, a seed or None), not data."""
    return value is None or (isinstance(value, _SEEDS) and not isinstance(value, bool))


def rng_was_positional(index: int):
    """Decorate a function whose ``rng`` used to be positional argument ``index`` (0-based).

    A call with a seed (:func:`is_seed`) at that position and no ``rng=`` is the old form:
    the seed becomes ``rng`` and the other positional arguments close up.
    """

    def decorate(function):
        @functools.wraps(function)
        def wrapper(*args, **kwargs):
            if len(args) > index and "rng" not in kwargs and is_seed(args[index]):
                kwargs["rng"] = args[index]
                args = args[:index] + args[index + 1:]
            return function(*args, **kwargs)

        return wrapper

    return decorate

"""Old names kept for one release: a result attribute renamed, read through with a warning.

:func:`renamed` makes the old attribute a property that warns (DeprecationWarning) and gives
the new one's value, so code written against the old name runs, and says what to write
instead. The CHANGELOG lists every such name; they go in the release after next.
"""

from __future__ import annotations

import warnings


def renamed(old: str, new: str, convert=None) -> property:
    """A read-only property ``old`` that warns and returns ``self.<new>`` (through ``convert``
    when the unit changed with the name, so that the old name keeps its old unit)."""

    def get(self):
        warnings.warn(f"{type(self).__name__}.{old} is deprecated: use {new}", DeprecationWarning, stacklevel=2)
        value = getattr(self, new)
        return value if convert is None else convert(value)

    get.__doc__ = f"Deprecated: ``{new}``" + (" (in the old unit)." if convert else ".")
    return property(get)


def ignored_rng(who: str, *, rng) -> None:
    """Warn (DeprecationWarning, at the caller's caller) when ``who``'s deprecated ``rng`` is
    given: the calibrations draw nothing, so it is ignored; it goes in the next release."""
    if rng is not None:
        warnings.warn(f"{who}'s rng is deprecated and ignored (the calibration draws nothing)",
                      DeprecationWarning, stacklevel=3)

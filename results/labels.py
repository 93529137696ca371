"""Labels of pre-stretch and voltage levels, as the user typed them."""

from __future__ import annotations


def level_label(value: float) -> str:
    """A pre-stretch or voltage as the user typed it: round-off of the grid it came from is
    dropped (a ramp of steps 0.025 from 1.1 gives 1.2000000000000002).

    >>> level_label(1.1 + 4 * 0.025), level_label(1.0), level_label(1.0375)
    ('1.2', '1.0', '1.0375')
    """
    return repr(round(float(value), 10))

"""One way to validate a parameter: its name, its value, the bounds it must lie in.

Every scalar option of the library is checked here, so that every refusal reads the same::

    >>> check_number("range_m", 3)
    3.0
    >>> check_number("range_m", -1.0, low=0, low_open=True)
    Traceback (most recent call last):
    ...
    ValueError: range_m must be a finite number > 0, got range_m=-1.0
    >>> check_integer("beams", 4, low=8)
    Traceback (most recent call last):
    ...
    ValueError: beams must be an integer >= 8, got beams=4
    >>> check_choice("broadcast", "always", ("on_obstacle", "every_tick"))
    Traceback (most recent call last):
    ...
    ValueError: broadcast must be one of ['on_obstacle', 'every_tick'], got broadcast='always'

The message form is ``NAME must be REQUIREMENT, got NAME=VALUE``; ``NAME`` may be a dotted
config key (``sensor.range_m``) or a file location (``obstacles[3].radius``). Booleans are never
numbers. Pure Python and numpy.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np

__all__ = ["check_choice", "check_integer", "check_number", "check_vector", "is_integer",
           "is_number"]


def is_number(value: Any) -> bool:
    """True for a real number (int, float, numpy scalar), False for ``bool`` and the rest."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_))


def is_integer(value: Any) -> bool:
    """True for an integer (int or numpy integer), False for ``bool``, floats and the rest."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _bounds_text(low: float | None, high: float | None, low_open: bool, high_open: bool) -> str:
    if low is not None and high is not None:
        return f" in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
    if low is not None:
        return f" {'>' if low_open else '>='} {low:g}"
    if high is not None:
        return f" {'<' if high_open else '<='} {high:g}"
    return ""


def _check_bounds(name: str, value: Any, kind: str, number: float, low: float | None,
                  high: float | None, low_open: bool, high_open: bool) -> None:
    too_low = low is not None and (number <= low if low_open else number < low)
    too_high = high is not None and (number >= high if high_open else number > high)
    if too_low or too_high:
        raise ValueError(f"{name} must be {kind}{_bounds_text(low, high, low_open, high_open)}, "
                         f"got {name}={value!r}")


def check_number(name: str, value: Any, *, low: float | None = None, high: float | None = None,
                 low_open: bool = False, high_open: bool = False) -> float:
    """Return ``value`` as a float if it is a finite number within the bounds.

    Parameters
    ----------
    name : str
        The parameter's name, as the caller knows it (used in the message).
    value : object
        The value to check.
    low, high : float, optional
        Bounds; ``None`` leaves that side open-ended.
    low_open, high_open : bool
        Exclude the bound itself (``> low`` rather than ``>= low``).

    Returns
    -------
    float

    Raises
    ------
    ValueError
        ``NAME must be a finite number [bounds], got NAME=VALUE``.
    """
    if not is_number(value) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number"
                         f"{_bounds_text(low, high, low_open, high_open)}, got {name}={value!r}")
    _check_bounds(name, value, "a finite number", float(value), low, high, low_open, high_open)
    return float(value)


def check_integer(name: str, value: Any, *, low: int | None = None,
                  high: int | None = None) -> int:
    """Return ``value`` as an int if it is an integer in ``[low, high]``.

    Raises
    ------
    ValueError
        ``NAME must be an integer [bounds], got NAME=VALUE`` (floats such as ``3.0`` and
        booleans are refused).
    """
    if not is_integer(value):
        raise ValueError(f"{name} must be an integer{_bounds_text(low, high, False, False)}, "
                         f"got {name}={value!r}")
    _check_bounds(name, value, "an integer", int(value), low, high, False, False)
    return int(value)


def check_choice(name: str, value: Any, choices: Iterable[Any]) -> Any:
    """Return ``value`` if it is one of ``choices``; ValueError listing them otherwise."""
    options = list(choices)
    if isinstance(value, bool) or value not in options:
        raise ValueError(f"{name} must be one of {options}, got {name}={value!r}")
    return value


def check_vector(name: str, value: Any, n: int) -> tuple[float, ...]:
    """Return ``value`` as a tuple of ``n`` floats if it is a list or tuple of ``n`` finite
    numbers; element ``i`` is checked as ``NAME[i]``."""
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise ValueError(f"{name} must be a list of {n} numbers, got {name}={value!r:.80}")
    return tuple(check_number(f"{name}[{i}]", v) for i, v in enumerate(value))

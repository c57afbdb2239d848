"""One way to validate a parameter: its name, its value, the bounds it must lie in.

Every scalar option of the library is checked here, so that every refusal reads the same. A
function (or a constructor taking arguments) calls the ``check_*`` helpers on its arguments::

    >>> check_number("range_m", 3)
    3.0
    >>> check_number("range_m", -1.0, low=0, low_open=True)
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: range_m must be a finite number > 0, got range_m=-1.0
    >>> check_integer("beams", 4, low=8)
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: beams must be an integer >= 8, got beams=4
    >>> check_choice("broadcast", "always", ("on_obstacle", "every_tick"))
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: broadcast must be one of ['on_obstacle', 'every_tick'], \
got broadcast='always'

A dataclass declares the check on each field instead (:func:`number_field`,
:func:`integer_field`, :func:`choice_field`, :func:`checked_field`) and derives from
:class:`Checked`, which runs them when an instance is made, then its rules between fields
(:meth:`Checked._check_together`)::

    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Lidar(Checked):
    ...     beams: int = integer_field(360, low=8)
    ...     range_m: float = number_field(3.0, low=0, low_open=True)
    >>> Lidar(range_m=5).range_m
    5.0
    >>> Lidar(beams=4)
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: beams must be an integer >= 8, got beams=4
    >>> Lidar.checked({"range_m": 0}, prefix="sensor.")
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: sensor.range_m must be a finite number > 0, got sensor.range_m=0

The message form is ``NAME must be REQUIREMENT, got NAME=VALUE``; ``NAME`` may be a dotted
config key (``sensor.range_m``) or a file location (``obstacles[3].radius``). Every refusal is a
:class:`fftnav.errors.FftnavError`, a ``ValueError``. Booleans are never numbers. Pure Python
and numpy.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import MISSING
from functools import partial
from typing import Any, TypeVar

import numpy as np

from fftnav.errors import FftnavError

__all__ = ["Checked", "check_choice", "check_integer", "check_multiple", "check_number",
           "check_vector", "checked_field", "choice_field", "integer_field", "is_integer",
           "is_number", "number_field"]

#: A check: ``check(name, value)`` returns the value to keep or raises FftnavError naming it.
Check = Callable[[str, Any], Any]
_C = TypeVar("_C", bound="Checked")


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


def _check_bounds(name: str, value: Any, *, kind: str, number: float, low: float | None,
                  high: float | None, low_open: bool = False, high_open: bool = False) -> None:
    too_low = low is not None and (number <= low if low_open else number < low)
    too_high = high is not None and (number >= high if high_open else number > high)
    if too_low or too_high:
        raise FftnavError(f"{name} must be {kind}{_bounds_text(low, high, low_open, high_open)}, "
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
    FftnavError
        ``NAME must be a finite number [bounds], got NAME=VALUE``.
    """
    if not is_number(value) or not math.isfinite(value):
        raise FftnavError(f"{name} must be a finite number"
                          f"{_bounds_text(low, high, low_open, high_open)}, got {name}={value!r}")
    _check_bounds(name, value, kind="a finite number", number=float(value), low=low, high=high,
                  low_open=low_open, high_open=high_open)
    return float(value)


def check_integer(name: str, value: Any, *, low: int | None = None,
                  high: int | None = None) -> int:
    """Return ``value`` as an int if it is an integer in ``[low, high]``.

    Raises
    ------
    FftnavError
        ``NAME must be an integer [bounds], got NAME=VALUE`` (floats such as ``3.0`` and
        booleans are refused).
    """
    if not is_integer(value):
        raise FftnavError(f"{name} must be an integer{_bounds_text(low, high, False, False)}, "
                          f"got {name}={value!r}")
    _check_bounds(name, value, kind="an integer", number=int(value), low=low, high=high)
    return int(value)


def check_choice(name: str, value: Any, choices: Iterable[Any]) -> Any:
    """Return ``value`` if it is one of ``choices``; FftnavError listing them otherwise."""
    options = list(choices)
    if isinstance(value, bool) or value not in options:
        raise FftnavError(f"{name} must be one of {options}, got {name}={value!r}")
    return value


def check_vector(name: str, value: Any, n: int) -> tuple[float, ...]:
    """Return ``value`` as a tuple of ``n`` floats if it is a list or tuple of ``n`` finite
    numbers; element ``i`` is checked as ``NAME[i]``."""
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise FftnavError(f"{name} must be a list of {n} numbers, got {name}={value!r:.80}")
    return tuple(check_number(f"{name}[{i}]", v) for i, v in enumerate(value))


def check_multiple(name: str, value: float, base_name: str, base: float) -> int:
    """Return ``value / base`` if ``value`` is an integer multiple (at least 1) of ``base``.

    >>> check_multiple("physics_hz", 240.0, "control_hz", 10.0)
    24
    >>> check_multiple("physics_hz", 25.0, "control_hz", 10.0)
    Traceback (most recent call last):
    ...
    fftnav.errors.FftnavError: physics_hz must be an integer multiple of control_hz=10.0, \
got physics_hz=25.0
    """
    ratio = value / base
    if ratio < 1 or abs(ratio - round(ratio)) > 1e-9:
        raise FftnavError(f"{name} must be an integer multiple of {base_name}={base!r}, "
                          f"got {name}={value!r}")
    return round(ratio)


# ---------------------------------------------------------------- dataclass fields


def checked_field(check: Check, kind: type, default: Any = MISSING) -> Any:
    """A dataclass field validated by ``check(name, value)`` (whose result is stored) when a
    :class:`Checked` instance is made; ``kind`` is the Python type of its values (float, int
    or str), with which a command-line text is parsed."""
    return dataclasses.field(default=default, metadata={"check": check, "type": kind})


def _or_none(check: Check, name: str, value: Any) -> Any:
    return None if value is None else check(name, value)


def number_field(default: Any = MISSING, *, optional: bool = False, **bounds: Any) -> Any:
    """A float field checked by :func:`check_number` with ``bounds``; ``optional``: None is
    allowed too."""
    check: Check = partial(check_number, **bounds)
    return checked_field(partial(_or_none, check) if optional else check, float, default)


def integer_field(default: Any = MISSING, **bounds: Any) -> Any:
    """An int field checked by :func:`check_integer` with ``bounds``."""
    return checked_field(partial(check_integer, **bounds), int, default)


def choice_field(default: Any, choices: Iterable[Any]) -> Any:
    """A field whose value must be one of ``choices`` (:func:`check_choice`)."""
    return checked_field(partial(check_choice, choices=tuple(choices)), str, default)


class Checked:
    """Base of every dataclass that validates: making an instance runs each field's own check
    (the fields above; a field without one is taken as given), then :meth:`_check_together`."""

    @classmethod
    def keys(cls) -> tuple[str, ...]:
        """The field names, in declaration order."""
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def value_type(cls, key: str) -> type | None:
        """Python type of a checked field's values (float, int or str); None if unchecked."""
        return {f.name: f.metadata.get("type") for f in dataclasses.fields(cls)}[key]

    @classmethod
    def checked(cls, values: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
        """``values`` checked field by field (errors name ``prefix + key``), converted as their
        checks return them (floats as float); an unknown key is refused."""
        fields = {f.name: f for f in dataclasses.fields(cls)}
        out = {}
        for key, value in values.items():
            if key not in fields:
                raise FftnavError(f"unknown key {prefix}{key}; expected one of {list(fields)}")
            check = fields[key].metadata.get("check")
            out[key] = value if check is None else check(f"{prefix}{key}", value)
        return out

    @classmethod
    def from_table(cls: type[_C], table: str, values: Mapping[str, Any], **given: Any) -> _C:
        """An instance from the configuration table ``[table]``: a bad value is named
        ``table.key``, a broken rule between keys is prefixed ``[table]``; ``given`` are fields
        taken as they are (already checked)."""
        kwargs = cls.checked(values, prefix=f"{table}.")
        try:
            return cls(**kwargs, **given)
        except ValueError as exc:
            raise FftnavError(f"[{table}] {exc}") from None

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            check = f.metadata.get("check")
            if check is not None:
                object.__setattr__(self, f.name, check(f.name, getattr(self, f.name)))
        self._check_together()

    def _check_together(self) -> None:
        """Rules between fields (none by default); raise ValueError naming the field."""

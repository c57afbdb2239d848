"""One registry of named components, behind every ``register_*`` of fftnav.

Decision policies, controllers, measures, world kinds and obstacle shapes are each kept in a
:class:`Registry`: a dict from name to component, in registration order, whose :meth:`~Registry.add`
refuses a name twice and whose :meth:`~Registry.lookup` refuses an unknown name with one line that
lists the known names (and the installed entry points of its group, if it has one) and suggests
the closest ones (:func:`difflib.get_close_matches`). Everything downstream (CLI choices, config
validation, summary columns) iterates over the registry. Standard library only.

>>> COLOURS = Registry("colour", parameter="colour")
>>> red = COLOURS.add("red", (255, 0, 0))
>>> COLOURS.lookup("red")
(255, 0, 0)
>>> try:
...     COLOURS.lookup("rde")
... except UnknownNameError as exc:
...     print(exc)
colour must be a registered colour ('red'), got colour='rde'; did you mean 'red'?
"""

from __future__ import annotations

import difflib
import importlib.metadata
from collections.abc import Iterable
from typing import Any, TypeVar

from fftnav.errors import FftnavError

__all__ = ["Registry", "UnknownNameError", "first_line"]

T = TypeVar("T")


class UnknownNameError(FftnavError):
    """A name that no registry entry (nor installed entry point) has."""


def first_line(doc: str | None) -> str:
    """The first non-empty line of a docstring, stripped ('' for none): a component's
    one-line description.

    >>> first_line('''
    ...     Always pass on the left.
    ...
    ...     More text.''')
    'Always pass on the left.'
    """
    for line in (doc or "").strip().splitlines():
        if line.strip():
            return line.strip()
    return ""


class Registry(dict[str, T]):
    """Named components of one kind, in registration order.

    Parameters
    ----------
    kind : str
        What an entry is, in messages (``"policy"``, ``"world kind"``).
    parameter : str
        The parameter an unknown name was given for, in messages (``"env"``, ``"policy"``).
    entry_point_group : str, optional
        The entry-point group in which installed packages declare more components of this kind;
        their names are listed and suggested beside the registered ones.

    Notes
    -----
    A ``dict`` subclass: ``name in registry``, ``registry[name]``, iteration in registration
    order and ``monkeypatch.setitem`` in tests all work as on a dict; :meth:`add` is the one
    way the package registers.
    """

    def __init__(self, kind: str, *, parameter: str = "name",
                 entry_point_group: str | None = None) -> None:
        super().__init__()
        self.kind, self.parameter, self.entry_point_group = kind, parameter, entry_point_group

    def add(self, name: str, item: T) -> T:
        """Register ``item`` under ``name``; ValueError if the name is taken or not a
        non-empty string. Returns ``item``."""
        if not isinstance(name, str) or not name:
            raise FftnavError(f"a {self.kind} name must be a non-empty string, got name={name!r}")
        if name in self:
            raise FftnavError(f"{self.kind} {name!r} is already registered")
        self[name] = item
        return item

    def copy(self) -> Registry[T]:
        """A registry of the same kind with the same entries (for tests that register more)."""
        new: Registry[T] = Registry(self.kind, parameter=self.parameter,
                                    entry_point_group=self.entry_point_group)
        new.update(self)
        return new

    def entry_point_names(self) -> tuple[str, ...]:
        """Names of the installed entry points of the registry's group (none without one)."""
        if self.entry_point_group is None:
            return ()
        points = importlib.metadata.entry_points(group=self.entry_point_group)
        return tuple(sorted({ep.name for ep in points} - set(self)))

    def lookup(self, name: Any) -> T:
        """The entry ``name``; :class:`UnknownNameError` (a ValueError) otherwise."""
        try:
            return self[name]
        except (KeyError, TypeError):
            raise self.unknown(name) from None

    def unknown(self, name: Any, *, also: Iterable[str] = (), forms: str = "") -> UnknownNameError:
        """The error for an unknown ``name``: the known names, the installed entry points,
        and the closest of them (``also``: more names accepted in the same place, such as
        another registry's; ``forms``: other accepted forms, in words)."""
        names = [*self, *(n for n in also if n not in self)]
        points = [p for p in self.entry_point_names() if p not in names]
        known = ", ".join(repr(n) for n in names)
        text = f"{self.parameter} must be a registered {self.kind} ({known})"
        if points:
            text += f", an installed entry point of group {self.entry_point_group!r} (" + \
                ", ".join(repr(n) for n in points) + ")"
        if forms:
            text += f" or {forms}"
        text += f", got {self.parameter}={name!r}"
        if isinstance(name, str):
            close = difflib.get_close_matches(name, [*names, *points], n=3, cutoff=0.6)
            if close:
                text += "; did you mean " + " or ".join(repr(c) for c in close) + "?"
        return UnknownNameError(text)

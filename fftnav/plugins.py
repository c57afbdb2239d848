"""Load a plugin object named by a reference string: ``module:attr``, ``path/to/file.py:attr``
or an entry point of an installed package.

This module only finds and imports objects; what they must be (a decision policy, a
controller) is checked by :mod:`fftnav.navigation.resolve`. Standard library only.

Reference forms:

``package.module:attr``
    ``importlib.import_module("package.module")``, then the attribute ``attr`` (dotted
    attributes such as ``module:Class.factory`` are followed). The current directory is first
    on the import path while the module is imported, so ``my_module:attr`` finds
    ``./my_module.py`` also when fftnav runs as the ``fftnav`` command.
``path/to/file.py:attr``
    The Python file is executed as a fresh module (its name derived from its path, so it is
    loaded once per process); relative paths are taken from the current directory. Its folder
    is first on the import path while it is executed, as Python does for a script, so the file
    can ``import helpers`` from a ``helpers.py`` beside it.
entry point
    A bare name found in the entry-point group (``fftnav.policies`` for policies and
    controllers), as an installed package declares it in its ``pyproject.toml``::

        [project.entry-points."fftnav.policies"]
        my-policy = "my_package.module:MyController"

The import path (``sys.path``) is restored after loading: the modules imported then stay
imported (``sys.modules``), so a plugin's functions can use them later, also in the worker
processes of ``fftnav run`` (which load the plugin themselves from its reference). A module
beside the plugin must therefore be imported when the plugin file is loaded (at its top), not
first inside a function; and two plugin folders should not hold neighbour modules of the same
name (the first one imported is the one every plugin gets, as with any Python import).
:func:`plugin_sources` lists the plugin file and the neighbour modules it imported, whose
contents ``fftnav run`` records to refuse resuming a folder after any of them changed.

Every failure raises :class:`PluginError` (a ``ValueError``) with a one-line message naming the
reference, so the CLI prints it and exits 2 before any episode starts. What a loaded plugin
raises when it is called (:func:`plugin_call`, :class:`PluginProxy`) becomes a one-line
:class:`PluginError` too, naming the plugin, the call and the plugin's own file and line.

>>> load_reference("math:pi")
3.141592653589793
>>> try:
...     load_reference("math:nope")
... except PluginError as exc:
...     print(exc)
cannot load 'math:nope': module 'math' has no attribute 'nope'
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib
import importlib.metadata
import importlib.util
import inspect
import re
import sys
import traceback
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

from fftnav.errors import FftnavError

__all__ = ["PluginError", "PluginProxy", "entry_points", "file_sha256", "is_reference",
           "load_reference", "plugin_call", "plugin_sources", "reference_file", "source_file"]

_ATTR = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")
#: Plugin file -> the files of the modules under its folder first imported while it was loaded.
_NEIGHBOURS: dict[Path, tuple[Path, ...]] = {}


class PluginError(FftnavError):
    """A plugin reference that cannot be loaded (bad form, missing file, import error)."""


def is_reference(text: str) -> bool:
    """Whether ``text`` has the form ``something:attr`` (a module or file reference)."""
    head, sep, attr = text.rpartition(":")
    return bool(sep and head and _ATTR.match(attr))


def reference_file(text: str) -> Path | None:
    """The Python file of a ``path/to/file.py:attr`` reference (resolved), else None."""
    head, sep, _ = text.rpartition(":")
    if sep and head.endswith(".py"):
        return Path(head).expanduser().resolve()
    return None


def file_sha256(path: Path) -> str:
    """SHA-256 of a file's bytes, hex."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def entry_points(group: str) -> dict[str, Any]:
    """The entry points of ``group`` of the installed distributions, by name."""
    return {ep.name: ep for ep in importlib.metadata.entry_points(group=group)}


def _attribute(obj: Any, attr: str, where: str) -> Any:
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise AttributeError(f"{where} has no attribute {attr!r}") from None
    return obj


def plugin_sources(path: Path) -> tuple[Path, ...]:
    """The plugin file ``path`` (resolved) and the files of the modules under its folder that
    were first imported while it was loaded in this process (e.g. a ``helpers.py`` beside it),
    sorted after it; just ``(path,)`` before it is loaded."""
    path = Path(path).expanduser().resolve()
    return (path, *_NEIGHBOURS.get(path, ()))


@contextlib.contextmanager
def _first_on_path(folder: Path) -> Iterator[None]:
    """``folder`` first on ``sys.path`` for the duration; then that entry is removed again
    (whatever else the imported code did to ``sys.path`` is kept)."""
    entry = str(folder)
    sys.path.insert(0, entry)
    try:
        yield
    finally:
        with contextlib.suppress(ValueError):
            sys.path.remove(entry)  # the first occurrence: the one inserted here


def _module_files_under(folder: Path, names: set[str]) -> tuple[Path, ...]:
    """The files of the modules ``names`` (of ``sys.modules``) that lie under ``folder``,
    fftnav's own modules left out (their version is recorded apart)."""
    files = set()
    for name in names:
        if name.partition(".")[0] == "fftnav":
            continue
        file = getattr(sys.modules.get(name), "__file__", None)
        if isinstance(file, str):
            resolved = Path(file).resolve()
            if resolved.is_relative_to(folder):
                files.add(resolved)
    return tuple(sorted(files))


def _load_file(path: Path) -> Any:
    name = "fftnav_plugin_" + hashlib.sha1(str(path).encode()).hexdigest()[:12]
    if name in sys.modules:
        return sys.modules[name]
    if not path.is_file():
        raise FileNotFoundError(f"no such file {str(path)!r}")
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"{str(path)!r} is not a Python file")
    module = importlib.util.module_from_spec(spec)
    before = set(sys.modules)
    sys.modules[name] = module
    try:
        with _first_on_path(path.parent):
            spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    new = set(sys.modules) - before - {name}
    _NEIGHBOURS[path] = tuple(f for f in _module_files_under(path.parent, new) if f != path)
    return module


def load_reference(text: str, *, group: str | None = None) -> Any:
    """The object a reference names.

    Parameters
    ----------
    text : str
        ``module:attr``, ``path/to/file.py:attr`` or (with ``group``) an entry-point name.
    group : str, optional
        Entry-point group searched for a bare name.

    Returns
    -------
    object

    Raises
    ------
    PluginError
        Malformed reference, missing module, file or attribute, or any exception raised while
        importing the plugin (its type and message are kept, on one line).
    """
    if not isinstance(text, str) or not text:
        raise PluginError(f"a plugin reference must be a non-empty string, got {text!r}")
    try:
        if is_reference(text):
            head, _, attr = text.rpartition(":")
            path = reference_file(text)
            if path is not None:
                module = _load_file(path)
                return _attribute(module, attr, f"file {head!r}")
            with _first_on_path(Path.cwd()):
                module = importlib.import_module(head)
            return _attribute(module, attr, f"module {head!r}")
        if group is not None:
            points = entry_points(group)
            if text in points:
                return points[text].load()
        raise PluginError(f"{text!r} is not a plugin reference (module:attr or file.py:attr)"
                          + (f" nor an entry point of group {group!r}" if group else ""))
    except PluginError:
        raise
    except Exception as exc:  # import errors of any kind, raised by third-party code
        message = " ".join(str(exc).split()) or type(exc).__name__
        if not isinstance(exc, (AttributeError, FileNotFoundError)):
            message = f"{type(exc).__name__}: {message}"
        raise PluginError(f"cannot load {text!r}: {message}") from None


def source_file(obj: Any) -> Path | None:
    """The Python file that defines ``obj`` (a class or function), resolved; None if unknown."""
    try:
        file = inspect.getsourcefile(inspect.unwrap(obj))
    except TypeError:
        return None
    return Path(file).resolve() if file else None


def _where(exc: BaseException, source: Path | None, defined: Any) -> str:
    """``file:line`` of the innermost frame of ``exc``'s traceback in the plugin's file
    ``source``; else where ``defined`` (the plugin's function) is defined."""
    for frame in reversed(traceback.extract_tb(exc.__traceback__)):
        if source is not None and Path(frame.filename).resolve() == source:
            return f"{frame.filename}:{frame.lineno}"
    code = getattr(inspect.unwrap(getattr(defined, "__func__", defined)), "__code__", None)
    return f"{code.co_filename}:{code.co_firstlineno}" if code is not None else "unknown file"


def plugin_call(plugin: str, call: str, source: Path | None, fn: Callable[..., Any], /,
                *args: Any, defined: Any = None, **kwargs: Any) -> Any:
    """``fn(*args, **kwargs)``, a call into plugin ``plugin``; whatever it raises becomes a
    :class:`PluginError` on one line naming the plugin, the call and the plugin's own file and
    line (the innermost frame in ``source``; else where ``defined``, default ``fn``, is).

    >>> def decide(ctx):
    ...     return 1 / 0
    >>> try:
    ...     plugin_call("mine.py:decide", "decide", None, decide, None)
    ... except PluginError as exc:
    ...     print(str(exc).split(" (at ")[0])
    plugin 'mine.py:decide': decide raised ZeroDivisionError: division by zero
    """
    try:
        return fn(*args, **kwargs)
    except PluginError:
        raise
    except Exception as exc:  # anything third-party code raises, on one line
        message = " ".join(str(exc).split()) or "(no message)"
        raise PluginError(f"plugin {plugin!r}: {call} raised {type(exc).__name__}: {message} "
                          f"(at {_where(exc, source, fn if defined is None else defined)})"
                          ) from exc


class PluginProxy:
    """A plugin's object whose method calls go through :func:`plugin_call` (attributes that
    are not callable are passed through).

    Parameters
    ----------
    obj : object
        The plugin's object, e.g. a controller.
    plugin : str
        Its reference, as the user wrote it.
    source : Path or None
        Its Python file (:func:`source_file`).
    calls : mapping, optional
        Method name -> (the name to report, the function whose definition locates an error
        raised outside the plugin's file), e.g. ``{"step": ("Mine.act", obj.act)}`` when the
        method is inherited and calls the plugin's ``act``.
    """

    __slots__ = ("_obj", "_plugin", "_source", "_calls")

    def __init__(self, obj: Any, plugin: str, source: Path | None,
                 calls: Mapping[str, tuple[str, Any]] | None = None) -> None:
        self._obj, self._plugin, self._source = obj, plugin, source
        self._calls = dict(calls or {})

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._obj, name)
        if not callable(value):
            return value
        call, defined = self._calls.get(name, (f"{type(self._obj).__name__}.{name}", value))
        return functools.partial(plugin_call, self._plugin, call, self._source, value,
                                 defined=defined)

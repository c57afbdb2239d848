"""The library's errors: one base for a refused value, one error for a missing optional extra.

Every error fftnav raises on purpose derives from :class:`FftnavError`, a ``ValueError``: code
that catches ``ValueError`` keeps working, and ``except FftnavError`` catches the library's
refusals alone. A feature that needs an optional extra (``pip install 'fftnav[ros]'``) imports
its dependency through :func:`import_extra`, which raises :class:`MissingExtraError`, an
``ImportError`` whose message is the pip line::

    >>> import_extra("math", extra="fast", needed_for="a test").pi > 3
    True
    >>> import_extra("nomod.io", extra="ros", needed_for="ROS bags")
    Traceback (most recent call last):
    ...
    fftnav.errors.MissingExtraError: ROS bags need the nomod package: pip install 'fftnav[ros]'

Standard library only (layer 0 of docs/architecture.md).
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["FftnavError", "MissingExtraError", "import_extra"]


class FftnavError(ValueError):
    """A value the library refuses: ``NAME must be REQUIREMENT, got NAME=VALUE``, or a file
    that cannot be read, naming the file (the base of the library's errors)."""


class MissingExtraError(ImportError, FftnavError):
    """An optional dependency is not installed; the message names the pip line that installs
    it, and ``name`` is the module that could not be imported.

    It is an ``ImportError`` (what a missing module is) and a :class:`FftnavError` (one of the
    library's refusals, reported by the command line in one line).

    Parameters
    ----------
    module : str
        The module that could not be imported (its top-level package is named).
    extra : str
        The extra of fftnav that installs it (``fast``, ``marl``, ``video``, ``ros``).
    needed_for : str
        What needs it, a plural noun phrase (``"ROS bags"``).

    >>> err = MissingExtraError("rosbags.highlevel", extra="ros", needed_for="ROS bags")
    >>> str(err)
    "ROS bags need the rosbags package: pip install 'fftnav[ros]'"
    >>> err.name, err.extra, isinstance(err, ImportError), isinstance(err, ValueError)
    ('rosbags.highlevel', 'ros', True, True)
    """

    def __init__(self, module: str, extra: str, needed_for: str) -> None:
        package = module.split(".")[0]
        super().__init__(f"{needed_for} need the {package} package: "
                         f"pip install 'fftnav[{extra}]'", name=module)
        self.extra, self.needed_for = extra, needed_for

    def __reduce__(self) -> tuple:
        # made again from its parameters when pickled (e.g. raised in a worker process)
        return type(self), (self.name, self.extra, self.needed_for)


def import_extra(module: str, *, extra: str, needed_for: str) -> ModuleType:
    """Import ``module`` (a dependency of the optional extra ``extra``), or raise
    :class:`MissingExtraError` naming the pip line.

    Parameters
    ----------
    module : str
        Dotted module name, e.g. ``"rosbags.highlevel"``.
    extra : str
        The extra of fftnav that installs it.
    needed_for : str
        What needs it, a plural noun phrase (``"ROS bags"``), for the message.

    Returns
    -------
    module
        The imported module.

    Raises
    ------
    MissingExtraError
        The module cannot be imported (not installed, or blocked).
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingExtraError(module, extra=extra, needed_for=needed_for) from None

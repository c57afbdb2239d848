"""Modules that moved keep their old import path for one minor release (CHANGELOG.md).

``import fftnav.planning.controllers`` (the path of the docs until 0.1) gives the module that is
now :mod:`fftnav.navigation.controllers`, the very same object, with a ``DeprecationWarning``
naming the new path; the old names go in 0.3. A meta path finder, installed when ``fftnav`` is
imported, answers for the old names only (:data:`MOVED`), so nothing else is affected.

>>> import sys, warnings
>>> _ = sys.modules.pop("fftnav.planning.controllers", None)  # as if never imported
>>> with warnings.catch_warnings(record=True) as caught:
...     warnings.simplefilter("always")
...     from fftnav.planning.controllers import Controller
>>> import fftnav.navigation.controllers
>>> Controller is fftnav.navigation.controllers.Controller
True
>>> str(caught[0].message).split(";")[0]
'fftnav.planning.controllers moved to fftnav.navigation.controllers in fftnav 0.2'
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import warnings
from types import ModuleType

__all__ = ["MOVED", "REMOVED_IN", "install"]

#: The release that removes the old paths.
REMOVED_IN = "0.3"
#: Old module path -> new module path (moved in 0.2).
MOVED: dict[str, str] = {
    **{f"fftnav.planning.{m}": f"fftnav.navigation.{m}"
       for m in ("baselines", "bug", "controllers", "ownmap", "policies", "resolve")},
    **{f"fftnav.planning.{m}": f"fftnav.optimal.{m}"
       for m in ("astar", "geodesic", "gridgraph", "gridsearch", "reference")},
    **{f"fftnav.episode.{m}": f"fftnav.navigation.{m}" for m in ("bugcontrol", "collab",
                                                                 "decider")},
    **{f"fftnav.{m}": f"fftnav.observe.{m}"
       for m in ("codec", "compress", "filters", "fusion", "geometry", "pipeline", "safe",
                 "scan", "scanio", "spherical")},
    "fftnav.comms": "fftnav.episode.comms",
    "fftnav.flight3d": "fftnav.episode.flight3d",
    "fftnav.grid": "fftnav.world.grid",
    "fftnav.scene": "fftnav.world.scenes",
}
#: Old packages that no longer exist: made empty, so that their old submodules import.
_PACKAGES = {"fftnav.planning"}


class _MovedFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds the old names of :data:`MOVED`; loads each as its new module, with a warning."""

    def find_spec(self, name: str, path: object = None,
                  target: object = None) -> importlib.machinery.ModuleSpec | None:
        if name in MOVED or name in _PACKAGES:
            return importlib.util.spec_from_loader(name, self, is_package=name in _PACKAGES)
        return None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType | None:
        if spec.name in _PACKAGES:
            return None  # an empty package
        new = MOVED[spec.name]
        warnings.warn(f"{spec.name} moved to {new} in fftnav 0.2; import it from there (the old "
                      f"path goes in fftnav {REMOVED_IN})", DeprecationWarning, stacklevel=2)
        return importlib.import_module(new)

    def exec_module(self, module: ModuleType) -> None:
        if module.__name__ in _PACKAGES:
            module.__doc__ = (f"Moved: its modules are now in fftnav.navigation and "
                              f"fftnav.optimal (gone in fftnav {REMOVED_IN}).")


def install() -> None:
    """Put the finder on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _MovedFinder) for f in sys.meta_path):
        sys.meta_path.append(_MovedFinder())

"""One name for every way to drive the robots: a decision policy or a controller, built in or not.

:func:`resolve` turns what a config or the command line says (``policies = [...]`` of an
experiment, ``fftnav episode --policy``) into a :class:`Resolved`:

1. a registered name: a decision policy of :data:`~fftnav.navigation.policies.POLICIES`
   (``fusion``, ``bug-left``, ...; run by the Bug planner) or a controller of
   :data:`~fftnav.navigation.controllers.CONTROLLERS` (``vfh``, ``ftg``, ``fft-go``);
2. ``module:attr`` or ``path/to/file.py:attr`` (:func:`fftnav.plugins.load_reference`);
3. the name of an entry point in the group ``fftnav.policies`` of an installed package;
4. ``learned:PATH.npz``: a trained network run by
   :class:`~fftnav.navigation.learned.LearnedController` (taken before ``module:attr``, whose
   form it also has), named ``learned-<stem of the file>``; its ``file`` is the ``.npz``, whose
   SHA-256 ``fftnav run`` records as it does a plugin file's;
5. ``learned-decider:PATH.npz``: a trained network picking the Bug planner's side
   (:func:`~fftnav.navigation.learned_decider.learned_decider_policy`), likewise.

The object found must be a :class:`~fftnav.navigation.controllers.Controller` subclass (a
controller), a :class:`~fftnav.navigation.policies.Policy` or a plain function
``(DecisionContext) -> +1 | -1`` (a decision policy). Its rows carry its ``name`` attribute if it
has one, else the attribute's name (the entry point's name for an entry point). Anything else
raises ``ValueError`` with one line, before any episode starts.

Every episode makes its controller the same way, from the episode's
:class:`~fftnav.navigation.controllers.ControllerSetup` alone: :meth:`Resolved.make` gives a
decision policy to the Bug planner (:class:`~fftnav.navigation.bugcontrol.BugController`) and
makes a controller class; a plugin's policy or controller is guarded, so that what it raises is
a one-line :class:`~fftnav.plugins.PluginError` naming it, the call and its file and line.

>>> resolve("fusion").policy.name, resolve("vfh").controller.name
('fusion', 'vfh')
>>> import numpy as np
>>> from fftnav.config import SwarmConfig
>>> setup = ControllerSetup(2, SwarmConfig(), np.random.default_rng(0), area_m=(20.0, 20.0))
>>> type(resolve("bug-left").make(setup)).__name__, resolve("vfh").make(setup).setup is setup
('BugController', True)
>>> try:
...     resolve("fusoin")
... except ValueError as exc:
...     print(str(exc).split("; ")[-1])
did you mean 'fusion'?
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import re
from dataclasses import dataclass
from pathlib import Path

from fftnav.navigation import baselines  # noqa: F401  (registers vfh, ftg, fft-go)
from fftnav.navigation.bugcontrol import BugController
from fftnav.navigation.controllers import (
    CONTROLLERS,
    ENTRY_POINT_GROUP,
    Controller,
    ControllerSetup,
    ControllerSpec,
)
from fftnav.navigation.learned import LEARNED_PREFIX, learned_controller
from fftnav.navigation.learned_decider import PREFIX as DECIDER_PREFIX
from fftnav.navigation.learned_decider import learned_decider_policy
from fftnav.navigation.policies import POLICIES, Policy
from fftnav.plugins import (
    PluginError,
    PluginProxy,
    entry_points,
    is_reference,
    load_reference,
    plugin_call,
    reference_file,
    source_file,
)
from fftnav.registry import Registry, first_line

__all__ = ["ENTRY_POINT_GROUP", "Resolved", "registered_names", "resolve"]

_NAME = re.compile(r"^[A-Za-z0-9_.+-]+$")
#: Every name :func:`resolve` accepts, for its unknown-name error: the registered policies and
#: controllers (passed as ``also``) and the installed entry points of the group.
_ACCEPTED = Registry("policy or controller", parameter="policy",
                     entry_point_group=ENTRY_POINT_GROUP)


@dataclass(frozen=True)
class Resolved:
    """A policy or controller found by :func:`resolve`.

    Attributes
    ----------
    name : str
        The name its rows carry (``policy`` column, task file names).
    reference : str
        What was asked for.
    policy : Policy or None
        The decision policy (run by the Bug planner), or None for a controller.
    controller : type[Controller] or None
        The controller class, or None for a decision policy.
    file : Path or None
        The plugin's Python file for a ``file.py:attr`` reference.
    """

    name: str
    reference: str
    policy: Policy | None = None
    controller: type[Controller] | None = None
    file: Path | None = None

    @property
    def plugin(self) -> bool:
        """Whether it is a plugin's (not one of :func:`registered_names`)."""
        return self.reference not in registered_names()

    def make(self, setup: ControllerSetup) -> Controller:
        """The controller of one episode, made from ``setup`` alone: the Bug planner deciding
        with the decision policy, or the controller class; a plugin's is guarded (what it
        raises, in ``__init__``, ``act``, ``decide`` or any other call, is a one-line
        :class:`~fftnav.plugins.PluginError` naming it, the call and its file and line)."""
        if self.policy is not None:
            return BugController(setup, self._guarded_policy() if self.plugin else self.policy)
        assert self.controller is not None  # resolve() finds one or the other
        if self.plugin:
            return self._guarded_controller(setup)
        return self.controller(setup)

    def _guarded_policy(self) -> Policy:
        """The plugin's decision policy whose errors are one-line PluginErrors naming it."""
        assert self.policy is not None
        decide = self.policy.decide
        name = getattr(decide, "__name__", "decide")
        return dataclasses.replace(self.policy, decide=functools.partial(
            plugin_call, self.reference, name, source_file(decide), decide))

    def _guarded_controller(self, setup: ControllerSetup) -> Controller:
        """The plugin's controller, made and then called through
        :class:`~fftnav.plugins.PluginProxy`."""
        cls = self.controller
        assert cls is not None
        source = source_file(cls)
        controller = plugin_call(self.reference, f"{cls.__name__}.__init__", source, cls, setup,
                                 defined=cls.__init__)
        calls = ({} if cls.step is not Controller.step  # the base's step calls act per robot
                 else {"step": (f"{cls.__name__}.act", controller.act)})
        return PluginProxy(controller, self.reference, source, calls)  # type: ignore[return-value]


def registered_names() -> tuple[str, ...]:
    """The built-in decision policies, then the built-in controllers, in registration order."""
    return (*POLICIES, *(n for n in CONTROLLERS if n not in POLICIES))


def _wrap(obj: object, reference: str, default_name: str, file: Path | None) -> Resolved:
    own = getattr(obj, "name", "")
    name = own if isinstance(own, str) and own else default_name
    if not _NAME.match(name):
        raise PluginError(f"{reference!r}: its name must be letters, digits and '_.+-', got "
                          f"name={name!r}; set a name attribute")
    if isinstance(obj, ControllerSpec):
        obj = obj.factory
    if isinstance(obj, type) and issubclass(obj, Controller):
        if obj is Controller:
            raise PluginError(f"{reference!r} is the Controller base class; subclass it")
        return Resolved(name, reference, controller=obj, file=file)
    if isinstance(obj, Policy):
        return Resolved(name, reference, policy=obj, file=file)
    if inspect.isfunction(obj) or inspect.isbuiltin(obj):
        return Resolved(name, reference, policy=Policy(name, obj, None, first_line(obj.__doc__)),
                        file=file)
    raise PluginError(f"{reference!r} must be a Controller subclass, a Policy or a decision "
                      f"function, got {type(obj).__name__}")


def resolve(reference: str) -> Resolved:
    """The decision policy or controller that ``reference`` names.

    Parameters
    ----------
    reference : str
        A registered name, ``module:attr``, ``path/to/file.py:attr``, an entry-point name or
        ``learned:PATH.npz``.

    Returns
    -------
    Resolved

    Raises
    ------
    fftnav.plugins.PluginError
        (a ``ValueError``) import error, or an object of the wrong kind; one line.
    fftnav.registry.UnknownNameError
        (a ``ValueError``) an unknown name: one line listing the registered names and the
        installed entry points, with the closest as suggestions ("did you mean 'fusion'?").
    """
    if not isinstance(reference, str) or not reference:
        raise PluginError(f"a policy or controller must be a non-empty string, got {reference!r}")
    # a network's file is read every time (it may have been retrained under the same name)
    if reference.startswith(DECIDER_PREFIX):
        path = reference[len(DECIDER_PREFIX):]
        policy = learned_decider_policy(path)
        return Resolved(policy.name, reference, policy=policy, file=Path(path))
    if reference.startswith(LEARNED_PREFIX):
        name, cls, path = learned_controller(reference)
        return Resolved(name, reference, controller=cls, file=path)
    return _resolve_named(reference)


@functools.lru_cache(maxsize=64)
def _resolve_named(reference: str) -> Resolved:
    """:func:`resolve` of everything but a network's file, cached."""
    if reference in POLICIES:
        return Resolved(reference, reference, policy=POLICIES[reference])
    if reference in CONTROLLERS:
        return Resolved(reference, reference, controller=CONTROLLERS[reference].factory)
    if is_reference(reference):
        obj = load_reference(reference)
        file = reference_file(reference)
        found = _wrap(obj, reference, reference.rpartition(":")[2].rsplit(".", 1)[-1], file)
    elif reference in entry_points(ENTRY_POINT_GROUP):
        obj = load_reference(reference, group=ENTRY_POINT_GROUP)
        found = _wrap(obj, reference, reference, None)
    else:
        raise _ACCEPTED.unknown(reference, also=registered_names(),
                                forms="module:attr or path/to/file.py:attr")
    builtin = POLICIES.get(found.name) or CONTROLLERS.get(found.name)
    if builtin is not None:
        same = (found.policy is builtin) or (isinstance(builtin, ControllerSpec)
                                            and found.controller is builtin.factory)
        if not same:
            raise PluginError(f"{reference!r} is named {found.name!r}, the name of a built-in "
                              "policy or controller; give it another name attribute")
    return found

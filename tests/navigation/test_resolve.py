"""One resolver for decision policies and controllers: names, module:attr, files, entry points."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from fftnav.config import SwarmConfig
from fftnav.navigation.baselines import VFHController
from fftnav.navigation.bugcontrol import BugController
from fftnav.navigation.controllers import CONTROLLERS, Controller, ControllerSetup
from fftnav.navigation.policies import LEFT, POLICIES, Policy
from fftnav.navigation.resolve import ENTRY_POINT_GROUP, registered_names, resolve
from fftnav.plugins import PluginError, PluginProxy

PLUGIN = textwrap.dedent("""\
    from fftnav.navigation.controllers import Controller
    from fftnav.navigation.policies import LEFT, Policy

    class Spin(Controller):
        uses_pipeline = False
        def act(self, obs):
            return 0.0, 1.0

    class Named(Spin):
        name = "my-spin"

    def always_left(ctx):
        return LEFT

    FANCY = Policy("fancy-left", always_left, "observation", "left, and talk")
    NUMBER = 3
    class Vfh(Spin):
        name = "vfh"
    class BadName(Spin):
        name = "has space"
    """)


@pytest.fixture(scope="module")
def plugin(tmp_path_factory):
    path = tmp_path_factory.mktemp("plugin") / "my_controllers.py"
    path.write_text(PLUGIN)
    return path


def test_registered_names_are_policies_then_controllers():
    assert registered_names() == (*POLICIES, *CONTROLLERS)
    assert {"vfh", "ftg", "fft-go"} <= set(CONTROLLERS)
    assert resolve("bug-left").policy is POLICIES["bug-left"]
    assert resolve("ftg").controller is CONTROLLERS["ftg"].factory
    assert resolve("vfh").controller is VFHController and resolve("vfh").file is None


def test_module_reference_to_a_registered_class_keeps_its_name():
    found = resolve("fftnav.navigation.baselines:VFHController")
    assert found.name == "vfh" and found.controller is VFHController


def test_file_references_name_controllers_and_policies(plugin):
    spin = resolve(f"{plugin}:Spin")
    assert spin.name == "Spin" and issubclass(spin.controller, Controller)
    assert spin.policy is None and spin.file == plugin.resolve()
    assert resolve(f"{plugin}:Named").name == "my-spin"
    left = resolve(f"{plugin}:always_left")  # a plain function is a decision policy
    assert left.name == "always_left" and left.policy.decide(None) == LEFT
    assert not left.policy.uses_messages
    fancy = resolve(f"{plugin}:FANCY")
    assert isinstance(fancy.policy, Policy) and fancy.name == "fancy-left"
    assert fancy.policy.uses_messages


@pytest.mark.parametrize(("attr", "match"), [
    ("NUMBER", r"must be a Controller subclass, a Policy or a decision function, got int"),
    ("Vfh", r"is named 'vfh', the name of a built-in policy or controller"),
    ("BadName", r"its name must be letters, digits and '_\.\+-', got name='has space'"),
    ("Missing", r"has no attribute 'Missing'"),
])
def test_wrong_objects_are_refused_in_one_line(plugin, attr, match):
    with pytest.raises(ValueError, match=match) as info:
        resolve(f"{plugin}:{attr}")
    assert "\n" not in str(info.value)


def test_unknown_name_lists_the_registered_ones():
    with pytest.raises(ValueError, match=r"^policy must be a registered policy or controller "
                                         r"\('bug-left', .*'vfh', 'ftg', 'fft-go'\) or "
                                         r"module:attr or path/to/file.py:attr, got "
                                         r"policy='teleport'$"):
        resolve("teleport")
    with pytest.raises(ValueError, match="Controller base class"):
        resolve("fftnav.navigation.controllers:Controller")


@pytest.mark.parametrize(("name", "suggestion"), [
    ("fusoin", "'fusion'"), ("bug-lft", "'bug-left'"), ("vhf", "'vfh'"),
])
def test_a_misspelled_name_gets_a_suggestion_in_one_line(name, suggestion):
    with pytest.raises(ValueError, match=rf"got policy='{name}'; did you mean {suggestion}") \
            as info:
        resolve(name)
    assert "\n" not in str(info.value)


def test_the_unknown_name_error_lists_and_suggests_installed_entry_points(monkeypatch):
    import importlib.metadata

    class Point:
        def __init__(self, name):
            self.name = name

    def entry_points(group=None):
        return [Point("swarm-dance")] if group == ENTRY_POINT_GROUP else []

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    with pytest.raises(ValueError, match=r"an installed entry point of group 'fftnav.policies' "
                                         r"\('swarm-dance'\).*got policy='swarm-danse'; did you "
                                         r"mean 'swarm-dance'\?$"):
        resolve("swarm-danse")


def test_an_installed_package_registers_a_controller_by_entry_point(tmp_path, monkeypatch):
    (tmp_path / "epctl_pkg.py").write_text(PLUGIN)
    info = tmp_path / "epctl-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: epctl\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[fftnav.policies]\nspinner = epctl_pkg:Spin\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    found = resolve("spinner")
    assert found.name == "spinner" and found.controller.__name__ == "Spin"


def test_every_policy_and_controller_is_made_from_the_setup_alone(plugin):
    """A decision policy goes to the Bug controller, a controller class is made; a plugin's
    are guarded: what they raise names them."""
    setup = ControllerSetup(2, SwarmConfig(), np.random.default_rng(0), area_m=(20.0, 20.0))
    bug = resolve("bug-left").make(setup)
    assert type(bug) is BugController and bug.setup is setup
    assert bug.policy is POLICIES["bug-left"]
    vfh = resolve("vfh").make(setup)
    assert type(vfh) is VFHController and vfh.setup is setup
    spin = resolve(f"{plugin}:Spin").make(setup)
    assert isinstance(spin, PluginProxy) and spin.setup is setup and spin.act(None) == (0.0, 1.0)
    left = resolve(f"{plugin}:always_left").make(setup)
    assert type(left) is BugController and left.setup is setup
    assert left.policy.name == "always_left" and left.policy.decide(None) == LEFT
    with pytest.raises(PluginError, match=r"^plugin '.*:always_left': always_left raised "
                                          r"TypeError: .*\(at .*my_controllers\.py:\d+\)$"):
        left.policy.decide(None, "one too many")

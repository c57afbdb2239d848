"""fftnav.registry: the one registry behind policies, controllers, measures, world kinds, shapes."""

from __future__ import annotations

import importlib.metadata
from types import SimpleNamespace

import pytest

from fftnav.metrics import MEASURES
from fftnav.registry import Registry, UnknownNameError, first_line
from fftnav.world.kinds import WORLD_KINDS
from fftnav.world.obstacles import SHAPES


def test_add_keeps_registration_order_and_refuses_a_name_twice():
    reg: Registry[int] = Registry("colour")
    assert reg.add("red", 1) == 1 and reg.add("blue", 2) == 2
    assert list(reg) == ["red", "blue"] and reg.lookup("blue") == 2
    with pytest.raises(ValueError, match=r"^colour 'red' is already registered$"):
        reg.add("red", 3)
    assert reg["red"] == 1
    for bad in ("", None, 3):
        with pytest.raises(ValueError, match=r"a colour name must be a non-empty string"):
            reg.add(bad, 0)  # type: ignore[arg-type]


def test_unknown_name_lists_the_names_and_suggests_the_closest():
    reg: Registry[int] = Registry("policy", parameter="policy")
    for name in ("fusion", "own-only", "bug-left"):
        reg.add(name, 0)
    with pytest.raises(UnknownNameError) as info:
        reg.lookup("fusoin")
    text = str(info.value)
    assert text == ("policy must be a registered policy ('fusion', 'own-only', 'bug-left'), "
                    "got policy='fusoin'; did you mean 'fusion'?")
    assert "\n" not in text and isinstance(info.value, ValueError)
    # nothing close: no suggestion; not a string: no suggestion, no crash
    assert "did you mean" not in str(reg.unknown("zzzzzz"))
    assert "got policy=[1]" in str(reg.unknown([1]))
    with pytest.raises(UnknownNameError):
        reg.lookup([1])  # unhashable
    # names accepted in the same place, and other forms, are listed and suggested too
    text = str(reg.unknown("vhf", also=("vfh",), forms="module:attr"))
    assert "'vfh')" in text and "or module:attr, got" in text and "did you mean 'vfh'" in text


def test_installed_entry_points_are_listed_and_suggested(monkeypatch):
    points = [SimpleNamespace(name="my-planner"), SimpleNamespace(name="fusion")]

    def fake(*, group):
        return points if group == "fftnav.policies" else []

    monkeypatch.setattr(importlib.metadata, "entry_points", fake)
    reg: Registry[int] = Registry("policy", parameter="policy",
                                  entry_point_group="fftnav.policies")
    reg.add("fusion", 0)
    assert reg.entry_point_names() == ("my-planner",)  # a registered name is not listed twice
    text = str(reg.unknown("my-planer"))
    assert "an installed entry point of group 'fftnav.policies' ('my-planner')" in text
    assert text.endswith("did you mean 'my-planner'?")
    # a name accepted beside the registry (another registry's) is not listed again as a point
    assert str(reg.unknown("x", also=("my-planner",))).count("my-planner") == 1
    assert Registry("shape").entry_point_names() == ()


def test_copy_is_a_registry_of_the_same_kind():
    copy = MEASURES.copy()
    assert isinstance(copy, Registry) and copy == MEASURES and copy is not MEASURES
    copy.add("extra", MEASURES["spl"])
    assert "extra" not in MEASURES
    with pytest.raises(ValueError, match="names must be a registered measure"):
        copy.lookup("nope")


@pytest.mark.parametrize(("registry", "kind"), [(MEASURES, "measure"), (WORLD_KINDS, "world kind"),
                                                (SHAPES, "shape")])
def test_the_package_registries_are_registries(registry, kind):
    assert isinstance(registry, Registry) and registry.kind == kind and len(registry) >= 2


def test_first_line():
    assert first_line(None) == "" and first_line("") == ""
    assert first_line("\n\n   One.\n   Two.") == "One."

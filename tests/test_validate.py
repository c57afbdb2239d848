"""fftnav.validate: the check_* helpers and the checked dataclass fields (Checked)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest

from fftnav.validate import (
    Checked,
    check_multiple,
    checked_field,
    choice_field,
    integer_field,
    number_field,
)


def _even(name: str, value: object) -> int:
    if not (isinstance(value, int) and value % 2 == 0):
        raise ValueError(f"{name} must be an even integer, got {name}={value!r}")
    return value


@dataclass(frozen=True)
class Probe(Checked):
    beams: int = integer_field(8, low=2)
    range_m: float = number_field(3.0, low=0, low_open=True)
    height_m: float | None = number_field(None, optional=True, low=0)
    mode: str = choice_field("fast", ("fast", "exact"))
    pairs: int = checked_field(_even, int, 2)
    label: str = "free"  # no check: taken as given
    notes: list = field(default_factory=list)

    def _check_together(self) -> None:
        if self.pairs > self.beams:
            raise ValueError(f"pairs must be <= beams={self.beams}, got pairs={self.pairs}")


@dataclass
class Mutable(Checked):
    gain: float = number_field(1.0)


def test_fields_are_checked_and_converted_when_made():
    probe = Probe(range_m=np.float32(2.5), height_m=1, beams=np.int64(16))
    assert probe.range_m == 2.5 and type(probe.range_m) is float
    assert probe.height_m == 1.0 and type(probe.height_m) is float
    assert probe.beams == 16 and type(probe.beams) is int
    assert Probe().height_m is None and Probe(label=3).label == 3
    assert Mutable(gain=2).gain == 2.0  # a non-frozen dataclass too


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"beams": 1}, r"^beams must be an integer >= 2, got beams=1$"),
    ({"beams": 4.0}, r"^beams must be an integer >= 2, got beams=4\.0$"),
    ({"range_m": math.inf}, r"^range_m must be a finite number > 0, got range_m=inf$"),
    ({"range_m": True}, r"^range_m must be a finite number > 0, got range_m=True$"),
    ({"height_m": -1}, r"^height_m must be a finite number >= 0, got height_m=-1$"),
    ({"mode": "slow"}, r"^mode must be one of \['fast', 'exact'\], got mode='slow'$"),
    ({"pairs": 3}, r"^pairs must be an even integer, got pairs=3$"),
    ({"pairs": 10}, r"^pairs must be <= beams=8, got pairs=10$"),
])
def test_a_bad_field_or_rule_is_refused_naming_it(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Probe(**kwargs)


def test_checked_names_keys_with_the_prefix_and_refuses_unknown_keys():
    assert Probe.checked({"range_m": 4, "label": "x"}) == {"range_m": 4.0, "label": "x"}
    with pytest.raises(ValueError, match=r"^lidar\.beams must be an integer >= 2, "
                                         r"got lidar\.beams=0$"):
        Probe.checked({"beams": 0}, prefix="lidar.")
    with pytest.raises(ValueError, match=r"^unknown key lidar\.colour; expected one of "
                                         r"\['beams', 'range_m', "):
        Probe.checked({"colour": 1}, prefix="lidar.")
    assert Probe.keys()[:3] == ("beams", "range_m", "height_m")
    assert (Probe.value_type("beams"), Probe.value_type("range_m"), Probe.value_type("mode"),
            Probe.value_type("label")) == (int, float, str, None)


def test_from_table_names_the_key_or_the_table():
    assert Probe.from_table("lidar", {"beams": 4}, label="y") == Probe(beams=4, label="y")
    with pytest.raises(ValueError, match=r"^lidar\.range_m must be a finite number > 0, "
                                         r"got lidar\.range_m=0$"):
        Probe.from_table("lidar", {"range_m": 0})
    with pytest.raises(ValueError, match=r"^\[lidar\] pairs must be <= beams=2, got pairs=4$"):
        Probe.from_table("lidar", {"beams": 2, "pairs": 4})


@pytest.mark.parametrize(("value", "base", "ratio"), [
    (240.0, 10.0, 24), (0.3, 0.1, 3), (10.0, 10.0, 1)])
def test_check_multiple_accepts_integer_ratios(value, base, ratio):
    assert check_multiple("physics_hz", value, "control_hz", base) == ratio


@pytest.mark.parametrize(("value", "base"), [(25.0, 10.0), (5.0, 10.0), (0.12, 0.05)])
def test_check_multiple_refuses_the_rest(value, base):
    with pytest.raises(ValueError, match=rf"^a must be an integer multiple of b={base!r}, "
                                         rf"got a={value!r}$"):
        check_multiple("a", value, "b", base)

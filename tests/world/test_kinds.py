"""World kinds are registered generators; presets ship with the package; a new kind is one module."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import tomllib

from fftnav.cli import build_parser
from fftnav.world import WORLD_KINDS, Circle, generate_world, get_world_kind, load_preset
from fftnav.world.kinds import register_world_kind, scatter_obstacles, world_kinds

ROOT = Path(__file__).resolve().parents[2]


def test_builtin_kinds_and_their_presets_are_the_files_of_worlds():
    assert world_kinds() == ("forest", "rocky", "walls", "traps")
    for name in world_kinds():
        shipped = resources.files("fftnav.world.presets") / f"{name}.toml"
        assert shipped.read_bytes() == (ROOT / "worlds" / f"{name}.toml").read_bytes()
        assert load_preset(name) == tomllib.loads(shipped.read_text())
        assert get_world_kind(name).description


def test_unknown_kind_and_bad_preset_path_are_refused():
    with pytest.raises(ValueError, match=r"env must be a registered world kind \('forest', "
                                         r"'rocky', 'walls', 'traps'\), got env='x'$"):
        get_world_kind("x")
    with pytest.raises(ValueError, match=r"got env='wals'; did you mean 'walls'\?"):
        get_world_kind("wals")
    with pytest.raises(ValueError, match=r"env_or_path must be one of .* or a .toml path"):
        load_preset("x.json")
    with pytest.raises(ValueError, match="world kind 'forest' is already registered"):
        register_world_kind("forest")(lambda params, rng: [])


@pytest.mark.parametrize(("key", "value", "match"), [
    ("trunk_radius_m", [0.3, 0.1], r"trunk_radius_m\[1\] must be a finite number in \[0.3, "),
    ("trunk_radius_m", [-0.1, 0.3], r"trunk_radius_m\[0\] must be a finite number in \(0, "),
    # both ends above what fits: the first end is named, with the bounds it must lie in
    ("trunk_radius_m", [50, 100], r"trunk_radius_m\[0\] must be a finite number in "
                                  r"\(0, 8\], got trunk_radius_m\[0\]=50$"),
])
def test_kind_parameters_are_checked_by_the_kind(key, value, match):
    with pytest.raises(ValueError, match=match):
        generate_world("forest", 0, **{key: value})


def test_rocky_parameters_are_checked_by_the_kind():
    with pytest.raises(ValueError, match=r"rock_sides\[0\] must be an integer >= 3, got"):
        generate_world("rocky", 0, rock_sides=[2, 5])
    with pytest.raises(ValueError, match=r"wall_fraction must be a finite number in \[0, 1\]"):
        generate_world("rocky", 0, wall_fraction=1.5)
    with pytest.raises(ValueError, match=r"rock_aspect\[0\] must be a finite number in "
                                         r"\(0, 1\], got rock_aspect\[0\]=5$"):
        generate_world("rocky", 0, rock_aspect=[5, 10])
    with pytest.raises(ValueError, match=r"rock_size_m\[0\] must be a finite number in "
                                         r"\(0, 16\], got rock_size_m\[0\]=50$"):
        generate_world("rocky", 0, rock_size_m=[50, 100])


def test_a_kind_registered_from_outside_generates_worlds_and_appears_in_the_cli(monkeypatch):
    monkeypatch.setattr("fftnav.world.kinds.WORLD_KINDS", WORLD_KINDS.copy())
    defaults = {**load_preset("forest"), "env": "pillars", "density_per_m2": 0.05}

    @register_world_kind("pillars", defaults=defaults)
    def pillars(params, rng):
        """Equal thick pillars."""
        return scatter_obstacles(params, rng, lambda p, r: (Circle((0.0, 0.0), 0.5, 1.0), 0.5))

    world = generate_world("pillars", 1)
    assert world.env == "pillars" and len(world.obstacles) == 20
    assert {o.radius for o in world.obstacles} == {0.5}
    assert np.array_equal(world.starts, generate_world("forest", 1).starts)
    parser = build_parser()
    args = parser.parse_args(["world", "generate", "--env", "pillars", "--seed", "0",
                              "--out", "w.json"])
    assert args.env == "pillars"

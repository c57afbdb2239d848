"""World kinds: registered, seeded obstacle generators, each with a preset of parameters.

A world kind is one module in this package: a function ``draw(params, rng)`` that returns the
obstacles of one draw (or None to ask for a redraw), registered with
:func:`register_world_kind`, and its preset ``worlds/<name>.toml`` (shipped in the wheel as
``fftnav.world.presets``). Every module here is imported when the package is, so that the
registry (:data:`WORLD_KINDS`) and everything built on it (the CLI's ``--env`` choices, config
validation) know the kind without further edits. :func:`fftnav.world.generate.generate_world`
adds what every kind shares: the robots' starts and goals, the reachability check and redraws.

Helpers for kinds: :func:`scatter_obstacles` (rejection sampling of obstacles between the start
and goal strips) and :data:`DECIMALS` (generated coordinates are rounded to 0.1 mm, so that a
world is identical on every machine and survives a JSON round trip bit for bit).
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from fftnav.errors import FftnavError
from fftnav.files import check_input
from fftnav.registry import Registry, first_line
from fftnav.world.obstacles import Obstacle

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

__all__ = ["DECIMALS", "WORLD_KINDS", "WorldKind", "get_world_kind", "load_preset",
           "max_obstacle_radius", "register_world_kind", "scatter_obstacles", "world_kinds"]

#: Decimals of generated coordinates (0.1 mm).
DECIMALS = 4

Params = dict[str, Any]
Draw = Callable[[Params, np.random.Generator], "list[Obstacle] | None"]
Check = Callable[[Params], None]


@dataclass(frozen=True)
class WorldKind:
    """A registered world kind: its name, obstacle generator and parameter check."""

    name: str
    draw: Draw
    check: Check = field(default=lambda params: None)
    description: str = ""
    #: Parameters of a kind registered from outside fftnav; None: the shipped preset.
    defaults: Params | None = None

    def preset(self) -> Params:
        """The kind's preset parameters: ``worlds/<name>.toml`` (package data ``fftnav.world.
        presets``) for the built-in kinds, else the ``defaults`` it was registered with."""
        if self.defaults is not None:
            return dict(self.defaults)
        resource = resources.files("fftnav.world.presets") / f"{self.name}.toml"
        return tomllib.loads(resource.read_text(encoding="utf-8"))


#: Registered world kinds by name, in registration order.
WORLD_KINDS: Registry[WorldKind] = Registry("world kind", parameter="env")


def register_world_kind(name: str, *, check: Check | None = None,
                        defaults: Params | None = None) -> Callable[[Draw], Draw]:
    """Decorator registering ``draw(params, rng) -> list[Obstacle] | None`` as world kind ``name``.

    ``check(params)`` validates the kind's own parameters (after the shared ones) and raises
    ValueError naming the key. ``defaults`` are the parameters of a kind defined outside
    fftnav (the built-in kinds read their preset ``worlds/<name>.toml``); they must hold the
    keys every kind shares (see ``worlds/forest.toml``).
    """

    def wrap(draw: Draw) -> Draw:
        WORLD_KINDS.add(name, WorldKind(name, draw, check or (lambda params: None),
                                        first_line(draw.__doc__), defaults))
        return draw

    return wrap


def world_kinds() -> tuple[str, ...]:
    """Names of the registered world kinds."""
    return tuple(WORLD_KINDS)


def get_world_kind(name: str) -> WorldKind:
    """The registered kind ``name``; ValueError listing the known kinds (and the closest)
    otherwise."""
    return WORLD_KINDS.lookup(name)


def load_preset(env_or_path: str | Path) -> Params:
    """Generation parameters of a registered kind (its preset) or from a TOML file path."""
    if str(env_or_path) in WORLD_KINDS:
        return get_world_kind(str(env_or_path)).preset()
    path = Path(env_or_path)
    if path.suffix != ".toml":
        raise FftnavError(f"env_or_path must be one of {list(WORLD_KINDS)} or a .toml path, "
                          f"got env_or_path={str(env_or_path)!r}")
    with check_input(path).open("rb") as fh:
        return tomllib.load(fh)


def max_obstacle_radius(params: Params) -> float:
    """Largest bounding radius (m) of an obstacle that fits between the start and goal strips
    and across the world's width (kinds refuse larger obstacles at validation)."""
    clear = params["strip_half_width_m"]
    band = params["goal_y_m"] - params["start_y_m"] - 2 * clear
    return min(float(params["size_m"][0]), band) / 2


Made = tuple["Obstacle | list[Obstacle]", float]


def scatter_obstacles(params: Params, rng: np.random.Generator,
                      make: Callable[[Params, np.random.Generator], Made], *,
                      count: int | None = None, avoid: Sequence[Obstacle] = (),
                      ) -> list[Obstacle] | None:
    """Place ``count`` (default ``round(density_per_m2 * w * h)``) obstacles by rejection sampling.

    ``make(params, rng)`` returns one obstacle centred at the origin (or a list of obstacles
    forming one compound, such as the three walls of a U) and its bounding radius (m); it is
    moved to a uniform random spot between the start and goal strips whose bounding circle keeps
    ``min_gap_m`` from those already placed and from every obstacle of ``avoid``. Returns None
    if an obstacle finds no spot in ``placement_tries`` tries (the world is then redrawn).
    """
    w, h = (float(v) for v in params["size_m"])
    clear = params["strip_half_width_m"]
    band = (params["start_y_m"] + clear, params["goal_y_m"] - clear)  # between the strips
    if count is None:
        count = round(params["density_per_m2"] * w * h)
    placed: list[Obstacle] = []
    centers = np.zeros((0, 2))
    radii = np.zeros(0)
    for _ in range(count):
        shape, rad = make(params, rng)
        for _attempt in range(params["placement_tries"]):
            xy = rng.uniform([rad, band[0] + rad], [w - rad, band[1] - rad])
            if (np.all(np.hypot(*(centers - xy).T) >= radii + rad + params["min_gap_m"])
                    and all(o.distance(xy)[0] >= rad + params["min_gap_m"] for o in avoid)):
                break
        else:
            return None
        parts = shape if isinstance(shape, list) else [shape]
        placed.extend(part.moved(xy, decimals=DECIMALS) for part in parts)
        centers = np.vstack([centers, xy])
        radii = np.append(radii, rad)
    return placed


for _module in pkgutil.iter_modules(__path__):  # register every kind defined in this package
    importlib.import_module(f"{__name__}.{_module.name}")

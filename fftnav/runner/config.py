"""Experiment configurations: a TOML file -> a validated :class:`ExperimentConfig`.

The file has an ``[experiment]`` table (what to run), an optional ``[sweep]`` table (axes of a
one-factor-at-a-time sweep: one run of the base config per value, each into its own folder),
an optional ``[world]`` table of overrides
for :func:`fftnav.world.model.generate_world` (with optional per-env sub-tables such as
``[world.forest]``), and the episode sections ``[robot]``, ``[sensor]``, ``[comms]``,
``[episode]`` of :class:`fftnav.config.SwarmConfig`. Every unknown key or invalid value raises
``ValueError`` naming the key, e.g. ``experiment.maps must be an integer >= 1, got
experiment.maps=0``.
See ``docs/experiments.md`` for the reference of every key.
"""

from __future__ import annotations

import copy
import dataclasses
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fftnav.config import SwarmConfig
from fftnav.errors import FftnavError
from fftnav.files import read_toml
from fftnav.limits import MAX_RAYS_PER_TICK, MAX_TASKS, check_limit
from fftnav.navigation.resolve import Resolved, resolve
from fftnav.validate import Checked, check_choice, checked_field, choice_field, integer_field
from fftnav.world import WORLD_KINDS, load_preset, load_world, world_kinds, world_parameters

__all__ = ["ExperimentConfig", "load_config", "parse_config"]

_EXPERIMENT_KEYS = ("name", "envs", "maps", "map_seed", "robots", "policies", "trajectory_maps",
                    "out")
#: ``[record] episodes``: which episodes keep their recording.
RECORD_CHOICES = ("none", "failures", "all")
_REQUIRED_KEYS = ("name", "envs", "maps", "map_seed", "robots", "policies")
_NAME = re.compile(r"^[A-Za-z0-9_.-]+$")


def _check_name(key: str, value: Any) -> str:
    if not (isinstance(value, str) and _NAME.match(value)):
        raise FftnavError(f"{key} must be a non-empty string of letters, digits, '_', '.', '-', "
                          f"got {key}={value!r}")
    return value


def _check_out(key: str, value: Any) -> str:
    if not (isinstance(value, str) and value):
        raise FftnavError(f"{key} must be a non-empty string, got {key}={value!r}")
    return value


@dataclass(frozen=True)
class ExperimentConfig(Checked):
    """A validated experiment: which episodes to run and with which parameters.

    Attributes
    ----------
    name : str
        Experiment name (letters, digits, ``_.-``).
    envs : tuple of str
        Environments, e.g. ``("forest", "rocky")``.
    maps : int
        Number of maps per environment; map ``i`` is generated with seed ``map_seed + i``.
    map_seed : int
        Seed of the first map (>= 0).
    robots : int
        Robots per episode (the paper uses 15).
    policies : tuple of str
        Decision policies and controllers, each run on every map (paired comparison): registered
        names, ``module:attr``, ``path/to/file.py:attr`` (relative paths are taken from the
        config file's folder and stored absolute) or entry points
        (:func:`fftnav.navigation.resolve.resolve`).
    out : str
        Default output folder (``--out`` overrides it).
    trajectory_maps : int
        How many maps per env keep their trajectories for the figures (first maps first),
        at most ``maps``.
    world : dict
        Overrides passed to ``generate_world`` for every env.
    world_by_env : dict
        Extra per-env overrides (``[world.<env>]``), applied after ``world``.
    world_files : dict
        ``[world_files]``: envs whose world is a file (a world JSON, e.g. imported from a ROS
        map with ``fftnav world import``) instead of a generator, env name -> absolute path
        (relative paths are taken from the config file's folder). Every map of such an env is
        that world; the maps differ by their episode seed (sensor noise, packet loss).
    swarm : SwarmConfig
        Robot, sensor, communication and episode parameters.
    record : str
        ``[record] episodes``: which episodes keep their recording in ``OUT/records/``
        (:mod:`fftnav.episode.recording`): ``"none"``, ``"failures"`` (those in which a robot
        did not arrive; the default) or ``"all"``. Recording changes no result.
    source : str
        The TOML text the config was parsed from (copied into the output folder).
    """

    name: str = checked_field(_check_name, str)
    envs: tuple[str, ...]
    maps: int = integer_field(low=1)
    map_seed: int = integer_field(low=0)
    robots: int = integer_field(low=1)
    policies: tuple[str, ...]
    out: str = checked_field(_check_out, str)
    trajectory_maps: int = integer_field(1, low=0)
    world: dict[str, Any] = field(default_factory=dict)
    world_by_env: dict[str, dict[str, Any]] = field(default_factory=dict)
    world_files: dict[str, str] = field(default_factory=dict)
    swarm: SwarmConfig = field(default_factory=SwarmConfig)
    record: str = choice_field("failures", RECORD_CHOICES)
    source: str = field(default="", repr=False, compare=False)
    #: ``[sweep]``: the cells of a one-factor-at-a-time sweep, ``(name, config)``, the first
    #: ``base`` (this config without the sweep); empty without ``[sweep]``.
    cells: tuple[tuple[str, ExperimentConfig], ...] = field(default=(), repr=False,
                                                            compare=False)

    def _check_together(self) -> None:
        if self.trajectory_maps > self.maps:
            raise FftnavError(f"trajectory_maps must be <= maps={self.maps}, "
                              f"got trajectory_maps={self.trajectory_maps}")

    def world_overrides(self, env: str) -> dict[str, Any]:
        """Overrides for ``generate_world(env, seed, **overrides)``.

        ``robot_radius_m`` (the radius the reachability check uses) defaults to ``robot.r0_m``;
        then ``[world]``, then ``[world.<env>]``.
        """
        return {"robot_radius_m": self.swarm.robot.r0_m, **self.world,
                **self.world_by_env.get(env, {})}

    @property
    def resolved(self) -> dict[str, Resolved]:
        """The policies and controllers by the name their rows carry, in config order."""
        return {found.name: found for found in map(resolve, self.policies)}

    @property
    def policy_names(self) -> tuple[str, ...]:
        """The names the rows of ``policies`` carry (``policy`` column), in config order."""
        return tuple(self.resolved)


def load_config(path: str | Path) -> ExperimentConfig:
    """Read and validate an experiment TOML file.

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Returns
    -------
    ExperimentConfig

    Raises
    ------
    ValueError
        Invalid TOML, unknown key or invalid value (the message names the key).
    OSError
        The file cannot be read.
    """
    data, text = read_toml(path)
    try:
        return parse_config(data, source=text, base=Path(path).parent)
    except ValueError as exc:
        raise FftnavError(f"{path}: {exc}") from None


def parse_config(data: dict[str, Any], *, source: str = "",
                 base: str | Path | None = None) -> ExperimentConfig:
    """Validate a parsed TOML document.

    Parameters
    ----------
    data : dict
        The document, as ``tomllib`` returns it.
    source : str
        Its text, kept for the copy written into the output folder.
    base : str or Path, optional
        Folder against which relative plugin file paths of ``experiment.policies`` are taken
        (the config file's folder; default: the current directory).

    Returns
    -------
    ExperimentConfig

    Raises
    ------
    ValueError
        Unknown section or key, missing or invalid value; the message names the key.
    """
    allowed = ("experiment", "world", "world_files", "sweep", "record", *SwarmConfig.SECTIONS)
    for name in data:
        if name not in allowed:
            raise FftnavError(f"unknown section [{name}]; expected one of {list(allowed)}")
    if "sweep" in data:
        common = {k: v for k, v in data.items() if k != "sweep"}
        config = parse_config(common, source=source, base=base)
        cells = tuple(_sweep_cells(common, {"": [None], **_table(data, "sweep")}, source,
                                   folder=base))
        return dataclasses.replace(config, cells=cells)
    exp = _table(data, "experiment")
    scalars = _experiment_scalars(exp)
    world_files = _world_files(_table(data, "world_files"), base)
    envs = _names("experiment.envs", exp["envs"], (*world_kinds(), *world_files))
    for env in world_files:
        if env not in envs:
            raise FftnavError(f"world_files.{env} is not one of experiment.envs={list(envs)}")
    policies = _policies(exp["policies"], base)
    check_limit("episodes (envs x maps x policies)", len(envs) * scalars["maps"] * len(policies),
                MAX_TASKS, hint="lower experiment.maps")
    swarm = SwarmConfig.from_sections({s: _table(data, s) for s in SwarmConfig.SECTIONS})
    check_limit("lidar rays per control tick (experiment.robots x sensor.beams)",
                scalars["robots"] * swarm.sensor.beams, MAX_RAYS_PER_TICK,
                hint="lower sensor.beams")
    try:
        swarm.episode.check_departures(scalars["robots"])
    except ValueError as exc:
        raise FftnavError(f"[episode] {exc}") from None
    common, by_env = _world_tables(_table(data, "world"), envs, world_files, scalars["robots"],
                                   swarm)
    record = _table(data, "record")
    _check_keys("record", record, ("episodes",))
    recorded = check_choice("record.episodes", record.get("episodes", "failures"),
                            RECORD_CHOICES)
    return ExperimentConfig.from_table(
        "experiment", scalars, envs=envs, policies=policies, world=common, world_by_env=by_env,
        world_files=world_files, swarm=swarm, source=source, record=recorded)


def _experiment_scalars(exp: dict[str, Any]) -> dict[str, Any]:
    """The ``[experiment]`` keys other than the lists ``envs`` and ``policies``, checked by
    :class:`ExperimentConfig`'s fields (``out`` defaults to ``results/<name>``); unknown and
    missing keys are refused."""
    _check_keys("experiment", exp, _EXPERIMENT_KEYS)
    for key in _REQUIRED_KEYS:
        if key not in exp:
            raise FftnavError(f"experiment.{key} is required")
    name = ExperimentConfig.checked({"name": exp["name"]}, prefix="experiment.")["name"]
    scalars = {"name": name, "out": f"results/{name}", "trajectory_maps": 1,
               **{k: v for k, v in exp.items() if k not in ("envs", "policies")}}
    return ExperimentConfig.checked(scalars, prefix="experiment.")


def _world_tables(world: dict[str, Any], envs: tuple[str, ...], world_files: dict[str, str],
                  robots: int, swarm: SwarmConfig) -> tuple[dict[str, Any], dict[str, Any]]:
    """``[world]`` split into the overrides of every env and the ``[world.<env>]`` tables, each
    checked against the env's preset (a world file env: its file loads with ``robots``)."""
    common = {k: v for k, v in world.items() if not isinstance(v, dict)}
    by_env = {k: v for k, v in world.items() if isinstance(v, dict)}
    for env, table in by_env.items():
        if env not in envs:
            raise FftnavError(f"world.{env} is not one of experiment.envs={list(envs)}")
        if env in world_files:
            raise FftnavError(f"world.{env}: a world file env (world_files.{env}) takes no "
                              "generator overrides")
        _check_world_keys(f"world.{env}", env, table)
    for env in envs:
        if env in world_files:
            _check_world_file(env, world_files[env], robots)
            continue
        _check_world_keys("world", env, common)
        overrides = {"robot_radius_m": swarm.robot.r0_m, **common, **by_env.get(env, {}),
                     "robots": robots}
        try:
            world_parameters(env, **overrides)
        except ValueError as exc:  # name the config section the bad value came from
            raise FftnavError(f"[world] for env {env!r}: {exc}") from None
    return common, by_env


def _world_files(table: dict[str, Any], base: str | Path | None) -> dict[str, str]:
    """``[world_files]``: env name -> world file, made absolute, names distinct from the
    registered world kinds."""
    out = {}
    for env, path in table.items():
        if not _NAME.match(env):
            raise FftnavError(f"world_files: an env name must be letters, digits, '_', '.', '-', "
                              f"got {env!r}")
        if env in world_kinds():
            raise FftnavError(f"world_files.{env}: {env!r} is a registered world kind; name the "
                              "world file's env otherwise")
        if not (isinstance(path, str) and path):
            raise FftnavError(f"world_files.{env} must be a world file path, got {path!r}")
        full = Path(path).expanduser()
        if not full.is_absolute():
            full = Path(base or ".") / full
        out[env] = str(full.resolve())
    return out


def _check_world_file(env: str, path: str, robots: int) -> None:
    """The world file of ``env`` loads and has ``robots`` robots (starts)."""
    try:
        world = load_world(path)
    except (ValueError, OSError) as exc:
        raise FftnavError(f"world_files.{env}: {exc}") from None
    if len(world.starts) != robots:
        raise FftnavError(f"world_files.{env}: {path} has {len(world.starts)} robots (starts), "
                          f"experiment.robots={robots}")


def _policies(value: Any, base: str | Path | None) -> tuple[str, ...]:
    """``experiment.policies``: each resolved now (a plugin that does not load is refused before
    any episode), relative plugin files made absolute, names distinct."""
    refs = _names("experiment.policies", value, None)
    out, names = [], {}
    for ref in refs:
        head, sep, attr = ref.rpartition(":")
        if sep and head.endswith(".py") and not Path(head).expanduser().is_absolute():
            ref = f"{(Path(base or '.') / head).resolve()}:{attr}"
        for prefix in ("learned-decider:", "learned:"):  # trained networks, files too
            path = ref[len(prefix):]
            if ref.startswith(prefix) and not Path(path).expanduser().is_absolute():
                ref = f"{prefix}{(Path(base or '.') / path).resolve()}"
                break
        try:
            found = resolve(ref)
        except ValueError as exc:
            raise FftnavError(f"experiment.policies: {exc}") from None
        if found.name in names:
            raise FftnavError(f"experiment.policies: {names[found.name]!r} and {ref!r} have the "
                              f"same name {found.name!r}")
        names[found.name] = ref
        out.append(ref)
    return tuple(out)


def _sweep_cells(base: dict[str, Any], sweep: dict[str, Any], source: str, *,
                 folder: str | Path | None = None) -> list[tuple[str, ExperimentConfig]]:
    """The sweep's cells: for each axis ``"section.key"`` (``[robot]``, ``[sensor]``,
    ``[comms]``, ``[episode]``, ``[planner]``), ``"world.key"`` or ``"world.<env>.key"`` and
    each of its values, the base config with that one value (``world.<env>.key``: and only that
    env); named ``key=value``, written to ``experiment.out/<name>``. Each cell is validated
    like a config of its own."""
    cells = []
    out = base["experiment"].get("out", f"results/{base['experiment'].get('name')}")
    for axis, values in sweep.items():
        if axis == "":  # the base cell
            data = copy.deepcopy(base)
            data["experiment"] = {**data["experiment"], "out": f"{out}/base"}
            cells.append(("base", parse_config(data, source=source, base=folder)))
            continue
        parts = axis.split(".")
        valid = ((len(parts) == 2 and parts[0] in (*SwarmConfig.SECTIONS, "world"))
                 or (len(parts) == 3 and parts[0] == "world"))
        if not valid:
            raise FftnavError(f"unknown key sweep.{axis}; expected 'section.key' of "
                              f"{[*SwarmConfig.SECTIONS, 'world']} or 'world.<env>.key'")
        if not isinstance(values, list) or not values:
            raise FftnavError(f"sweep.{axis} must be a non-empty list of values, got {values!r}")
        for value in values:
            data = copy.deepcopy(base)
            table = data.setdefault(parts[0], {})
            for part in parts[1:-1]:
                table = table.setdefault(part, {})
            table[parts[-1]] = value
            if len(parts) == 3:  # an axis of one env's world runs that env only
                data["experiment"] = {**data["experiment"], "envs": [parts[1]]}
            text = "-".join(f"{v:g}" for v in value) if isinstance(value, list) else (
                f"{value:g}" if isinstance(value, float) else str(value))
            name = f"{parts[-1]}={text}"
            data["experiment"] = {**data["experiment"], "out": f"{out}/{name}"}
            try:
                cells.append((name, parse_config(data, source=source, base=folder)))
            except ValueError as exc:
                raise FftnavError(f"sweep.{axis} = {value!r}: {exc}") from None
    return cells


def _table(data: dict[str, Any], name: str) -> dict[str, Any]:
    table = data.get(name, {})
    if not isinstance(table, dict):
        raise FftnavError(f"{name} must be a table [{name}], got {table!r}")
    return table


def _check_keys(section: str, table: dict[str, Any], keys: tuple[str, ...]) -> None:
    for key in table:
        if key not in keys:
            raise FftnavError(f"unknown key {section}.{key}; expected one of {list(keys)}")


def _check_world_keys(section: str, env: str, table: dict[str, Any]) -> None:
    """World overrides must be keys of the env's preset (``worlds/<env>.toml``)."""
    preset = load_preset(env)
    for key in table:
        if key in ("env", "robots"):
            raise FftnavError(f"{section}.{key} cannot be overridden; it is set by the experiment")
        if key not in preset:
            raise FftnavError(f"unknown key {section}.{key}; expected one of {sorted(preset)}")


def _names(key: str, value: Any, known: tuple[str, ...] | None) -> tuple[str, ...]:
    if (not isinstance(value, list) or not value
            or not all(isinstance(v, str) for v in value) or len(set(value)) != len(value)):
        raise FftnavError(f"{key} must be a non-empty list of distinct strings, got {value!r}")
    for v in value if known is not None else ():
        if v not in known:
            raise FftnavError(f"{key}: {WORLD_KINDS.unknown(v, also=known, forms='a world file')}")
    return tuple(value)

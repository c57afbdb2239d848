"""Benchmark suites: named, versioned protocols, and their reference rows for every built-in.

A suite (``paper-v2``, ``walls-v1``, ``traps-v1``, ``all-v1``) pins everything that changes a
score: the world kinds and their parameters, the maps and their episode seeds, the robots, and
every setting of the episode (time limit, sensor, comms, planner, localization). Its definition
is a TOML file in ``fftnav/suites/defs/`` (a ``[suite]`` table, then the ``[experiment]`` keys
``envs``, ``maps``, ``map_seed``, ``robots`` and any section of an experiment config); a suite
with ``includes`` pools the maps of others. Like Gymnasium's environment ids, a suite's version
changes whenever its behaviour does, so scores of one version are comparable across releases.

What it pins is written out in ``fftnav/suites/pins/<suite>.json`` (:meth:`Suite.pins`): the
definition with every default resolved, each world kind's parameters, each map's episode seed,
the SHA-256 of the maps' worlds and the episode CSV columns. :meth:`Suite.changes` compares a
suite's pins with what this fftnav resolves, so a default that a suite depends on cannot change
without a new version (tests/suites/test_suites.py; ``fftnav evaluate`` refuses such a suite).

``$FFTNAV_SUITES_HOME``, when set, is a folder laid out like ``fftnav/suites`` (``defs/``,
``pins/``, ``references/``) used instead of the package's: a lab's own suites, or tests'.

Every built-in method's per-robot rows on a suite ship in ``fftnav/suites/references/<suite>/``
(``<method>.csv``, the runner's episode columns; ``timing.csv``, their compute; ``SHA256SUMS``),
so ``fftnav evaluate`` runs only the method it ranks (:mod:`fftnav.suites.evaluate`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from importlib import resources
from pathlib import Path
from typing import Any

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

import pandas as pd

from fftnav.errors import FftnavError
from fftnav.registry import Registry
from fftnav.runner.config import ExperimentConfig, parse_config
from fftnav.runner.run import CSV_COLUMNS, TIMING_COLUMNS
from fftnav.runner.tasks import episode_seed, task_world
from fftnav.world import world_parameters

__all__ = ["HOME_VARIABLE", "SUITES", "ReferenceError", "Suite", "builtin_methods", "find_suite",
           "maps_of", "ordered_suites", "pins_path", "read_references", "reference_lines",
           "references_folder", "rerun_task", "resolve_suites", "rows_csv", "suite_from_toml",
           "write_references"]

#: Environment variable naming a folder laid out like the package's suites (``defs/``,
#: ``pins/``, ``references/``) to use instead of them: suites being made, before they ship.
HOME_VARIABLE = "FFTNAV_SUITES_HOME"
#: The folder of the suites' files: the package's, or ``$FFTNAV_SUITES_HOME``.
_DATA = (Path(os.environ[HOME_VARIABLE]) if os.environ.get(HOME_VARIABLE)
         else resources.files("fftnav.suites"))


class ReferenceError(FftnavError):
    """A suite's reference rows that cannot be trusted (missing, damaged or tampered with)."""


def builtin_methods() -> tuple[str, ...]:
    """Every built-in decision policy and controller, the methods a suite has references of."""
    from fftnav.navigation.resolve import registered_names

    return registered_names()


@dataclass(frozen=True)
class Suite:
    """A versioned benchmark protocol (module docstring).

    Attributes
    ----------
    family : str
        What is measured, e.g. ``"paper"``; the suite's name is ``<family>-v<version>``.
    version : int
        Bumped whenever anything that changes a score changes.
    description : str
        One line: worlds, maps, robots.
    measures : str
        One line: what the suite tells about a method.
    includes : tuple of str
        The suites whose maps this one pools (empty for a suite of its own maps).
    tables : dict
        The experiment config's tables (``[experiment]`` and its sections) of a suite of its
        own maps.
    """

    family: str
    version: int
    description: str
    measures: str
    includes: tuple[str, ...] = ()
    tables: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def name(self) -> str:
        """``<family>-v<version>``, e.g. ``paper-v2``."""
        return f"{self.family}-v{self.version}"

    @property
    def parts(self) -> tuple[Suite, ...]:
        """The suites of its own maps this suite consists of (itself, or those it includes)."""
        if not self.includes:
            return (self,)
        return tuple(p for name in self.includes for p in SUITES.lookup(name).parts)

    def experiment(self, methods: Sequence[str], *, base: str | Path | None = None
                   ) -> ExperimentConfig:
        """The experiment that runs ``methods`` on this suite's maps (a suite of its own maps).

        ``base`` is the folder against which plugin file paths are taken (default: the current
        directory). The experiment keeps the recordings of failed episodes.
        """
        if self.includes:
            raise FftnavError(f"suite {self.name} pools {list(self.includes)}: run those, "
                              f"got suite={self.name!r}")
        data = json.loads(json.dumps(self.tables))
        data.setdefault("experiment", {}).update(
            {"name": self.name, "policies": list(methods), "trajectory_maps": 0,
             "out": self.name})
        return parse_config(data, base=base)

    def pins(self) -> dict[str, Any]:
        """Everything this suite pins, as this fftnav resolves it (module docstring): the
        JSON of ``pins/<suite>.json``."""
        if self.includes:
            return {"suite": self.name, "includes": [p.name for p in self.parts]}
        config = self.experiment(builtin_methods()[:1])
        swarm = dataclasses.asdict(config.swarm)
        envs = sorted(config.envs)
        seeds = {env: [episode_seed(env, config.map_seed + i) for i in range(config.maps)]
                 for env in envs}
        worlds = {}
        for env in envs:
            digest = hashlib.sha256()
            for i in range(config.maps):
                digest.update(task_world(config, env, config.map_seed + i).to_json().encode())
            worlds[env] = digest.hexdigest()
        return {"suite": self.name, "envs": envs, "maps": config.maps,
                "map_seed": config.map_seed, "robots": config.robots, "swarm": swarm,
                "world": {env: world_parameters(env, **config.world_overrides(env))
                          for env in envs},
                "episode_seeds": seeds, "worlds_sha256": worlds,
                "csv_columns": list(CSV_COLUMNS)}

    @cached_property
    def pinned(self) -> dict[str, Any]:
        """The pins shipped with the package (``pins/<suite>.json``)."""
        path = pins_path(self.name)
        try:
            return json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise FftnavError(f"suite {self.name}: cannot read its pins {path}: {exc}") from None

    def changes(self) -> list[str]:
        """What this fftnav resolves differently from the suite's pins, one ``key: pinned ->
        now`` per difference (empty: the suite is what it was when its references were made).

        A non-empty list means the suite's scores are not comparable any more: the suite needs
        a new version (and new references)."""
        found: list[str] = []
        _diff(self.pinned, _jsonable(self.pins()), "", found)
        return found

    def check(self) -> None:
        """Refuse a suite whose pins changed (:meth:`changes`), naming the first changes."""
        changed = self.changes()
        if changed:
            more = f" (and {len(changed) - 3} more)" if len(changed) > 3 else ""
            raise FftnavError(f"suite {self.name} is not what its version pins: "
                              f"{'; '.join(changed[:3])}{more}; a new version of the suite "
                              f"is needed")


def _jsonable(value: Any) -> Any:
    return json.loads(json.dumps(value))


def _diff(pinned: Any, now: Any, key: str, found: list[str]) -> None:
    if isinstance(pinned, dict) and isinstance(now, dict):
        for k in sorted(set(pinned) | set(now)):
            sub = f"{key}.{k}" if key else str(k)
            if k not in now:
                found.append(f"{sub}: pinned {_short(pinned[k])} -> gone")
            elif k not in pinned:
                found.append(f"{sub}: not pinned -> {_short(now[k])}")
            else:
                _diff(pinned[k], now[k], sub, found)
    elif pinned != now:
        found.append(f"{key}: pinned {_short(pinned)} -> {_short(now)}")


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 40 else text[:37] + "..."


def pins_path(name: str) -> Path:
    """Where a suite's pins ship: ``fftnav/suites/pins/<suite>.json``."""
    return Path(str(_DATA / "pins" / f"{name}.json"))


def references_folder(name: str) -> Path:
    """Where a suite's reference rows ship: ``fftnav/suites/references/<suite>/``."""
    return Path(str(_DATA / "references" / name))


def suite_from_toml(text: str, *, file: str = "") -> Suite:
    """A suite from its definition's TOML text (module docstring); ``file``, the file's name,
    must be ``<family>-v<version>.toml`` when given."""
    data = tomllib.loads(text)
    head = data.pop("suite", None)
    if not isinstance(head, dict):
        raise FftnavError(f"a suite definition needs a [suite] table, got {file or 'text'} "
                          "without one")
    try:
        suite = Suite(family=str(head["family"]), version=int(head["version"]),
                      description=str(head["description"]), measures=str(head["measures"]),
                      includes=tuple(head.get("includes", ())), tables=data)
    except KeyError as exc:
        raise FftnavError(f"suite definition {file or 'text'} lacks suite.{exc.args[0]}"
                          ) from None
    if file and f"{suite.name}.toml" != file:
        raise FftnavError(f"suite file {file} must be named {suite.name}.toml")
    return suite


def _load_suites() -> Registry[Suite]:
    suites: Registry[Suite] = Registry("suite", parameter="suite")
    folder = _DATA / "defs"
    for entry in sorted(folder.iterdir(), key=lambda e: e.name):
        if entry.name.endswith(".toml"):
            suite = suite_from_toml(entry.read_text(encoding="utf-8"), file=entry.name)
            suites.add(suite.name, suite)
    return suites


#: The suites by name (``paper-v2``, ...), in name order.
SUITES: Registry[Suite] = _load_suites()


def ordered_suites() -> list[Suite]:
    """Every suite in reading order: the suites of their own maps (by name), then the pooling
    ones."""
    return sorted(SUITES.values(), key=lambda s: (bool(s.includes), s.name))


def find_suite(name: str) -> Suite:
    """The suite ``name``: a full name (``paper-v2``) or a family (``paper``, ``all``: its
    newest version); an unknown name is a ValueError listing the suites."""
    if name in SUITES:
        return SUITES[name]
    family = [s for s in SUITES.values() if s.family == name]
    if family:
        return max(family, key=lambda s: s.version)
    return SUITES.lookup(name)


def resolve_suites(names: Iterable[str]) -> list[Suite]:
    """The suites ``names`` name (:func:`find_suite`), each once, in the order given."""
    found = [find_suite(n) for n in names]
    return list({s.name: s for s in found}.values())


# -- reference rows ---------------------------------------------------------------------------

def _sums_path(folder: Path) -> Path:
    return folder / "SHA256SUMS"


def write_references(suite: Suite, episodes: pd.DataFrame, timing: pd.DataFrame,
                     folder: str | Path | None = None) -> Path:
    """Write a suite's reference rows: one ``<method>.csv`` per method of ``episodes`` (the
    runner's columns, rows in (env, map_seed, robot) order), ``timing.csv`` and
    ``SHA256SUMS`` into ``folder`` (default: the package's :func:`references_folder`)."""
    from fftnav.files import write_atomic

    out = Path(folder) if folder is not None else references_folder(suite.name)
    out.mkdir(parents=True, exist_ok=True)
    for old in out.glob("*.csv"):
        old.unlink()
    sums = []
    for method, rows in episodes.groupby("policy", sort=True):
        text = rows_csv(rows)
        write_atomic(out / f"{method}.csv", text)
        sums.append((f"{method}.csv", hashlib.sha256(text.encode()).hexdigest()))
    text = timing[list(TIMING_COLUMNS)].sort_values(["policy", "env", "map_seed"]).to_csv(
        index=False, float_format="%.6g")
    write_atomic(out / "timing.csv", text)
    sums.append(("timing.csv", hashlib.sha256(text.encode()).hexdigest()))
    write_atomic(_sums_path(out), "".join(f"{h}  {n}\n" for n, h in sorted(sums)))
    return out


def rows_csv(rows: pd.DataFrame) -> str:
    """Episode rows as the runner writes them (its columns, booleans ``true``/``false``, floats
    fixed), with a header, sorted by env, map seed and robot: the text of a method's
    reference or submitted rows, and what their hashes are taken of."""
    from fftnav.episode.record import episode_csv

    ordered = rows.sort_values(["env", "map_seed", "robot"])[list(CSV_COLUMNS)]
    return episode_csv(ordered.to_dict("records"), columns=CSV_COLUMNS)


def _verified(folder: Path) -> dict[str, bytes]:
    """The files of a reference folder, each checked against ``SHA256SUMS``."""
    sums = _sums_path(folder)
    if not sums.exists():
        raise ReferenceError(f"no reference rows in {folder} (no SHA256SUMS)")
    found = {}
    for line in sums.read_text(encoding="utf-8").splitlines():
        digest, _, name = line.partition("  ")
        data = (folder / name).read_bytes() if (folder / name).exists() else None
        if data is None:
            raise ReferenceError(f"reference file {folder / name} is missing")
        if hashlib.sha256(data).hexdigest() != digest:
            raise ReferenceError(f"reference file {folder / name} does not match its "
                                 "checksum in SHA256SUMS: it was changed after it was made")
        found[name] = data
    return found


def read_references(suite: Suite, *, folder: str | Path | None = None
                    ) -> tuple[pd.DataFrame, pd.DataFrame]:
    """A suite's reference rows and timing, checked (:class:`ReferenceError` if a file was
    changed), pooled over the suites a pooling suite includes.

    Returns
    -------
    (episodes, timing) : (DataFrame, DataFrame)
        The runner's episode columns for every built-in on every map, and
        :data:`fftnav.runner.run.TIMING_COLUMNS`.
    """
    import io

    episodes, timing = [], []
    for part in suite.parts:
        where = Path(folder) / part.name if folder is not None else references_folder(part.name)
        files = _verified(where)
        for name, data in sorted(files.items()):
            table = pd.read_csv(io.BytesIO(data))
            (timing if name == "timing.csv" else episodes).append(table)
    if not episodes:
        raise ReferenceError(f"suite {suite.name} has no reference rows")
    return (pd.concat(episodes, ignore_index=True),
            pd.concat(timing, ignore_index=True) if timing else
            pd.DataFrame(columns=list(TIMING_COLUMNS)))


def reference_lines(suite: Suite, method: str, env: str, map_seed: int, *,
                    folder: str | Path | None = None) -> str:
    """The reference CSV lines (no header) of ``method`` on one map, as the runner writes a
    task's file: what a rerun of that task must reproduce byte for byte."""
    where = Path(folder) if folder is not None else references_folder(suite.name)
    data = _verified(where).get(f"{method}.csv")
    if data is None:
        raise ReferenceError(f"suite {suite.name} has no reference rows of {method!r}")
    prefix = f"{env},{map_seed},{method},"
    return "".join(line + "\n" for line in data.decode().splitlines()
                   if line.startswith(prefix))


def maps_of(suite: Suite) -> list[tuple[str, int]]:
    """The suite's maps, ``(env, map_seed)`` in task order."""
    found = []
    for part in suite.parts:
        config = part.experiment(builtin_methods()[:1])
        found += [(env, config.map_seed + i) for env in sorted(config.envs)
                  for i in range(config.maps)]
    return found


def rerun_task(suite: Suite, task: str, *, folder: str | Path | None = None) -> Any:
    """Rerun the reference episode ``task`` (``env-map_seed-method``) of a suite of its own
    maps, recorded, and refuse it unless its rows are the shipped ones byte for byte: the
    replay of a leaderboard's failure, made on demand (``fftnav replay --suite``).

    Returns
    -------
    fftnav.runner.rerun.Rerun

    Raises
    ------
    ValueError
        ``task`` is not an episode of the suite's references (naming the close ones), or the
        rerun does not reproduce them (naming the first difference).
    """
    from fftnav.runner.rerun import Rerun, close_names, first_difference, task_lines
    from fftnav.runner.tasks import Task, run_task

    parts = {f"{env}-{seed}-": part for part in suite.parts for env, seed in maps_of(part)}
    prefix = next((p for p in parts if task.startswith(p)), None)
    method = task[len(prefix):] if prefix else ""
    names = [f"{p}{m}" for p in parts for m in builtin_methods()]
    if prefix is None or method not in builtin_methods():
        close = close_names(task, names)
        raise FftnavError(f"task must be a reference episode of {suite.name} "
                          f"(ENV-MAP_SEED-METHOD of a built-in), got task={task!r}"
                          + (f"; did you mean {', '.join(close)}?" if close else ""))
    part = parts[prefix]
    env, _, seed = prefix[:-1].rpartition("-")
    where = Path(folder) / part.name if folder is not None else None
    shipped = reference_lines(part, method, env, int(seed), folder=where).splitlines()
    config = dataclasses.replace(part.experiment([method]), record="all")
    found = Task(env, int(seed), method, episode_seed(env, int(seed)), True)
    result = run_task(config, found)
    here = task_lines(found, result)
    if here != shipped:
        raise FftnavError(f"the rerun of {task} must give the shipped reference rows of "
                          f"{suite.name}, got other rows ({first_difference(shipped, here)}): "
                          "this fftnav does not reproduce them")
    return Rerun(config, found, result)

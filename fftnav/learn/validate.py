"""Validation of a network during training: AR and SPL of its numpy twin on fixed maps.

The network is run as the method it becomes (``learned:PATH`` or ``learned-decider:PATH``)
through :func:`fftnav.episode.run_episode`, on the first ``episodes`` map seeds of the
validation range of every validation world, each with the runner's episode seed of that map
(:func:`fftnav.runner.tasks.episode_seed`); the maps' reference lengths (grid A*) are computed
once per training and kept in the output folder.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fftnav.episode import run_episode
from fftnav.files import read_json, write_atomic
from fftnav.learn.config import LearnConfig
from fftnav.optimal.reference import optimal_lengths
from fftnav.runner.tasks import episode_seed
from fftnav.world import generate_world

__all__ = ["Validation", "ValidationMaps", "method_reference"]


def method_reference(config: LearnConfig, path: Path) -> str:
    """How a trained network at ``path`` is named as a method."""
    prefix = "learned:" if config.method == "controller" else "learned-decider:"
    return f"{prefix}{path}"


@dataclass(frozen=True)
class Validation:
    """One validation: arrival rate, SPL and failures over every robot of the maps."""

    ar: float
    spl: float
    collided: float
    #: neither arrived nor collided (timed out or lost)
    timed_out: float
    robots: int


class ValidationMaps:
    """The fixed validation maps of a training, their worlds and reference lengths.

    Parameters
    ----------
    config : LearnConfig
    cache : Path
        JSON file of the maps' reference lengths (read if present, else written).
    """

    def __init__(self, config: LearnConfig, cache: Path) -> None:
        self.config = config
        self.maps = [(kind, config.validation.first + i) for kind in config.validation.worlds
                     for i in range(config.validate_episodes)]
        r0 = config.swarm.robot.r0_m
        self.worlds = {m: generate_world(m[0], m[1], robots=config.robots, robot_radius_m=r0)
                       for m in self.maps}
        stored = read_json(cache) if cache.exists() else {}
        lengths = {}
        for kind, seed in self.maps:
            key = f"{kind}-{seed}"
            if key not in stored:
                stored[key] = [a.tolist() for a in optimal_lengths(self.worlds[(kind, seed)],
                                                                    r0_m=r0)]
            lengths[(kind, seed)] = tuple(np.array(a) for a in stored[key])
        write_atomic(cache, json.dumps(stored, sort_keys=True))
        self.lengths = lengths

    def run(self, reference: str) -> Validation:
        """Run ``reference`` (a method's name) on every validation map."""
        rows = []
        for kind, seed in self.maps:
            result = run_episode(self.worlds[(kind, seed)], reference,
                                 seed=episode_seed(kind, seed), config=self.config.swarm,
                                 reference=self.lengths[(kind, seed)])
            rows.extend(result.rows)
        arrived = np.array([r.arrived for r in rows])
        collided = np.array([r.collided for r in rows])
        return Validation(ar=float(arrived.mean()), spl=float(np.mean([r.spl for r in rows])),
                          collided=float(collided.mean()),
                          timed_out=float(np.mean(~arrived & ~collided)), robots=len(rows))

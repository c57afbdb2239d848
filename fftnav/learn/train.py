"""``fftnav learn``: PPO (Stable-Baselines3, CPU torch) with one policy shared by every robot.

A training runs in segments of ``validation.every`` learner samples. Each segment starts new
episodes, trains, then exports the network to ``.npz`` (numpy only,
:class:`~fftnav.navigation.mlp.MLP`), validates that file as the method it is
(:mod:`fftnav.learn.validate`), appends a row to ``curve.csv``, keeps the best file by
validation SPL (ties: the earlier) as ``best.npz`` and saves a checkpoint (the SB3 model with
its optimiser, and every generator's state). Rerunning the same command resumes from the
checkpoint and gives the same curve and weights as an uninterrupted run (same seed, CPU torch
with one thread); another config for the same folder is refused.

Controller: :class:`~fftnav.learn.batch.SwarmBatch` (the robots of a ``SwarmNavEnv`` as slots)
behind an SB3 ``VecEnv``; ``MlpPolicy`` with separate tanh actor and critic of ``hidden``
widths, a diagonal Gaussian over ``(a_v, a_w)``; the exported actor is the Gaussian's mean.

Decider: :class:`~fftnav.envs.DecisionEnv`, one decision per step, trained as a contextual
bandit with exact credit: the return of a decision is its robot's path until its next decision
(or its end, with the arrival bonus or failure penalty) minus the progress to the goal made
meanwhile, so ``-(excess path)``: the potential-based shaping of "the path that follows", whose
sum over a robot's decisions is its path minus its start-to-goal distance. A decision whose
return is not known when its rollout ends (its robot still driving) is left out of that update.
The exported decider's logit is ``logit(LEFT) - logit(RIGHT)`` of the categorical policy.
"""

from __future__ import annotations

import csv
import json
import math
import pickle
import random
import shutil
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fftnav.errors import FftnavError, import_extra
from fftnav.files import write_atomic
from fftnav.learn.batch import SwarmBatch
from fftnav.learn.config import LearnConfig
from fftnav.learn.validate import ValidationMaps, method_reference
from fftnav.navigation.decision_features import NAME as DECISION_FEATURES
from fftnav.navigation.mlp import MLP, VERSION

__all__ = ["CURVE_COLUMNS", "TrainOutcome", "check_extra", "export_policy", "train"]

#: Columns of ``curve.csv``, one row per validation.
CURVE_COLUMNS = ("samples", "live_steps", "episodes", "wall_s", "train_ar", "val_ar", "val_spl",
                 "val_collided", "val_timed_out", "val_robots")


@dataclass(frozen=True)
class TrainOutcome:
    """What a training left in its folder."""

    out: Path
    samples: int
    wall_s: float
    best_spl: float
    best_samples: int


def _imports() -> tuple[Any, Any]:
    """Stable-Baselines3 and torch, or MissingExtraError naming the pip line."""
    sb3 = import_extra("stable_baselines3", extra="learn", needed_for="training runs")
    torch = import_extra("torch", extra="learn", needed_for="training runs")
    return sb3, torch


def check_extra() -> None:
    """Raise MissingExtraError unless the extra ``learn`` is installed."""
    _imports()


# -- the controller's vector env --------------------------------------------------------------

def _vec_env_base() -> type:
    """SB3's ``VecEnv`` with the attribute and method plumbing our single-process envs need."""
    from stable_baselines3.common.vec_env import VecEnv

    class Base(VecEnv):
        render_mode = None  # nothing to render (SB3 warns when the attribute is missing)

        def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
            return [getattr(self, attr_name)] * len(self._get_indices(indices))

        def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
            setattr(self, attr_name, value)

        def env_method(self, method_name: str, *args: Any, indices: Any = None,
                       **kwargs: Any) -> list[Any]:
            raise NotImplementedError(method_name)

        def env_is_wrapped(self, wrapper_class: Any, indices: Any = None) -> list[bool]:
            return [False] * len(self._get_indices(indices))

    return Base


def _swarm_vec_env(batch: SwarmBatch) -> Any:
    """``batch`` as a Stable-Baselines3 ``VecEnv`` of ``batch.n`` slots."""
    from gymnasium import spaces

    class SwarmVecEnv(_vec_env_base()):  # type: ignore[misc]
        def __init__(self) -> None:
            super().__init__(batch.n, spaces.Box(-np.inf, np.inf, (batch.size,), np.float32),
                             spaces.Box(-1.0, 1.0, (2,), np.float32))
            self._actions: np.ndarray | None = None

        def reset(self) -> np.ndarray:
            return batch.reset().astype(np.float32)

        def step_async(self, actions: np.ndarray) -> None:
            self._actions = actions

        def step_wait(self) -> Any:
            obs, rewards, dones, truncated, ended = batch.step(self._actions)
            obs = obs.astype(np.float32)
            infos: list[dict[str, Any]] = [{} for _ in range(batch.n)]
            for i in np.flatnonzero(truncated).tolist():
                infos[i] = {"terminal_observation": obs[i], "TimeLimit.truncated": True}
            if ended:
                obs = batch.reset().astype(np.float32)
            return obs, rewards, dones, infos

        def close(self) -> None:
            batch.close()

    return SwarmVecEnv()


# -- the decider's credit ---------------------------------------------------------------------

class _Credit:
    """Exact per-decision returns of a :class:`DecisionEnv` (module docstring)."""

    def __init__(self, env: Any, worlds: tuple[str, ...], rng: np.random.Generator) -> None:
        self.env = env
        #: the features' standardisation (:meth:`standardise`), fixed before training
        self.mean = np.zeros(env.observation_space.shape, np.float64)
        self.std = np.ones(env.observation_space.shape, np.float64)
        self.worlds = worlds
        self.rng = rng
        self.episode = -1
        self.pending: tuple[int, int] | None = None
        #: (episode, decision) of each step's answered decision, in order
        self.log: list[tuple[int, int]] = []
        self.start: dict[tuple[int, int], float] = {}
        self.returns: dict[tuple[int, int], float] = {}
        self.tally_robots = 0
        self.tally_arrived = 0
        self.episodes = 0

    def _distance(self, robot: int) -> float:
        core = self.env.core  # the last pose driven (a robot that left keeps its last)
        return float(np.hypot(*(np.asarray(core.robots.trajectories[robot][-1][:2])
                                - core.goals[robot])))

    def _opened(self, info: dict[str, Any]) -> None:
        key = (self.episode, int(info["decision"]))
        self.pending = key
        self.start[key] = self._distance(int(info["robot"]))

    def _closed(self, info: dict[str, Any]) -> None:
        for decision, robot, reward in info.get("closed", ()):
            key = (self.episode, int(decision))
            start = self.start.pop(key, None)
            if start is not None:
                self.returns[key] = float(reward) + start - self._distance(int(robot))

    def standardise(self, decisions: int) -> None:
        """Fix ``mean`` and ``std`` from ``decisions`` features met with random sides (a
        feature that does not vary keeps ``std = 1``)."""
        seen = [self.reset()]
        while len(seen) < decisions:
            obs, done = self.step(int(self.rng.integers(2)))
            seen.append(self.reset() if done else obs)
        x = np.array(seen, np.float64)
        self.mean = x.mean(axis=0)
        std = x.std(axis=0)
        self.std = np.where(std > 1e-6, std, 1.0)
        self.log.clear()
        self.returns.clear()

    def features(self, obs: np.ndarray) -> np.ndarray:
        return ((obs - self.mean) / self.std).astype(np.float32)

    def reset(self) -> np.ndarray:
        kind = self.worlds[int(self.rng.integers(len(self.worlds)))]
        obs, info = self.env.reset(seed=int(self.rng.integers(2**31)),
                                   options={"world_kind": kind})
        self.episode += 1
        self._opened(info)
        return obs

    def step(self, action: int) -> tuple[np.ndarray, bool]:
        assert self.pending is not None
        self.log.append(self.pending)
        obs, _, terminated, _, info = self.env.step(int(action))
        self._closed(info)
        if terminated:
            rows = self.env.episode_rows()
            self.tally_robots += len(rows)
            self.tally_arrived += sum(r.arrived for r in rows)
            self.episodes += 1
            self.pending = None
            return obs, True
        self._opened(info)
        return obs, False


def _decision_vec_env(credit: _Credit) -> Any:
    """The decisions of ``credit``'s environment as a Stable-Baselines3 ``VecEnv`` of 1."""
    from gymnasium import spaces

    class DecisionVecEnv(_vec_env_base()):  # type: ignore[misc]
        def __init__(self) -> None:
            super().__init__(1, credit.env.observation_space, spaces.Discrete(2))
            self._action = 0

        def reset(self) -> np.ndarray:
            return credit.features(credit.reset())[None, :]

        def step_async(self, actions: np.ndarray) -> None:
            self._action = int(np.asarray(actions).reshape(-1)[0])

        def step_wait(self) -> Any:
            obs, done = credit.step(self._action)
            if done:
                obs = credit.reset()
            return credit.features(obs)[None, :], np.zeros(1, np.float32), np.array([done]), [{}]

        def close(self) -> None:
            credit.env.close()

    return DecisionVecEnv()


def _credit_callback(credit: _Credit) -> Any:
    """At each rollout's end, the buffer's returns become the decisions' exact returns and
    advantages ``return - value``, standardised over the known ones; unknown ones get 0."""
    from stable_baselines3.common.callbacks import BaseCallback

    class Credit(BaseCallback):
        def _on_step(self) -> bool:
            return True

        def _on_rollout_end(self) -> None:
            buf = self.model.rollout_buffer
            n = buf.buffer_size
            keys = credit.log[-n:]
            known = np.array([k in credit.returns for k in keys])
            returns = np.array([credit.returns.get(k, 0.0) for k in keys], np.float32)
            values = buf.values[:, 0]
            adv = np.where(known, returns - values, 0.0)
            if known.sum() > 1:
                sel = adv[known]
                adv[known] = (sel - sel.mean()) / (sel.std() + 1e-8)
            buf.advantages[:, 0] = adv
            buf.returns[:, 0] = np.where(known, returns, values)
            credit.log.clear()  # the next rollout's decisions are all new
            credit.returns.clear()

    return Credit()


# -- export -----------------------------------------------------------------------------------

def _linears(module: Any) -> list[Any]:
    import torch

    return [m for m in module.modules() if isinstance(m, torch.nn.Linear)]


def export_policy(model: Any, config: LearnConfig,
                  standardisation: tuple[np.ndarray, np.ndarray] | None = None) -> MLP:
    """The SB3 policy's actor as an :class:`MLP`: a controller's Gaussian mean, or a decider's
    ``logit(LEFT) - logit(RIGHT)`` (``W_i = weight.T``) with its features' ``standardisation``
    ``(mean, std)`` in the meta."""
    policy = model.policy
    layers = [*_linears(policy.mlp_extractor.policy_net), policy.action_net]
    weights = [lin.weight.detach().cpu().numpy().T.astype(np.float64) for lin in layers]
    biases = [lin.bias.detach().cpu().numpy().astype(np.float64) for lin in layers]
    if config.method == "decider":
        weights[-1] = (weights[-1][:, 1] - weights[-1][:, 0])[:, None]
        biases[-1] = np.array([biases[-1][1] - biases[-1][0]])
        meta = {"kind": "decider", "observation": DECISION_FEATURES, "version": VERSION,
                "mean": standardisation[0].tolist(), "std": standardisation[1].tolist()}
    else:
        meta = {"kind": "controller", "observation": config.observation, "version": VERSION}
        if config.speeds is not None:
            meta["v_range"] = list(config.speeds)
    meta["trained"] = {"library": "stable-baselines3 PPO", "seed": config.seed,
                       "samples": int(model.num_timesteps)}
    return MLP(weights=weights, biases=biases, activation="tanh", output="identity", meta=meta)


# -- the training loop ------------------------------------------------------------------------

class _Run:
    """The model, its environment and every generator of one training."""

    def __init__(self, config: LearnConfig, out: Path, *, resume: bool = False) -> None:
        sb3, torch = _imports()
        self.config, self.out, self.torch = config, out, torch
        torch.set_num_threads(1)
        sb3.common.utils.set_random_seed(config.seed)
        self.rng = np.random.default_rng(config.seed)
        ppo = config.ppo
        kwargs = {"n_steps": ppo.n_steps, "batch_size": ppo.batch_size,
                  "n_epochs": ppo.n_epochs, "learning_rate": ppo.learning_rate,
                  "gamma": ppo.gamma, "gae_lambda": ppo.gae_lambda,
                  "clip_range": ppo.clip_range, "ent_coef": ppo.ent_coef,
                  "vf_coef": ppo.vf_coef, "max_grad_norm": ppo.max_grad_norm}
        arch = {"net_arch": {"pi": list(config.hidden), "vf": list(config.hidden)},
                "activation_fn": torch.nn.Tanh}
        self.callback = None
        if config.method == "controller":
            from fftnav.envs.swarm_env import Rewards

            r = config.reward
            self.batch = SwarmBatch(
                config.observation, schedule=config.train, robots=config.robots,
                config=config.swarm, rewards=Rewards(progress=r.progress, arrival=r.arrival,
                                                     collision=r.collision, step=r.step),
                rng=self.rng, speeds=config.speeds,
                min_live=max(1, math.ceil(config.min_live * config.robots)))
            self.venv = _swarm_vec_env(self.batch)
            arch["log_std_init"] = ppo.log_std_init
        else:
            from fftnav.envs import DecisionEnv

            env = DecisionEnv(config.train.worlds[0],
                              map_seeds=(config.train.first, config.train.end),
                              robots=config.robots, config=config.swarm,
                              arrival_bonus_m=config.reward.arrival_bonus_m,
                              failure_penalty_m=config.reward.failure_penalty_m)
            self.credit = _Credit(env, config.train.worlds, self.rng)
            if not resume:  # a checkpoint holds it
                self.credit.standardise(config.warmup)
            self.venv = _decision_vec_env(self.credit)
            self.callback = _credit_callback(self.credit)
            kwargs["normalize_advantage"] = False
        self.model = sb3.PPO("MlpPolicy", self.venv, policy_kwargs=arch, seed=None,
                             device="cpu", verbose=0, **kwargs)
        self.sb3 = sb3

    def standardisation(self) -> tuple[np.ndarray, np.ndarray] | None:
        if self.config.method == "controller":
            return None
        return self.credit.mean, self.credit.std

    # progress figures
    def live_steps(self) -> int:
        return self.batch.live_steps if self.config.method == "controller" else 0

    def episodes(self) -> int:
        if self.config.method == "controller":
            return self.batch.tally.episodes
        return self.credit.episodes

    def train_ar(self) -> float:
        if self.config.method == "controller":
            t = self.batch.tally
            robots, arrived = t.robots, t.arrived
        else:
            robots, arrived = self.credit.tally_robots, self.credit.tally_arrived
        return arrived / robots if robots else float("nan")

    # checkpoints
    def _state(self) -> dict[str, Any]:
        # SB3 shuffles its minibatches with numpy's global generator: kept for an exact resume
        state = {"torch": self.torch.get_rng_state(),
                 "numpy": np.random.get_state(),  # noqa: NPY002
                 "python": random.getstate(), "rng": self.rng.bit_generator.state}
        if self.config.method == "controller":
            state["tally"] = asdict(self.batch.tally)
            state["live_steps"] = self.batch.live_steps
        else:
            c = self.credit
            state["tally"] = (c.tally_robots, c.tally_arrived, c.episodes, c.episode)
            state["standardisation"] = (c.mean, c.std)
        return state

    def save(self, folder: Path, extra: dict[str, Any]) -> None:
        folder.mkdir(parents=True, exist_ok=True)
        tmp = folder / "model.tmp.zip"
        self.model.save(tmp)
        write_atomic(folder / "state.pkl", pickle.dumps({**self._state(), **extra}))
        tmp.replace(folder / "model.zip")

    def load(self, folder: Path) -> dict[str, Any]:
        self.model = self.sb3.PPO.load(folder / "model.zip", env=self.venv, device="cpu")
        with open(folder / "state.pkl", "rb") as fh:
            state = pickle.load(fh)
        self.torch.set_rng_state(state["torch"])
        np.random.set_state(state["numpy"])  # noqa: NPY002
        random.setstate(state["python"])
        self.rng.bit_generator.state = state["rng"]
        if self.config.method == "controller":
            for key, value in state["tally"].items():
                setattr(self.batch.tally, key, value)
            self.batch.live_steps = state["live_steps"]
        else:
            c = self.credit
            c.tally_robots, c.tally_arrived, c.episodes, c.episode = state["tally"]
            c.mean, c.std = state["standardisation"]
        return state

    def segment(self, samples: int, *, progress: Any) -> None:
        """Train ``samples`` more learner samples, from new episodes, ``progress`` (an SB3
        callback) told after every rollout."""
        self.model._last_obs = None  # learn() starts new episodes: resuming is exact
        callbacks = [c for c in (self.callback, progress) if c is not None]
        self.model.learn(samples, reset_num_timesteps=False, callback=callbacks)

    def close(self) -> None:
        self.venv.close()


def _prepare_folder(config: LearnConfig, out: Path, *, fresh: bool) -> bool:
    """Make ``out`` ready; whether it holds a checkpoint to resume (same config only)."""
    stored = out / "config.json"
    if fresh and out.exists():
        for name in ("checkpoint", "curve.csv", "best.npz", "policy.npz", "untrained.npz",
                     "config.json", "config.toml", "run.json"):
            path = out / name
            if path.is_dir():
                shutil.rmtree(path)
            elif path.exists():
                path.unlink()
    if stored.exists():
        old = json.loads(stored.read_text())
        if old.get("sha256") != config.sha256():
            raise FftnavError(f"{out} holds a training of another config ({stored}); use "
                              f"another --out, or --fresh to start it again")
        return (out / "checkpoint" / "model.zip").exists()
    out.mkdir(parents=True, exist_ok=True)
    write_atomic(stored, json.dumps({"sha256": config.sha256(), **config.to_json()},
                                    indent=1, sort_keys=True, default=list))
    if config.source:
        write_atomic(out / "config.toml", config.source)
    return False


def _curve_rows(path: Path) -> list[dict[str, str]]:
    if not path.exists():
        return []
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _write_curve(path: Path, rows: list[dict[str, Any]]) -> None:
    lines = [",".join(CURVE_COLUMNS)]
    for row in rows:
        lines.append(",".join(_fmt(row[c]) for c in CURVE_COLUMNS))
    write_atomic(path, "\n".join(lines) + "\n")


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def train(config: LearnConfig, out: str | Path, *, fresh: bool = False,
          progress: Callable[[dict[str, Any]], None] | None = None) -> TrainOutcome:
    """Train ``config`` into ``out`` (module docstring), resuming a checkpoint there.

    Parameters
    ----------
    config : LearnConfig
    out : str or Path
        The training's folder: ``config.toml``, ``config.json``, ``curve.csv``,
        ``policy.npz`` (the latest network), ``best.npz``, ``untrained.npz`` (the network
        before training), ``checkpoint/``, ``run.json``.
    fresh : bool
        Start again, removing an earlier training of this folder.
    progress : callable, optional
        Called after every rollout with ``{"samples", "total", "live_steps", "train_ar",
        "episodes"}``.

    Returns
    -------
    TrainOutcome

    Raises
    ------
    MissingExtraError
        Without the extra ``learn`` (Stable-Baselines3 and torch).
    FftnavError
        ``out`` holds a training of another config.
    """
    out = Path(out)
    _imports()
    resume = _prepare_folder(config, out, fresh=fresh)
    maps = ValidationMaps(config, out / "validation_maps.json")
    run = _Run(config, out, resume=resume)
    curve_path = out / "curve.csv"
    rows: list[dict[str, Any]] = []
    best = (-1.0, 0)
    wall0 = 0.0
    t0 = time.perf_counter()
    try:
        if resume:
            state = run.load(out / "checkpoint")
            rows = _curve_rows(curve_path)[:state["rows"]]
            best, wall0 = tuple(state["best"]), state["wall_s"]
        def validate() -> None:
            nonlocal best
            samples = int(run.model.num_timesteps)
            net = export_policy(run.model, config, run.standardisation())
            net.save(out / "policy.npz")
            result = maps.run(method_reference(config, out / "policy.npz"))
            rows.append({"samples": samples, "live_steps": run.live_steps(),
                         "episodes": run.episodes(),
                         "wall_s": round(wall0 + time.perf_counter() - t0, 1),
                         "train_ar": run.train_ar(), "val_ar": result.ar,
                         "val_spl": result.spl, "val_collided": result.collided,
                         "val_timed_out": result.timed_out, "val_robots": result.robots})
            _write_curve(curve_path, rows)
            if result.spl > best[0]:
                best = (result.spl, samples)
                net.save(out / "best.npz")
            run.save(out / "checkpoint", {"rows": len(rows), "best": best,
                                          "wall_s": wall0 + time.perf_counter() - t0})

        if not rows:  # the untrained network: the curve's first point, kept as untrained.npz
            validate()
            shutil.copyfile(out / "policy.npz", out / "untrained.npz")
        report = _progress_callback(run, config, progress)
        while run.model.num_timesteps < config.agent_steps:
            run.segment(min(config.validate_every,
                            config.agent_steps - int(run.model.num_timesteps)), progress=report)
            validate()
    finally:
        run.close()
    wall = wall0 + time.perf_counter() - t0
    write_atomic(out / "run.json", json.dumps({
        "samples": int(run.model.num_timesteps), "wall_s": round(wall, 1),
        "best_spl": best[0], "best_samples": best[1], "validations": len(rows)}, indent=1))
    return TrainOutcome(out, int(run.model.num_timesteps), wall, best[0], best[1])


def _progress_callback(run: _Run, config: LearnConfig,
                       progress: Callable[[dict[str, Any]], None] | None) -> Any:
    from stable_baselines3.common.callbacks import BaseCallback

    class Progress(BaseCallback):
        def _on_step(self) -> bool:
            return True

        def _on_rollout_end(self) -> None:
            if progress is not None:
                progress({"samples": int(run.model.num_timesteps), "total": config.agent_steps,
                          "live_steps": run.live_steps(), "train_ar": run.train_ar(),
                          "episodes": run.episodes()})

    return Progress()

"""Choose the RL library of ``fftnav learn`` by measurement: PPO training throughput
of each candidate on :class:`fftnav.envs.SwarmNavEnv`, side by side, and the environment alone.

Run, after ``bash experiments/learn_libraries.sh ROOT`` has made one venv per candidate in
``ROOT/venvs`` and their install figures in ``ROOT/installs.csv``::

    .venv/bin/python experiments/learn_libraries.py --root ROOT --seconds 90 \\
        --out results/learn_libraries.csv

It runs the candidates one after the other, each in its own venv's Python (this file with
``--worker NAME``, which prints one JSON line), and writes one CSV row per candidate: library,
versions, install_s (download and install), installed_mb (the venv less an empty venv),
download_mb (the wheels), agent_steps_per_s (PPO training), env_only_steps_per_s (the
environment alone, random actions, in the same venv just before), extra_mb and
extra_download_mb (less the ``base`` venv: fftnav with its ``marl`` and ``fast`` extras, so the
learn extra's own cost), deterministic (two runs of 2 PPO iterations from the same seed end on
bit-identical parameters), load_avg (the 1-minute load average before and after the candidate)
and notes. ``--profile STEPS`` prints where the environment's time goes (cProfile, random
actions). ``--threads`` sets torch's and XLA's intra-op threads (default 1: beside the
single-threaded simulator, SB3 with 2 torch threads ran 8 % slower on the idle 2-core machine
and 8 times slower at a load average of 4 to 5). ``--set physics_hz=60`` runs the env, sb3
and skrl workers with a config key changed.

The task, the same for every library: forest map 0, 15 robots, default observations (the 360
ranges and the goal) as 362 numbers (ranges / R, goal / 10 m); an agent that has ended sees
zeros and gets no reward until every agent has ended and the episode restarts (SuperSuit's
"black death"; TorchRL masks it instead). PPO with one policy shared by the 15 agents: an MLP
of two hidden layers of 64 (tanh) for a Gaussian, a value MLP of the same size, rollouts of
128 steps x 15 agents, 4 epochs of 4 minibatches of 480, Adam 3e-4, gamma 0.99, GAE 0.95,
clip 0.2, on the CPU. Each library's own route from the PettingZoo environment: SB3 through
SuperSuit (``pettingzoo_env_to_vec_env_v1``, ``concat_vec_envs_v1``; black death by this
file's wrapper: SuperSuit 3.11.0's ``black_death_v3`` ends an episode only when every agent is
terminated *and* truncated at once, so never here; fixed upstream, SuperSuit PR #265);
skrl through its gymnasium wrapper, on the agents as a ``gymnasium.vector.VectorEnv`` (its
PettingZoo wrapper serves its multi-agent IPPO/MAPPO, one model per agent); TorchRL through
``PettingZooWrapper`` (the agents one group, with a mask) and a collector. Throughput counts
agent-steps (one agent's transition, ended agents included, as their slots are computed) over
whole PPO iterations (rollout and update) after one warm-up iteration, until ``--seconds``
have passed.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve()
ROBOTS = 15
N_STEPS = 128          # rollout length per agent
MINIBATCH = 480        # 4 minibatches of a 1920-transition rollout
EPOCHS = 4
HIDDEN = (64, 64)
GOAL_SCALE_M = 10.0
#: Intra-op threads of torch and XLA (``--threads``; set in the workers' environment too).
THREADS = 1
#: Config keys of the environment (``--set KEY=VALUE``, e.g. ``physics_hz=60``; default none:
#: the benchmark's configuration).
SETTINGS: dict[str, float] = {}
#: PPO iterations of the determinism check (``--iterations``; 0: the timed throughput run).
ITERATIONS = 0


def thread_env(threads: int) -> dict[str, str]:
    """Environment variables that hold OpenMP, MKL and XLA to ``threads`` threads."""
    env = {"OMP_NUM_THREADS": str(threads), "MKL_NUM_THREADS": str(threads)}
    if threads == 1:
        env["XLA_FLAGS"] = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
    return env

#: Candidates: the worker run in each venv, its library name and the packages whose versions
#: the CSV records.
CANDIDATES = {
    "sb3-cpu": ("sb3", "Stable-Baselines3 + SuperSuit, CPU torch",
                ("stable-baselines3", "supersuit", "torch")),
    "sb3-cuda": ("sb3", "Stable-Baselines3 + SuperSuit, PyPI's default torch (CUDA)",
                 ("stable-baselines3", "supersuit", "torch")),
    "skrl-jax": ("skrl", "skrl, JAX backend (jax[cpu])", ("skrl", "jax", "flax", "optax")),
    "torchrl-cpu": ("torchrl", "TorchRL (+ BenchMARL installed), CPU torch",
                    ("torchrl", "tensordict", "benchmarl", "torch")),
}


# -- the task: one SwarmNavEnv as a fixed batch of agents -----------------------------------

class SwarmBatch:
    """The agents of one :class:`~fftnav.envs.SwarmNavEnv` as a fixed batch.

    ``reset()`` gives observations ``(K, M + 2)`` float32; ``step(actions)`` takes ``(K, 2)``
    actions in [-1, 1] and gives observations, rewards ``(K,)``, dones ``(K,)`` (True at an
    agent's last step) and whether the episode ended (every agent's done; with ``autoreset``
    the observations are then the next episode's first). Ended agents see zeros.
    """

    def __init__(self, *, map_seed: int = 0, robots: int = ROBOTS, seed: int = 0,
                 autoreset: bool = True) -> None:
        from fftnav.config import SwarmConfig
        from fftnav.envs import SwarmNavEnv

        config = SwarmConfig().replace(SETTINGS) if SETTINGS else None
        self.env = SwarmNavEnv("forest", map_seed=map_seed, robots=robots, config=config)
        self.agents = list(self.env.possible_agents)
        self.n = len(self.agents)
        self.beams = self.env.config.sensor.beams
        self.range_m = self.env.config.sensor.range_m
        self.high = self.env.action_space(self.agents[0]).high.astype(np.float64)
        self.dim = self.beams + 2
        self.seed = seed
        self.autoreset = autoreset
        self.episodes = 0

    def reset(self) -> np.ndarray:
        obs, _ = self.env.reset(seed=self.seed + self.episodes)
        self.episodes += 1
        return self._flat(obs)

    def _flat(self, obs: dict) -> np.ndarray:
        out = np.zeros((self.n, self.dim), np.float32)
        for agent, o in obs.items():
            i = self.env.index(agent)
            out[i, :self.beams] = o["scan"] / self.range_m
            out[i, self.beams:] = o["goal"] / GOAL_SCALE_M
        return out

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        actions = np.clip(np.asarray(actions, np.float64).reshape(self.n, 2), -1.0, 1.0)
        act = {a: actions[self.env.index(a)] * self.high for a in self.env.agents}
        obs, rew, term, trunc, _ = self.env.step(act)
        reward = np.zeros(self.n, np.float32)
        done = np.zeros(self.n, bool)
        for agent, r in rew.items():
            i = self.env.index(agent)
            reward[i] = r
            done[i] = term[agent] or trunc[agent]
        if not self.env.agents:
            done[:] = True
            return (self.reset() if self.autoreset else self._flat({})), reward, done, True
        return self._flat(obs), reward, done, False


def env_only(seconds: float, *, seed: int = 0) -> dict:
    """Agent-steps per second of the environment alone, random actions, for ``seconds``: of the
    15 slots (as the learners count them) and of the live agents (in ``env.agents``: moving or
    waiting to depart; ended ones are parked and cost nothing)."""
    env = SwarmBatch(seed=seed)
    rng = np.random.default_rng(seed)
    env.reset()
    for _ in range(20):  # warm-up: numba kernels, caches
        env.step(rng.uniform(-1, 1, (env.n, 2)))
    steps, live, resets, t0 = 0, 0, 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        live += len(env.env.agents)
        _, _, _, restarted = env.step(rng.uniform(-1, 1, (env.n, 2)))
        steps += 1
        resets += restarted
    dt = time.perf_counter() - t0
    return {"env_only_steps_per_s": steps * env.n / dt, "live_steps_per_s": live / dt,
            "env_steps": steps, "resets": resets}


# -- the PettingZoo route for SB3: SuperSuit --------------------------------------------------

def _flat_parallel_env():
    """SwarmNavEnv with flat Box observations and every agent present until the episode ends
    (black death: an ended agent sees zeros, gets 0 and is done again at the episode's end), as
    a PettingZoo ParallelEnv for SuperSuit's pettingzoo_env_to_vec_env_v1. SuperSuit's own
    black_death_v3 (3.11.0) ends the episode only when every agent is terminated *and*
    truncated (``terminations & truncations``), so after the last agent leaves it steps an
    environment that has no agents left (``step() needs a live episode``)."""
    from gymnasium import spaces
    from pettingzoo.utils import BaseParallelWrapper

    inner = SwarmBatch(autoreset=False)

    class Flat(BaseParallelWrapper):
        def __init__(self):
            super().__init__(inner.env)
            self._space = spaces.Box(-np.inf, np.inf, (inner.dim,), np.float32)
            self._act = spaces.Box(-1.0, 1.0, (2,), np.float32)
            self.agents = []

        def observation_space(self, agent):
            return self._space

        def action_space(self, agent):
            return self._act

        def reset(self, seed=None, options=None):
            flat = inner.reset()
            self.agents = list(inner.agents)
            return {a: flat[i] for i, a in enumerate(self.agents)}, {a: {} for a in self.agents}

        def step(self, actions):
            flat, reward, done, restarted = inner.step(
                np.array([actions[a] for a in inner.agents]))
            if restarted:  # every agent has ended: the vec env resets next
                self.agents = []
            agents = inner.agents
            term = {a: bool(done[i]) for i, a in enumerate(agents)}
            return ({a: flat[i] for i, a in enumerate(agents)},
                    {a: float(reward[i]) for i, a in enumerate(agents)}, term,
                    {a: False for a in agents}, {a: {} for a in agents})

    return Flat()


def run_sb3(seconds: float, *, seed: int = 0) -> dict:
    """SB3 PPO through SuperSuit: pettingzoo_env_to_vec_env_v1, concat_vec_envs_v1 (one env
    of 15 agents)."""
    import stable_baselines3 as sb3
    import supersuit as ss
    import torch

    # SuperSuit's ConcatVecEnv has no seed(), which SB3 calls when PPO is given a seed: seed
    # Python, numpy and torch here instead, and the episodes by SwarmBatch's seeds
    sb3.common.utils.set_random_seed(seed)
    torch.set_num_threads(THREADS)
    venv = ss.pettingzoo_env_to_vec_env_v1(_flat_parallel_env())
    venv = ss.concat_vec_envs_v1(venv, 1, num_cpus=0, base_class="stable_baselines3")
    model = sb3.PPO("MlpPolicy", venv, n_steps=N_STEPS, batch_size=MINIBATCH, n_epochs=EPOCHS,
                    learning_rate=3e-4, gamma=0.99, gae_lambda=0.95, clip_range=0.2,
                    policy_kwargs={"net_arch": {"pi": list(HIDDEN), "vf": list(HIDDEN)},
                                   "activation_fn": torch.nn.Tanh},
                    seed=None, device="cpu", verbose=0)
    per_iter = N_STEPS * venv.num_envs

    def iterate():
        model.learn(per_iter, reset_num_timesteps=False)
        return per_iter

    return _timed(iterate, seconds,
                  params=lambda: [v.numpy() for v in model.policy.state_dict().values()],
                  extra={"torch_threads": torch.get_num_threads(), "agents": venv.num_envs})


def _timed(iterate, seconds: float, *, params, extra: dict | None = None) -> dict:
    """Run ``iterate`` (one PPO iteration, returns its agent-steps) once to warm up, then until
    ``seconds`` have passed; agent-steps per second over the timed iterations. With
    ``--iterations N``: N iterations, and the SHA-256 of the parameters ``params()`` gives
    after them (the determinism check: the same seed twice, the same hash)."""
    if ITERATIONS:
        for _ in range(ITERATIONS):
            iterate()
        digest = hashlib.sha256()
        for a in params():
            digest.update(np.ascontiguousarray(np.asarray(a, np.float64)).tobytes())
        return {"params_sha256": digest.hexdigest()}
    t = time.perf_counter()
    iterate()
    warmup = time.perf_counter() - t
    steps, iters, t0 = 0, 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        steps += iterate()
        iters += 1
    dt = time.perf_counter() - t0
    return {"agent_steps_per_s": steps / dt, "iterations": iters, "timed_s": dt,
            "warmup_s": warmup, **(extra or {})}


# -- skrl (JAX): a gymnasium VectorEnv of the agents ------------------------------------------

def _vector_env():
    """The agents of one SwarmNavEnv as a gymnasium VectorEnv (one sub-env per agent; the
    whole batch resets when every agent has ended)."""
    import gymnasium
    from gymnasium import spaces

    class SwarmVector(gymnasium.vector.VectorEnv):
        def __init__(self):
            self.batch = SwarmBatch()
            self.num_envs = self.batch.n
            self.single_observation_space = spaces.Box(-np.inf, np.inf, (self.batch.dim,),
                                                       np.float32)
            self.single_action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
            self.observation_space = spaces.Box(-np.inf, np.inf,
                                                (self.num_envs, self.batch.dim), np.float32)
            self.action_space = spaces.Box(-1.0, 1.0, (self.num_envs, 2), np.float32)
            self.metadata = {"autoreset_mode": gymnasium.vector.AutoresetMode.SAME_STEP}

        def reset(self, *, seed=None, options=None):
            return self.batch.reset(), {}

        def step(self, actions):
            obs, reward, done, _ = self.batch.step(np.asarray(actions))
            return obs, reward, done, np.zeros_like(done), {}

        def close(self, **kwargs):
            self.batch.env.close()

    return SwarmVector()


def run_skrl(seconds: float, *, seed: int = 0) -> dict:
    """skrl PPO, JAX backend, on the agents as a gymnasium VectorEnv (the interaction loop of
    skrl's SequentialTrainer, written out so that it runs by whole PPO iterations)."""
    import jax
    from skrl import config as skrl_config
    from skrl.agents.jax.ppo import PPO, PPO_CFG
    from skrl.envs.wrappers.jax import wrap_env
    from skrl.memories.jax import RandomMemory
    from skrl.utils import set_seed
    from skrl.utils.model_instantiators.jax import deterministic_model, gaussian_model

    skrl_config.jax.backend = "jax"
    set_seed(seed)
    env = wrap_env(_vector_env(), wrapper="gymnasium", verbose=False)
    net = [{"name": "net", "input": "OBSERVATIONS", "layers": list(HIDDEN),
            "activations": "tanh"}]
    spaces_ = {"observation_space": env.observation_space, "action_space": env.action_space,
               "device": env.device}
    models = {"policy": gaussian_model(**spaces_, network=net, output="ACTIONS"),
              "value": deterministic_model(**spaces_, network=net, output="ONE")}
    for role, model in models.items():
        model.init_state_dict(role=role)
    cfg = PPO_CFG(rollouts=N_STEPS, learning_epochs=EPOCHS,
                  mini_batches=N_STEPS * env.num_envs // MINIBATCH, discount_factor=0.99,
                  gae_lambda=0.95, learning_rate=3e-4, ratio_clip=0.2, value_clip=0.2,
                  grad_norm_clip=0.5, entropy_loss_scale=0.0, value_loss_scale=0.5)
    memory = RandomMemory(memory_size=N_STEPS, num_envs=env.num_envs, device=env.device)
    agent = PPO(models=models, memory=memory, cfg=cfg, observation_space=env.observation_space,
                action_space=env.action_space, device=env.device)
    agent.init()
    agent.enable_training_mode(True)
    obs, _ = env.reset()
    state = {"obs": obs, "t": 0}
    big = 10**9

    def iterate():
        for _ in range(N_STEPS):
            t = state["t"]
            agent.pre_interaction(timestep=t, timesteps=big)
            actions, _ = agent.act(state["obs"], None, timestep=t, timesteps=big)
            nxt, rewards, terminated, truncated, infos = env.step(actions)
            agent.record_transition(observations=state["obs"], states=None, actions=actions,
                                    rewards=rewards, next_observations=nxt, next_states=None,
                                    terminated=terminated, truncated=truncated, infos=infos,
                                    timestep=t, timesteps=big)
            agent.post_interaction(timestep=t, timesteps=big)
            state["obs"], state["t"] = nxt, t + 1
        return N_STEPS * env.num_envs

    def params():
        return [leaf for m in models.values()
                for leaf in jax.tree_util.tree_leaves(m.state_dict.params)]

    return _timed(iterate, seconds, params=params, extra={"jax_devices": str(jax.devices())})


# -- TorchRL: its PettingZoo wrapper, collector, GAE and PPO loss ------------------------------

def run_torchrl(seconds: float, *, seed: int = 0) -> dict:
    """TorchRL PPO on ``PettingZooWrapper(SwarmNavEnv)``: the 15 agents are one group
    (``robot``, with a mask of the live ones), the policy an MLP shared over the group's agent
    dimension, data by a SyncDataCollector (as in TorchRL's multi-agent PPO tutorial)."""
    import torch
    from tensordict.nn import NormalParamExtractor, TensorDictModule
    from torch import nn
    try:  # TorchRL >= 0.11 names it Collector and deprecates SyncDataCollector
        from torchrl.collectors import Collector as SyncDataCollector
    except ImportError:
        from torchrl.collectors import SyncDataCollector
    from torchrl.envs.libs.pettingzoo import PettingZooWrapper
    from torchrl.modules import MLP, ProbabilisticActor, TanhNormal, ValueOperator
    from torchrl.objectives import ClipPPOLoss, ValueEstimators

    from fftnav.envs import SwarmNavEnv

    torch.manual_seed(seed)
    torch.set_num_threads(THREADS)
    env = PettingZooWrapper(env=SwarmNavEnv("forest", map_seed=0, robots=ROBOTS),
                            use_mask=True, categorical_actions=False, return_state=False,
                            done_on_any=False, seed=seed)
    group = next(iter(env.group_map))
    k = len(env.group_map[group])
    range_m = env._env.config.sensor.range_m

    class Features(nn.Module):
        """The flat observation of SwarmBatch: ranges / R, goal / 10 m."""

        def forward(self, scan, goal):
            return torch.cat([scan / range_m, goal / GOAL_SCALE_M], dim=-1)

    dim = env._env.config.sensor.beams + 2
    obs_keys = [(group, "observation", "scan"), (group, "observation", "goal")]
    features = TensorDictModule(Features(), in_keys=obs_keys, out_keys=[(group, "features")])
    policy_net = nn.Sequential(MLP(in_features=dim, out_features=4, num_cells=list(HIDDEN),
                                   activation_class=nn.Tanh), NormalParamExtractor())
    spec = env.full_action_spec[group, "action"]
    actor = ProbabilisticActor(
        module=_seq(features, TensorDictModule(
            policy_net, in_keys=[(group, "features")], out_keys=[(group, "loc"),
                                                                  (group, "scale")])),
        spec=spec, in_keys=[(group, "loc"), (group, "scale")],
        out_keys=[(group, "action")], distribution_class=TanhNormal,
        distribution_kwargs={"low": spec.space.low, "high": spec.space.high},
        return_log_prob=True)
    critic = _seq(features, ValueOperator(
        MLP(in_features=dim, out_features=1, num_cells=list(HIDDEN), activation_class=nn.Tanh),
        in_keys=[(group, "features")], out_keys=[(group, "state_value")]))
    loss = ClipPPOLoss(actor_network=actor, critic_network=critic, clip_epsilon=0.2,
                       entropy_coeff=0.0, normalize_advantage=False)
    loss.set_keys(reward=(group, "reward"), action=(group, "action"),
                  value=(group, "state_value"), done=(group, "done"),
                  terminated=(group, "terminated"))
    loss.make_value_estimator(ValueEstimators.GAE, gamma=0.99, lmbda=0.95)
    optim = torch.optim.Adam(loss.parameters(), lr=3e-4)
    collector = SyncDataCollector(env, actor, frames_per_batch=N_STEPS, total_frames=-1,
                                  device="cpu")
    batches = iter(collector)

    def iterate():
        data = next(batches)  # (time,) with the group's (time, agents)
        with torch.no_grad():
            loss.value_estimator(data, params=loss.critic_network_params,
                                 target_params=loss.target_critic_network_params)
        flat = data.reshape(-1)
        n = flat.shape[0] * k
        per = max(1, MINIBATCH // k)  # minibatches of 480 agent-steps
        for _ in range(EPOCHS):
            perm = torch.randperm(flat.shape[0])
            for j in range(0, flat.shape[0], per):
                out = loss(flat[perm[j:j + per]])
                total = out["loss_objective"] + out["loss_critic"]
                optim.zero_grad()
                total.backward()
                nn.utils.clip_grad_norm_(loss.parameters(), 0.5)
                optim.step()
        collector.update_policy_weights_()
        return n

    result = _timed(iterate, seconds,
                    params=lambda: [p.detach().numpy() for p in loss.parameters()],
                    extra={"torch_threads": torch.get_num_threads()})
    collector.shutdown()
    return result


def _seq(*modules):
    from tensordict.nn import TensorDictSequential

    return TensorDictSequential(*modules)


WORKERS = {"sb3": run_sb3, "skrl": run_skrl, "torchrl": run_torchrl}


# -- where the environment's time goes ---------------------------------------------------------

def profile(steps: int, *, top: int = 25) -> None:
    """cProfile of ``steps`` random-action steps of the environment (after a warm-up): the top
    functions by own time, and the share of the time by package."""
    import cProfile
    import pstats

    env = SwarmBatch()
    rng = np.random.default_rng(0)
    env.reset()
    for _ in range(20):
        env.step(rng.uniform(-1, 1, (env.n, 2)))
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    for _ in range(steps):
        env.step(rng.uniform(-1, 1, (env.n, 2)))
    prof.disable()
    dt = time.perf_counter() - t0
    print(f"{steps} steps x {env.n} agents in {dt:.2f} s under cProfile "
          f"({steps * env.n / dt:.0f} agent-steps/s)")
    stats = pstats.Stats(prof)
    stats.sort_stats("tottime").print_stats(top)
    stats.sort_stats("cumulative").print_stats(40)
    by_package: dict[str, float] = {}
    total = 0.0
    for (path, _, _), (_, _, tottime, _, _) in stats.stats.items():
        total += tottime
        key = ("fftnav/" + path.split("fftnav/", 1)[1].split("/")[0] if "fftnav/" in path
               and "site-packages/fftnav" not in path.replace("fftnav/fftnav", "")
               else _package(path))
        by_package[key] = by_package.get(key, 0.0) + tottime
    print("own time by package:")
    for key, t in sorted(by_package.items(), key=lambda kv: -kv[1])[:15]:
        print(f"  {key:40s} {t:7.2f} s  {100 * t / total:5.1f} %")
    t = time.perf_counter()
    env.env.reset(seed=1, options={"map_seed": 1})
    print(f"reset onto a new map (world generation, simulator build): "
          f"{time.perf_counter() - t:.2f} s")
    t = time.perf_counter()
    env.env.reset(seed=2)
    print(f"reset on the same map: {time.perf_counter() - t:.2f} s")


def _package(path: str) -> str:
    if "fftnav/" in path:
        rest = path.rsplit("fftnav/", 1)[1]
        return "fftnav/" + (rest.split("/")[0] if "/" in rest else rest)
    if "site-packages/" in path:
        return path.split("site-packages/", 1)[1].split("/")[0]
    return path if path.startswith("<") or path == "~" else Path(path).name


# -- the side-by-side run ------------------------------------------------------------------------

def _versions(python: Path, packages: tuple[str, ...]) -> str:
    code = ("import importlib.metadata as m, sys\n"
            "out = []\n"
            "for p in sys.argv[1:]:\n"
            "    try: out.append(f'{p} {m.version(p)}')\n"
            "    except m.PackageNotFoundError: pass\n"
            "print('; '.join(out))")
    res = subprocess.run([str(python), "-c", code, *packages], capture_output=True, text=True,
                         check=False)
    return res.stdout.strip()


def _worker(python: Path, args: list[str], timeout: float) -> dict:
    env = {**os.environ, **thread_env(THREADS)}
    res = subprocess.run([str(python), str(HERE), *args, "--threads", str(THREADS)],
                         capture_output=True, text=True, timeout=timeout, check=False, env=env)
    lines = [ln for ln in res.stdout.splitlines() if ln.startswith("{")]
    if res.returncode or not lines:
        tail = (res.stderr.strip().splitlines() or ["no output"])[-1]
        return {"error": f"exit {res.returncode}: {tail[:200]}"}
    return json.loads(lines[-1])


def side_by_side(root: Path, seconds: float, env_seconds: float, out: Path,
                 names: list[str]) -> None:
    installs = {}
    with open(root / "installs.csv", newline="") as f:
        for row in csv.DictReader(f):
            installs[row["name"]] = row  # the last row of a name wins (a rerun)
    base = installs.get("base")
    rows = []
    for name in names:
        kind, label, packages = CANDIDATES[name]
        inst = installs.get(name, {})
        python = root / "venvs" / name / "bin" / "python"
        load = os.getloadavg()[0]
        row = {"library": label, "candidate": name, "versions": "",
               "install_s": "", "installed_mb": "", "download_mb": "",
               "agent_steps_per_s": "", "env_only_steps_per_s": "", "extra_mb": "",
               "extra_download_mb": "", "deterministic": "", "load_avg": f"{load:.2f}",
               "notes": ""}
        notes = []
        if inst:
            row["install_s"] = f"{float(inst['download_s']) + float(inst['install_s']):.0f}"
            row["installed_mb"] = int(inst["venv_mb"]) - int(inst["empty_venv_mb"])
            row["download_mb"] = inst["download_mb"]
            if base:
                row["extra_mb"] = int(inst["venv_mb"]) - int(base["venv_mb"])
                row["extra_download_mb"] = int(inst["download_mb"]) - int(base["download_mb"])
            if inst["status"] != "ok":
                notes.append(inst["status"])
        if inst.get("status", "ok") == "ok" and python.exists():
            row["versions"] = _versions(python, packages)
            env = _worker(python, ["--worker", "env", "--seconds", str(env_seconds)],
                          timeout=env_seconds + 600)
            if "error" in env:
                notes.append(f"env: {env['error']}")
            else:
                row["env_only_steps_per_s"] = f"{env['env_only_steps_per_s']:.0f}"
                notes.append(f"env alone: {env['live_steps_per_s']:.0f} live agent-steps/s, "
                             f"{env['resets']} episodes ended in {env_seconds:.0f} s")
            res = _worker(python, ["--worker", kind, "--seconds", str(seconds)],
                          timeout=seconds + 1200)
            if "error" in res:
                notes.append(f"training: {res['error']}")
            else:
                row["agent_steps_per_s"] = f"{res['agent_steps_per_s']:.0f}"
                env_rate = env.get("env_only_steps_per_s")
                share = (f", {100 * res['agent_steps_per_s'] / env_rate:.0f} % of the env "
                         f"alone" if env_rate else "")
                notes.append(f"{res['iterations']} PPO iterations in {res['timed_s']:.0f} s "
                             f"after a {res['warmup_s']:.0f} s warm-up{share}")
            hashes = [_worker(python, ["--worker", kind, "--iterations", "2"], timeout=900)
                      for _ in range(2)]
            if any("error" in h for h in hashes):
                notes.append(f"determinism check: {hashes[0].get('error') or hashes[1]['error']}")
            else:
                row["deterministic"] = ("yes" if hashes[0] == hashes[1] else "no")
            row["load_avg"] += f"-{os.getloadavg()[0]:.2f}"
        rows.append(row)
        row["notes"] = "; ".join(notes)
        print(json.dumps(row), flush=True)
    with open(out, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--root", type=Path, default=Path("/tmp/fftnav-learn-libraries"))
    ap.add_argument("--seconds", type=float, default=90.0, help="timed training per library (s)")
    ap.add_argument("--env-seconds", type=float, default=30.0, help="env alone per venv (s)")
    ap.add_argument("--out", type=Path, default=HERE.parents[1] / "results/learn_libraries.csv")
    ap.add_argument("--only", nargs="*", choices=list(CANDIDATES), default=list(CANDIDATES))
    ap.add_argument("--worker", choices=["env", *WORKERS])
    ap.add_argument("--profile", type=int, metavar="STEPS", help="profile STEPS env steps")
    ap.add_argument("--iterations", type=int, default=0,
                    help="worker: run N PPO iterations and print the parameters' hash")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="worker env, sb3 or skrl: a config key of the environment "
                         "(e.g. physics_hz=60)")
    ap.add_argument("--threads", type=int, default=1,
                    help="intra-op threads of torch and XLA (default 1: see the module doc)")
    args = ap.parse_args(argv)
    global THREADS, ITERATIONS
    THREADS, ITERATIONS = args.threads, args.iterations
    for item in args.set:
        key, _, value = item.partition("=")
        SETTINGS[key] = float(value)
    os.environ.update(thread_env(THREADS))  # before torch or jax is imported
    if args.profile:
        profile(args.profile)
    elif args.worker == "env":
        print(json.dumps(env_only(args.env_seconds if args.seconds is None else args.seconds)))
    elif args.worker:
        print(json.dumps(WORKERS[args.worker](args.seconds)))
    else:
        side_by_side(args.root, args.seconds, args.env_seconds, args.out, args.only)


if __name__ == "__main__":
    sys.exit(main())

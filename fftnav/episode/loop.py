"""One swarm episode: a world, a decision policy and a seed -> one row per robot.

Ties the stages together: PyBullet swarm (``fftnav.sim``) -> FFT pipeline
(``fftnav.observe.pipeline``)
-> swarm messages (``fftnav.episode.comms``) -> Bug planner with a decision policy
(``fftnav.planning``) -> metrics (``fftnav.metrics``).
"""

from __future__ import annotations

import collections
import dataclasses
import functools
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["EpisodeConfig", "EpisodeResult", "EPISODE_COLUMNS", "episode_csv", "run_episode"]

#: Columns of an episode's per-robot table, in order.
EPISODE_COLUMNS: tuple[str, ...] = (
    "robot",
    "policy",
    "arrived",
    "collided",
    "path_length_m",
    "optimal_length_m",
    "geodesic_length_m",
    "spl",
    "time_s",
    "bytes_sent",
    "messages_sent",
    "decisions_left",
    "decisions_right",
    "decisions_with_neighbours",
    "decisions_flipped_by_neighbours",
    "robot_contacts",
)


@dataclass(frozen=True)
class EpisodeConfig:
    """Every parameter of an episode except the world, the policy and the seed.

    The experiment TOML groups the fields in sections (``SECTIONS``): ``[robot]``,
    ``[sensor]``, ``[comms]``, ``[episode]``.
    """

    # [robot]
    r0_m: float = 0.15
    r_m: float = 0.30
    v_max_mps: float = 0.5
    w_max_radps: float = 1.5
    embodiment: str = "body"
    # [sensor]
    beams: int = 360
    range_m: float = 3.0
    fov_deg: float = 360.0
    blind_deg: float = 15.0
    noise_std_m: float = 0.0
    dropout: float = 0.0
    # [comms]
    comm_range_m: float = 6.0
    packet_loss: float = 0.0
    delay_ticks: int = 0
    broadcast: str = "on_obstacle"
    pose_noise_m: float = 0.0
    # [episode]
    time_limit_s: float = 120.0
    control_hz: float = 10.0
    physics_hz: float = 240.0
    success_radius_m: float = 0.3

    SECTIONS: dict[str, tuple[str, ...]] = field(
        default_factory=lambda: {
            "robot": ("r0_m", "r_m", "v_max_mps", "w_max_radps", "embodiment"),
            "sensor": ("beams", "range_m", "fov_deg", "blind_deg", "noise_std_m", "dropout"),
            "comms": ("comm_range_m", "packet_loss", "delay_ticks", "broadcast", "pose_noise_m"),
            "episode": ("time_limit_s", "control_hz", "physics_hz", "success_radius_m"),
        },
        init=False,
        repr=False,
        compare=False,
    )

    def __post_init__(self) -> None:
        positive = ("r0_m", "r_m", "v_max_mps", "w_max_radps", "range_m", "fov_deg",
                    "comm_range_m", "time_limit_s", "control_hz", "physics_hz",
                    "success_radius_m")
        for name in positive:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                np.isfinite(value) and value > 0
            ):
                raise ValueError(f"{name} must be a finite number > 0, got {name}={value!r}")
        for name in ("blind_deg", "noise_std_m", "pose_noise_m"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                np.isfinite(value) and value >= 0
            ):
                raise ValueError(f"{name} must be a finite number >= 0, got {name}={value!r}")
        for name in ("dropout", "packet_loss"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                0 <= value < 1
            ):
                raise ValueError(f"{name} must be in [0, 1), got {name}={value!r}")
        for name, low in (("beams", 8), ("delay_ticks", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise ValueError(f"{name} must be an integer >= {low}, got {name}={value!r}")
        if self.r_m <= self.r0_m:
            raise ValueError(f"r_m must be > r0_m={self.r0_m!r}, got r_m={self.r_m!r}")
        if self.fov_deg > 360:
            raise ValueError(f"fov_deg must be <= 360, got fov_deg={self.fov_deg!r}")
        if self.embodiment not in ("body", "wheeled"):
            raise ValueError(
                f"embodiment must be 'body' or 'wheeled', got embodiment={self.embodiment!r}"
            )
        if self.broadcast not in ("on_obstacle", "every_tick"):
            raise ValueError(
                f"broadcast must be 'on_obstacle' or 'every_tick', got broadcast={self.broadcast!r}"
            )
        if self.physics_hz < self.control_hz:
            raise ValueError(
                f"physics_hz must be >= control_hz={self.control_hz!r}, "
                f"got physics_hz={self.physics_hz!r}"
            )

    @classmethod
    def from_sections(cls, sections: dict[str, dict[str, Any]]) -> EpisodeConfig:
        """Build from TOML-like sections; an unknown section or key raises ValueError naming it."""
        valid = cls().SECTIONS
        kwargs: dict[str, Any] = {}
        for name, values in sections.items():
            if name not in valid:
                raise ValueError(f"unknown section [{name}]; expected one of {sorted(valid)}")
            for key, value in values.items():
                if key not in valid[name]:
                    raise ValueError(
                        f"unknown key {key!r} in [{name}]; expected one of {list(valid[name])}"
                    )
                kwargs[key] = value
        return cls(**kwargs)

    def to_dict(self) -> dict[str, Any]:
        """Flat dictionary of the fields (for CSV metadata and config copies)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.init}


@dataclass
class EpisodeResult:
    """Outcome of one episode: per-robot rows (``EPISODE_COLUMNS``) and trajectories."""

    rows: list[dict[str, Any]]
    #: One (T_i, 3) array of x, y, yaw per robot, sampled at the control rate.
    trajectories: list[np.ndarray]


def _seeds(seed: int) -> tuple[int, np.random.Generator]:
    """Everything random in an episode derives from ``seed``: the simulator's sensor-noise seed
    and the episode's generator (random policy, packet loss, pose noise)."""
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got seed={seed!r}")
    sim_ss, ep_ss = np.random.SeedSequence(int(seed)).spawn(2)
    return int(sim_ss.generate_state(1)[0]), np.random.default_rng(ep_ss)


class _Decider:
    """Computes P_s and the fused P of one robot at decision time, in the goal frame.

    The goal frame is the robot frame rotated by the goal bearing beta, so that the quadrants of
    Fig. 2b and the neighbours' target sector are centred on the goal (docs/planner.md).
    """

    def __init__(self, geometry: Any, cfg: EpisodeConfig, channel: Any, rng: np.random.Generator,
                 full_circle: bool) -> None:
        self.geometry, self.cfg, self.channel, self.rng = geometry, cfg, channel, rng
        self.full_circle = full_circle
        self.tick = 0
        self.poses: np.ndarray = np.zeros((0, 3))
        self.beta: np.ndarray = np.zeros(0)
        self.sigma: dict[int, np.ndarray] = {}
        #: Per robot: fused decisions that used at least one neighbour, and those among them
        #: whose side differs from the robot's own (P_s) side.
        self.with_neighbours: dict[int, int] = collections.Counter()
        self.flipped: dict[int, int] = collections.Counter()

    def _own_sigma(self, i: int) -> np.ndarray:
        from fftnav.observe.fusion import rotate_sigma

        return rotate_sigma(self.sigma[i], -float(self.beta[i]))

    def own_probability(self, i: int) -> float:
        from fftnav.observe.compress import quadrant_areas
        from fftnav.observe.fusion import own_probability

        x0 = quadrant_areas(self._own_sigma(i), alpha_rad=self.geometry.alpha_rad,
                            range_m=self.cfg.range_m, full_circle=self.full_circle)
        return float(own_probability(x0))

    def fused_probability(self, i: int) -> float:
        from fftnav.observe.codec import decode_message
        from fftnav.observe.fusion import decide_turn

        packets = self.channel.inbox(i, tick=self.tick, max_age_ticks=int(self.cfg.control_hz))
        frame = float(self.poses[i, 2] + self.beta[i])  # goal-frame heading in the world
        c, s = np.cos(frame), np.sin(frame)
        neighbours, rel = [], []
        for pkt in packets:
            sig, is_min = decode_message(pkt.payload, range_m=self.cfg.range_m)
            d = np.asarray(pkt.sender_pose[:2]) - self.poses[i, :2]
            if self.cfg.pose_noise_m > 0:
                d = d + self.rng.normal(0.0, self.cfg.pose_noise_m, 2)
            rel.append((c * d[0] + s * d[1], -s * d[0] + c * d[1], pkt.sender_pose[2] - frame))
            neighbours.append((sig, is_min))
        decision = decide_turn(
            self._own_sigma(i), neighbours=neighbours, rel_poses=np.array(rel).reshape(-1, 3),
            target_rad=0.0, geometry=self.geometry, range_m=self.cfg.range_m,
            max_range_m=self.cfg.comm_range_m, full_circle=self.full_circle,
        )
        if (decision.sides != 0).any():
            self.with_neighbours[i] += 1
            self.flipped[i] += decision.turn_left != (decision.p_s > 0.5)
        return decision.p


@functools.lru_cache(maxsize=8)
def _reference_lengths(world_json: str, r0_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid A* and geodesic lengths of a world's robots, cached: every policy run on the same map
    in this process reuses them (they take about a second or two per 20 m x 20 m map)."""
    from fftnav.planning.reference import optimal_lengths
    from fftnav.world import World

    return optimal_lengths(World.from_json(world_json), r0_m=r0_m)


def run_episode(
    world: Any,
    policy: str,
    *,
    seed: int = 0,
    config: EpisodeConfig | None = None,
    gui: bool = False,
) -> EpisodeResult:
    """Run every robot of ``world`` to its goal under decision ``policy``.

    Parameters
    ----------
    world : fftnav.world.model.World
        Obstacles, starts and goals (one robot per start).
    policy : str
        A registered decision policy (:data:`fftnav.planning.policies.POLICIES`).
    seed : int
        Episode seed: sensor noise, packet loss, pose noise and the ``random`` policy all derive
        from it. The world has its own seed.
    config : EpisodeConfig, optional
        Robot, sensor, communication and episode parameters (default: the paper's setting).
    gui : bool
        Open the PyBullet GUI.

    Returns
    -------
    EpisodeResult
        One row per robot (``EPISODE_COLUMNS``; ``robot`` is the index in the world's starts)
        and the trajectories sampled at the control rate.

    Notes
    -----
    Each control tick: the lidar scans of the active robots go through the FFT pipeline in one
    batched call; the Bug planner (``docs/planner.md``) turns safe masks into commands and asks
    the policy for a side when a goal direction is blocked; robots that met an obstacle broadcast
    their compact message (fusion only); the simulator advances one control period. A robot
    within ``success_radius_m`` of its goal has arrived, one touching an obstacle has failed;
    either is parked (taken out of the world). Metrics come from :mod:`fftnav.metrics` applied
    to the trajectories.
    """
    from fftnav import metrics
    from fftnav.episode.comms import Channel
    from fftnav.observe.geometry import RobotGeometry
    from fftnav.observe.pipeline import Pipeline
    from fftnav.planning.bug import BugPlanner, PlannerParams
    from fftnav.planning.policies import DecisionContext, get_policy
    from fftnav.sim.swarm import SimConfig, SwarmSim

    cfg = config or EpisodeConfig()
    pol = get_policy(policy)
    sim_seed, rng = _seeds(seed)
    geometry = RobotGeometry(r0_m=cfg.r0_m, r_m=cfg.r_m)
    fov_rad = float(np.radians(cfg.fov_deg))
    pipe = Pipeline(geometry, beams=cfg.beams, fov_rad=fov_rad, range_m=cfg.range_m,
                    blind_rad=float(np.radians(cfg.blind_deg)))
    n = len(world.starts)
    goals = np.asarray(world.goals, dtype=np.float64)
    channel = Channel(n, range_m=cfg.comm_range_m, loss=cfg.packet_loss,
                      delay_ticks=cfg.delay_ticks, rng=rng)
    decider = _Decider(geometry, cfg, channel, rng, pipe.bank.full_circle)

    def decide(i: int) -> int:
        ctx = DecisionContext(i, lambda: decider.own_probability(i),
                              lambda: decider.fused_probability(i), rng)
        return pol.decide(ctx)

    planner = BugPlanner(n, l_th_m=geometry.l_th_m, r0_m=cfg.r0_m, fov_rad=fov_rad, decide=decide,
                         params=PlannerParams(v_max_mps=cfg.v_max_mps, w_max_radps=cfg.w_max_radps,
                                              control_hz=cfg.control_hz))
    sim_cfg = SimConfig(r0_m=cfg.r0_m, v_max=cfg.v_max_mps, w_max=cfg.w_max_radps,
                        physics_hz=cfg.physics_hz, control_hz=cfg.control_hz, beams=cfg.beams,
                        range_m=cfg.range_m, fov_deg=cfg.fov_deg, blind_deg=cfg.blind_deg,
                        noise_std_m=cfg.noise_std_m, dropout=cfg.dropout,
                        embodiment=cfg.embodiment)
    optimal, geodesic = _reference_lengths(world.to_json(), cfg.r0_m)  # unreachable: fail early
    active = np.ones(n, dtype=bool)
    collided = np.zeros(n, dtype=bool)
    robot_contacts = np.zeros(n, dtype=np.int64)
    in_contact = np.zeros(n, dtype=bool)
    max_ticks = int(round(cfg.time_limit_s * cfg.control_hz))
    with SwarmSim(world, config=sim_cfg, gui=gui) as sim:
        obs = sim.reset(seed=sim_seed)
        traj = [[obs.poses[i].copy()] for i in range(n)]
        for tick in range(max_ticks):
            idx = np.flatnonzero(active)
            if idx.size == 0:
                break
            res = pipe.process(obs.scans[idx], with_p_s=False)
            safe = np.zeros((n, cfg.beams), dtype=bool)
            y1 = np.zeros((n, cfg.beams))
            ranges = np.zeros((n, cfg.beams))
            safe[idx], y1[idx] = res.safe_mask, res.y1
            ranges[idx] = pipe.normalise(obs.scans[idx]) * cfg.range_m
            channel.deliver(tick)
            delta = goals - obs.poses[:, :2]
            decider.tick, decider.poses = tick, obs.poses
            decider.beta = np.arctan2(delta[:, 1], delta[:, 0]) - obs.poses[:, 2]
            decider.sigma = dict(zip(idx.tolist(), res.sigma, strict=True))
            commands, blocked = planner.step(obs.time_s, obs.poses, goals, safe, ranges, y1)
            if pol.uses_messages:
                senders = idx if cfg.broadcast == "every_tick" else idx[blocked[idx]]
                for j, i in enumerate(idx):
                    if i in senders:
                        channel.broadcast(int(i), res.messages[j], tick=tick, poses=obs.poses,
                                          active=active)
            obs = sim.step(commands)
            robot_contacts += obs.robot_contact & active & ~in_contact  # count contact onsets
            in_contact = obs.robot_contact & active
            for i in idx:
                traj[i].append(obs.poses[i].copy())
                hit = bool(obs.obstacle_contact[i])
                home = np.hypot(*(obs.poses[i, :2] - goals[i])) <= cfg.success_radius_m
                if hit or home:
                    collided[i] = hit
                    active[i] = False
                    planner.finish(int(i))
                    sim.park(int(i))
    trajectories = [np.array(t) for t in traj]
    dt = 1.0 / cfg.control_hz
    rows = []
    for i in range(n):
        ok = metrics.arrived(trajectories[i][:, :2], goals[i], dt_s=dt, collided=bool(collided[i]),
                             success_radius_m=cfg.success_radius_m, time_limit_s=cfg.time_limit_s)
        length = metrics.path_length_m(trajectories[i][:, :2])
        rows.append({
            "robot": i,
            "policy": policy,
            "arrived": ok,
            "collided": bool(collided[i]),
            "path_length_m": length,
            "optimal_length_m": float(optimal[i]),
            "geodesic_length_m": float(geodesic[i]),
            "spl": float(metrics.spl_terms([ok], [length], [optimal[i]])[0]),
            "time_s": metrics.time_to_goal_s(trajectories[i][:, :2], goals[i], dt_s=dt,
                                             success_radius_m=cfg.success_radius_m)
            if ok else float("nan"),
            "bytes_sent": int(channel.bytes_sent[i]),
            "messages_sent": int(channel.messages_sent[i]),
            "decisions_left": int(planner.decisions[i, 0]),
            "decisions_right": int(planner.decisions[i, 1]),
            "decisions_with_neighbours": decider.with_neighbours[i],
            "decisions_flipped_by_neighbours": decider.flipped[i],
            "robot_contacts": int(robot_contacts[i]),
        })
    return EpisodeResult(rows=rows, trajectories=trajectories)


def episode_csv(
    rows: list[dict[str, Any]], *, columns: tuple[str, ...] = EPISODE_COLUMNS, header: bool = True
) -> str:
    """Rows as CSV text: ``columns`` in order, booleans ``true``/``false``, floats ``%.6f``
    (fixed, so the same episode gives byte-identical files), NaN as an empty field."""

    def cell(value: Any) -> str:
        if isinstance(value, (bool, np.bool_)):
            return "true" if value else "false"
        if isinstance(value, (float, np.floating)):
            return "" if np.isnan(value) else f"{value:.6f}"
        return str(value)

    lines = [",".join(columns)] if header else []
    lines += [",".join(cell(row[c]) for c in columns) for row in rows]
    return "\n".join(lines) + "\n"

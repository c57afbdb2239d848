"""Figures quoted in docs/simulation.md, measured again on this machine.

Run: ``.venv/bin/python experiments/sim_measurements.py`` (about 30 s on one core). Prints:

1. lidar accuracy: |Bullet - analytic| range on every ray of 15 random free poses, rocky
   (triangle meshes of the rocks) and forest (64-gon prisms around the trunks: against the
   prisms and against the trunks' circles);
2. the share of cast rays (after culling) that return a hit, in the 20 s speed-bench drive;
3. one physics step of 15 body robots in the rocky world, as built (planar: no ground, no
   gravity) and with a ground plane and gravity added, timed alternately (best of 7 x 200 steps).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pybullet as p

from fftnav.sim.swarm import SimConfig, SwarmSim
from fftnav.world import (
    Polygon,
    World,
    generate_world,
    raycast_world,
)


def lidar_errors(env: str, *, prisms: bool = False, seed: int = 4,
                 batches: int = 3) -> np.ndarray:
    """|Bullet - analytic| range (m) on every live ray of ``batches`` x 5 random free poses (at
    least 0.16 m from obstacles; the 5 poses of a batch 6.5 m apart, so that the robots do not
    see each other). ``prisms``: the analytic world holds the 64-gons that Bullet is given for
    the trunks instead of their circles."""
    world = generate_world(env, seed)
    shapes = tuple(Polygon(tuple(map(tuple, o.outline().tolist())), o.height)
                   for o in world.obstacles) if prisms else world.obstacles
    rng = np.random.default_rng(1)
    errors = []
    for _ in range(batches):
        chosen: list[tuple[float, float, float]] = []
        while len(chosen) < 5:
            x, y = rng.uniform(1.0, 19.0, 2)
            if world.obstacle_distance([[x, y]])[0] > 0.16 and all(
                    math.hypot(x - a, y - b) > 6.5 for a, b, _ in chosen):
                chosen.append((x, y, rng.uniform(-math.pi, math.pi)))
        poses = np.array(chosen)
        probe = World(env, seed, world.size_m, world.obstacles, poses, poses[:, :2])
        with SwarmSim(probe) as sim:
            sim.lidar.cull = False
            scans = sim.reset(seed=0).scans
            live = sim.lidar.live
            angles = poses[:, 2:3] + sim.lidar.angles_rad[live]
        oracle = World(env, seed, world.size_m, shapes, poses, poses[:, :2])
        expected = raycast_world(oracle, poses[:, :2], angles, 3.0)
        errors.append(np.abs(scans[:, live] - expected).ravel())
    return np.concatenate(errors)


def hit_share(env: str, *, seconds: float = 20.0, seed: int = 0) -> float:
    """Share of the rays the lidar casts (those left after culling, ``Lidar.rays_cast``) that
    return a hit, in the speed bench's drive (random arcs, new commands every tick). Culling is
    exact, so every reading below R comes from a cast ray: hits / cast."""
    world = generate_world(env, seed)
    rng = np.random.default_rng(seed)
    config = SimConfig()
    with SwarmSim(world, config=config) as sim:
        sim.reset(seed=seed)
        lidar = sim.lidar
        cast, hits = lidar.rays_cast, 0
        for _ in range(round(seconds * config.control_hz)):
            obs = sim.step(np.c_[rng.uniform(0, config.robot.v_max_mps, 15),
                                 rng.uniform(-1, 1, 15) * config.robot.w_max_radps])
            hits += int((obs.scans[:, lidar.live] < lidar.range_m * (1.0 - 1e-9)).sum())
        return hits / (lidar.rays_cast - cast)


def physics_step_us(*, repeats: int = 7, steps: int = 200) -> tuple[float, float]:
    """One physics step (us) of 15 body robots at rest in the rocky world: as built (planar)
    and with a ground plane under gravity, timed alternately, best of ``repeats``."""
    world = generate_world("rocky", 0)
    sims = [SwarmSim(world), SwarmSim(world)]
    for sim in sims:
        sim.reset(seed=0)
    grounded = sims[1]._client
    plane = p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=grounded),
                              physicsClientId=grounded)
    p.changeDynamics(plane, -1, lateralFriction=0.0, physicsClientId=grounded)
    p.setGravity(0, 0, -9.81, physicsClientId=grounded)
    best = [math.inf, math.inf]
    for _ in range(repeats):
        for k, sim in enumerate(sims):
            tic = time.perf_counter()
            for _ in range(steps):
                p.stepSimulation(physicsClientId=sim._client)
            best[k] = min(best[k], (time.perf_counter() - tic) / steps * 1e6)
    for sim in sims:
        sim.close()
    return best[0], best[1]


def main() -> None:
    rocks = lidar_errors("rocky")
    print(f"lidar, rocky: max |Bullet - analytic| = {rocks.max():.2g} m over {rocks.size} rays")
    prisms, trunks = lidar_errors("forest", prisms=True), lidar_errors("forest")
    print(f"lidar, forest: max |Bullet - analytic 64-gon prisms| = {prisms.max():.2g} m; "
          f"against the circles: {np.mean(trunks > 1e-3):.2%} of {trunks.size} rays off by "
          f"more than 1 mm (grazing rays, up to {trunks.max():.2g} m), 99th percentile "
          f"{np.percentile(trunks, 99) * 1e3:.2f} mm")
    for env in ("forest", "rocky"):
        print(f"speed-bench drive, {env}: {hit_share(env):.1%} of the cast rays return a hit")
    planar, grounded = physics_step_us()
    print(f"one physics step, 15 body robots, rocky: planar {planar:.1f} us, "
          f"with ground plane and gravity {grounded:.1f} us")


if __name__ == "__main__":
    main()

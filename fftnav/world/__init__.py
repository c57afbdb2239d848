"""Worlds: the world model, registered obstacle shapes and world kinds, seeded generation,
exact 2D geometry, occupancy grids and analytic scenes (pure numpy/scipy).

Modules, in dependency order: :mod:`~fftnav.world.obstacles` (shapes), :mod:`~fftnav.world.model`
(``World``, JSON files), :mod:`~fftnav.world.geometry` (analytic ray casts),
:mod:`~fftnav.world.grid` (occupancy grids, reachability, ROS maps), :mod:`~fftnav.world.kinds`
(the kind registry and the built-in kinds), :mod:`~fftnav.world.generate` (``generate_world``),
:mod:`~fftnav.world.scenes` (analytic trunk scans for figures and benchmarks).
"""

from fftnav.world.generate import generate_world, world_parameters
from fftnav.world.geometry import raycast_world
from fftnav.world.grid import OccupancyGrid, occupancy_grid, unreachable_robots, write_ros_map
from fftnav.world.kinds import WORLD_KINDS, get_world_kind, load_preset, world_kinds
from fftnav.world.model import World, load_world, save_world
from fftnav.world.obstacles import SHAPES, Circle, Obstacle, Polygon

__all__ = [
    "SHAPES", "WORLD_KINDS", "Circle", "Obstacle", "OccupancyGrid", "Polygon", "World",
    "generate_world", "get_world_kind", "load_preset", "load_world", "occupancy_grid",
    "raycast_world", "save_world", "unreachable_robots", "world_kinds", "world_parameters",
    "write_ros_map",
]

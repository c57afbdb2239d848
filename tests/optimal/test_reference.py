"""Per-robot optimal lengths of a World (8-connected A* reference and 32-connected geodesic)."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest

from fftnav.optimal import gridsearch
from fftnav.optimal.astar import UnreachableGoalError
from fftnav.optimal.reference import optimal_lengths
from fftnav.world import Circle, Polygon, World, generate_world


def make_world(obstacles, starts, goals, size=(4.0, 4.0)) -> World:
    return World("test", 0, size, tuple(obstacles), np.array(starts, float), np.array(goals, float))


def test_detour_around_a_trunk_matches_tangent_arc_tangent():
    # Robot 0 must pass a 0.5 m trunk (inflated by r0 = 0.15 m); robot 1 has a clear straight run.
    world = make_world(
        [Circle((2.0, 2.0), 0.5, 2.0)],
        starts=[[2.025, 0.525, 0.0], [0.525, 0.525, 0.0]],
        goals=[[2.025, 3.525], [0.525, 3.525]],
    )
    astar_m, geodesic_m = optimal_lengths(world, r0_m=0.15)
    rho, d = 0.65, 1.5  # inflated radius; start and goal 1.5 m from the centre, opposite sides
    exact = 2 * math.sqrt(d**2 - rho**2) + rho * (math.pi - 2 * math.acos(rho / d))
    assert geodesic_m[0] == pytest.approx(exact, rel=0.015)
    assert exact * 1.03 < astar_m[0] < exact * 1.09  # the 8-connected excess
    np.testing.assert_allclose([astar_m[1], geodesic_m[1]], 3.0, atol=1e-9)


def test_generated_forest_lengths_are_consistent():
    world = generate_world("forest", 1, size_m=(6.0, 6.0), robots=3, start_y_m=0.5, goal_y_m=5.5,
                           strip_half_width_m=0.4)
    astar_m, geodesic_m = optimal_lengths(world, r0_m=0.15)
    euclid = np.hypot(*(world.goals - world.starts[:, :2]).T)
    cell_diag = 0.05 * math.sqrt(2)  # positions snap to cell centres
    assert np.all(geodesic_m >= euclid - cell_diag)
    assert np.all(astar_m >= geodesic_m - 1e-9)
    assert np.all(astar_m <= geodesic_m * 1.083 + cell_diag)


def test_wall_makes_goal_unreachable():
    wall = Polygon(((0.0, 1.9), (4.0, 1.9), (4.0, 2.1), (0.0, 2.1)), 2.0)
    world = make_world([wall], starts=[[1.0, 0.5, 0.0]], goals=[[1.0, 3.5]])
    with pytest.raises(UnreachableGoalError, match=r"goal cell \(70, 20\) is unreachable from start cell \(10, 20\)"):
        optimal_lengths(world, r0_m=0.15)


def test_start_inside_inflated_obstacle_is_an_error():
    world = make_world([Circle((1.0, 1.0), 0.3, 2.0)], starts=[[1.0, 1.4, 0.0]], goals=[[3.0, 3.0]])
    with pytest.raises(ValueError, match=r"start of robot 0 at \[1.0, 1.4\] m lies in an occupied cell of the inflated grid"):
        optimal_lengths(world, r0_m=0.15)
    with pytest.raises(ValueError, match=r"r0_m must be a finite number >= 0, got r0_m=-1"):
        optimal_lengths(world, r0_m=-1)


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "fftnav", "bench", "optimal", *args],
        capture_output=True, text=True, timeout=120,
    )


def test_cli_bench_optimal_times_both_solvers_and_they_agree():
    proc = run_cli("--json", "--env", "rocky", "--seed", "2")
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert result["robots"] == 15 and result["grid_cells"] == "400x400"
    assert result["max_length_diff_cells"] < 1e-6
    assert result["euclidean_m"] <= result["geodesic_m"] <= result["astar_m"]
    assert all(result[k] > 0 for k in ("heapq_astar_s", "csgraph_8_s", "csgraph_32_s"))
    if gridsearch.AVAILABLE:  # the compiled A* the references use: same lengths
        assert result["compiled_max_rel_diff"] < 1e-12
        assert result["compiled_astar_8_s"] > 0 and result["compiled_astar_32_s"] > 0


def test_cli_bench_optimal_bad_r0_exits_2_with_one_line():
    proc = run_cli("--r0", "-1")
    assert proc.returncode == 2
    assert proc.stderr.strip() == "fftnav bench: error: r0_m must be a finite number >= 0, got r0_m=-1.0"
    assert "Traceback" not in proc.stderr


def test_the_optimal_reference_bench_is_named_after_its_package():
    listed = subprocess.run([sys.executable, "-m", "fftnav", "bench", "--help"],
                            capture_output=True, text=True, timeout=120)
    assert listed.returncode == 0
    assert re.search(r"^\s+optimal\s+time of the optimal-path reference", listed.stdout, re.M)
    gone = subprocess.run([sys.executable, "-m", "fftnav", "bench", "planning"],
                          capture_output=True, text=True, timeout=120)
    assert gone.returncode == 2 and "invalid choice: 'planning'" in gone.stderr

"""World generation, JSON validation and the analytic ray-cast oracle (fftnav.world.model)."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

from fftnav.world import (
    Circle,
    Polygon,
    World,
    generate_world,
    load_preset,
    load_world,
    raycast_world,
    save_world,
    world_parameters,
)
from fftnav.world.grid import unreachable_robots


def _across(polygon):
    """Largest distance between two vertices of a polygon (m)."""
    v = np.asarray(polygon.vertices)
    return np.max(np.hypot(*(v[:, None] - v[None]).transpose(2, 0, 1)))


def _extent_y(obstacle):
    if isinstance(obstacle, Circle):
        return obstacle.center[1] - obstacle.radius, obstacle.center[1] + obstacle.radius
    ys = [v[1] for v in obstacle.vertices]
    return min(ys), max(ys)


@pytest.mark.parametrize("env", ["forest", "rocky"])
def test_density_and_clear_strips_hold_for_50_seeds(env):
    preset = load_preset(env)
    w, h = preset["size_m"]
    for seed in range(50):
        world = generate_world(env, seed)
        assert len(world.obstacles) == round(preset["density_per_m2"] * w * h) == 80
        low = preset["start_y_m"] + preset["strip_half_width_m"]
        high = preset["goal_y_m"] - preset["strip_half_width_m"]
        for obstacle in world.obstacles:
            y0, y1 = _extent_y(obstacle)
            assert low <= y0 and y1 <= high
        # every robot fits: starts at least 2 r0 apart, clear of obstacles by r0
        assert np.all(np.diff(world.starts[:, 0]) > 2 * preset["robot_radius_m"])
        clearance = world.obstacle_distance(np.r_[world.starts[:, :2], world.goals])
        assert clearance.min() > preset["robot_radius_m"]
        if env == "rocky":  # rocks (5- to 9-gons; walls are rectangles) are 0.3 to 1.2 m across
            across = [_across(o) for o in world.obstacles if len(o.vertices) > 4]
            assert 0.3 - 1e-3 <= min(across) and max(across) <= 1.2 + 1e-3, seed


def test_generated_shapes_match_their_presets():
    forest = generate_world("forest", 3)
    radii = [o.radius for o in forest.obstacles]
    assert all(isinstance(o, Circle) for o in forest.obstacles)
    assert 0.1 <= min(radii) and max(radii) <= 0.3
    rocky = generate_world("rocky", 3)
    sides = {len(o.vertices) for o in rocky.obstacles}
    assert all(isinstance(o, Polygon) for o in rocky.obstacles)
    assert sides <= {4, 5, 6, 7, 8, 9} and len(sides & {5, 6, 7, 8, 9}) >= 3
    across = [_across(o) for o in rocky.obstacles if len(o.vertices) > 4]
    assert 0.3 - 1e-3 <= min(across) and max(across) <= 1.2 + 1e-3


def test_same_seed_same_world_and_json_round_trip(tmp_path):
    a, b = generate_world("rocky", 11), generate_world("rocky", 11)
    assert a.to_json() == b.to_json()
    assert a.to_json() != generate_world("rocky", 12).to_json()
    save_world(a, tmp_path / "w.json")
    assert load_world(tmp_path / "w.json").to_json() == a.to_json()


def test_overrides_change_size_density_and_robots():
    world = generate_world("forest", 0, size_m=[30.0, 30.0], density_per_m2=0.1, robots=10)
    assert world.size_m == (30.0, 30.0)
    assert len(world.obstacles) == 90 and len(world.starts) == 10
    with pytest.raises(ValueError, match=r"unknown world parameter\(s\) \['colour'\]"):
        generate_world("forest", 0, colour="red")
    with pytest.raises(ValueError, match=r"env must be a registered world kind \(.forest., .rocky., "
                                         r".walls., .traps.\), got env=.desert."):
        generate_world("desert", 0)
    with pytest.raises(ValueError, match="seed must be an integer >= 0, got seed=-1"):
        generate_world("forest", -1)
    with pytest.raises(ValueError, match="robots=100 robots of radius"):
        generate_world("forest", 0, robots=100)


@pytest.mark.parametrize(("override", "match"), [
    ({"size_m": "big"}, r"size_m must be a list of 2 numbers, got size_m='big'"),
    ({"size_m": [20.0, math.nan]}, r"size_m\[1\] must be a finite number, got size_m\[1\]=nan"),
    ({"robots": 1.5}, r"robots must be an integer, got robots=1\.5"),
    ({"density_per_m2": "x"}, r"density_per_m2 must be a finite number, got density_per_m2='x'"),
    ({"boundary": 1}, r"boundary must be str, got boundary=1"),
])
def test_an_override_must_have_the_type_of_the_preset_value(override, match):
    with pytest.raises(ValueError, match=match):
        world_parameters("forest", **override)


def test_unreachable_goal_is_detected():
    wall = Polygon(((0.0, 9.0), (20.0, 9.0), (20.0, 9.5), (0.0, 9.5)), 1.0)
    starts = np.array([[5.0, 1.0, 0.0], [5.0, 12.0, 0.0]])
    world = World("rocky", 0, (20.0, 20.0), (wall,), starts, np.array([[5.0, 19.0], [6.0, 19.0]]))
    assert unreachable_robots(world, radius_m=0.15) == [0]
    gap = (Polygon(((0.0, 9.0), (9.9, 9.0), (9.9, 9.5), (0.0, 9.5)), 1.0),
           Polygon(((10.2, 9.0), (20.0, 9.0), (20.0, 9.5), (10.2, 9.5)), 1.0))
    narrow = World("rocky", 0, (20.0, 20.0), gap, starts, world.goals)
    assert unreachable_robots(narrow, radius_m=0.15) == [0]  # 0.3 m gap, robot 0.3 m wide
    assert unreachable_robots(narrow, radius_m=0.1) == []


# ----------------------------------------------------------------------------- validation

GOOD = {
    "env": "rocky", "seed": 1, "size": [10, 10],
    "obstacles": [{"shape": "circle", "center": [5, 5], "radius": 0.3, "height": 2},
                  {"shape": "polygon", "vertices": [[1, 1], [2, 1], [2, 2], [1, 2]], "height": 1}],
    "starts": [[1, 0.5, 0]], "goals": [[9, 9.5]],
}


def _with(path, value):
    data = json.loads(json.dumps(GOOD))
    *head, last = path
    target = data
    for key in head:
        target = target[key]
    if value is KeyError:
        del target[last]
    else:
        target[last] = value
    return json.dumps(data)


@pytest.mark.parametrize(("path", "value", "message"), [
    (["starts"], KeyError, "world file is missing key 'starts'"),
    (["obstacles", 0, "radius"], KeyError, r"obstacles\[0\]: missing key 'radius'"),
    (["obstacles", 0, "radius"], -0.2, r"obstacles\[0\].radius must be a finite number in \(0, 1000\], got obstacles\[0\].radius=-0.2"),
    (["obstacles", 0, "center"], [9.9, 5], r"obstacles\[0\]: obstacle lies \(partly\) outside "
     r"the world \[0, 10\] x \[0, 10\]: it spans \[9.6, 10.2\] x \[4.7, 5.3\]"),
    (["obstacles", 0, "height"], KeyError, r"obstacles\[0\]: missing key 'height'"),
    (["obstacles", 1, "height"], KeyError, r"obstacles\[1\]: missing key 'height'"),
    (["starts", 0], [1.5, 1.5, 0], r"starts\[0\] lies inside obstacles\[1\], got \[1.5, 1.5, 0.0\]"),
    (["goals", 0], [5.3, 5], r"goals\[0\] lies inside obstacles\[0\], got \[5.3, 5.0\]"),
    (["goals", 0], [2, 1.5], r"goals\[0\] lies inside obstacles\[1\]"),
    (["obstacles", 1, "vertices"], [[1, 1], [3, 1], [2, 1.2], [3, 3], [1, 3]],
     r"obstacles\[1\].vertices: polygon is not convex"),
    (["obstacles", 1, "vertices"], [[5, 9], [6.2, 5.3], [3, 7.6], [7, 7.6], [3.8, 5.3]],
     r"obstacles\[1\].vertices: polygon is self-intersecting"),
    (["obstacles", 1, "vertices"], [[1, 1], [2, 1]], r"obstacles\[1\].vertices must be a list of >= 3"),
    (["obstacles", 1, "vertices"], [[1, 1], [-2, 1], [1, 2]], r"obstacles\[1\]: obstacle lies"),
    (["obstacles", 1, "shape"], "star", r"obstacles\[1\]: shape must be one of \['circle', 'polygon'\]"),
    (["obstacles", 0, "height"], 0, r"obstacles\[0\].height must be a finite number > 0"),
    (["size"], [10], r"size must be a list of 2 numbers"),
    (["goals"], [[1, 2], [3, 4]], "starts and goals must have the same length"),
    (["starts", 0], [11, 1, 0], r"starts\[0\] lies outside the world"),
    (["goals", 0], [1, "x"], r"goals\[0\]\[1\] must be a finite number"),
    (["seed"], 1.5, "seed must be an integer"),
    (["edge"], "walls", r"world file has an unknown key 'edge'; its keys are \['env', .*'boundary'"),
    (["boundary"], "fence", r"boundary must be one of \['open', 'walls'\], got boundary='fence'"),
    (["obstacles", 0, "colour"], "red", r"obstacles\[0\]: unknown key 'colour'; a circle has "
     r"the keys \['shape', 'center', 'radius', 'height'\]"),
])
def test_malformed_world_files_are_refused(path, value, message):
    assert World.from_json(json.dumps(GOOD)).obstacles[0] == Circle((5.0, 5.0), 0.3, 2.0)
    with pytest.raises(ValueError, match=message):
        World.from_json(_with(path, value))


@pytest.mark.parametrize(("path", "value", "message"), [
    (["obstacles", 1, "vertices"], [[1e300, 1], [2, 1e300], [-1e300, -1e300]],
     r"obstacles\[1\].vertices\[0\]\[0\] must be a finite number in \[-1000, 1000\], "
     r"got obstacles\[1\].vertices\[0\]\[0\]=1e\+300$"),
    (["obstacles", 0, "center"], [5, -1e308], r"obstacles\[0\].center\[1\] must be a finite "
     r"number in \[-1000, 1000\]"),
    (["obstacles", 0, "radius"], 1e308, r"obstacles\[0\].radius must be a finite number in "
     r"\(0, 1000\]"),
])
def test_huge_coordinates_are_refused_in_one_line_without_a_warning(path, value, message):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow warning would fail the test
        with pytest.raises(ValueError, match=message):
            World.from_json(_with(path, value))


def test_not_json_and_clockwise_polygons():
    with pytest.raises(ValueError, match="world file: not valid JSON"):
        World.from_json("{")
    world = World.from_json(_with(["obstacles", 1, "vertices"], [[1, 1], [1, 2], [2, 2], [2, 1]]))
    assert world.obstacles[1].vertices == ((2.0, 1.0), (2.0, 2.0), (1.0, 2.0), (1.0, 1.0))


# ----------------------------------------------------------------------------- ray casts


@pytest.mark.parametrize("env", ["forest", "rocky"])
def test_raycast_hits_lie_on_boundaries(env):
    """Oracle: a hit point is on an obstacle boundary and the ray is free just before it."""
    world = generate_world(env, 5)
    rng = np.random.default_rng(7)
    origins = rng.uniform([1, 3], [19, 17], (40, 2))
    origins = origins[world.obstacle_distance(origins) > 0.05]
    angles = rng.uniform(-math.pi, math.pi, (len(origins), 30))
    dist = raycast_world(world, origins, angles, 3.0)
    hit = dist < 3.0
    assert 0.2 < hit.mean() < 0.9
    direction = np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    at = origins[:, None, :] + dist[..., None] * direction
    before = origins[:, None, :] + (dist[..., None] - 1e-3) * direction
    assert np.all(world.obstacle_distance(at[hit]) < 1e-9)
    assert np.all(world.obstacle_distance(before.reshape(-1, 2)) > 0)
    # coarse marching: no obstacle anywhere along a ray shorter than its reported distance
    for f in np.linspace(0.0, 0.99, 25):
        pts = origins[:, None, :] + f * dist[..., None] * direction
        assert np.all(world.obstacle_distance(pts.reshape(-1, 2)) > 0)


def test_raycast_simple_cases_and_errors():
    square = Polygon(((4.0, -1.0), (6.0, -1.0), (6.0, 1.0), (4.0, 1.0)), 1.0)
    tree = Circle((0.0, 2.0), 0.5, 1.0)
    world = World("x", 0, (10.0, 10.0), (square, tree), np.zeros((1, 3)), np.zeros((1, 2)))
    got = raycast_world(world, [[0.0, 0.0], [5.0, 0.0]], [[0.0, math.pi / 2], [0.0, 1.0]], 5.0)
    np.testing.assert_allclose(got, [[4.0, 1.5], [0.0, 0.0]])
    assert tree.distance([[0.0, 0.0]])[0] == pytest.approx(1.5)
    with pytest.raises(ValueError, match=r"origins must have shape \(K, 2\)"):
        raycast_world(world, [0.0, 0.0], [[0.0]], 3.0)
    with pytest.raises(ValueError, match="range_m must be a finite number > 0, got range_m=0"):
        raycast_world(world, [[0.0, 0.0]], [[0.0]], 0)


def test_a_draw_whose_obstacles_do_not_fit_is_redrawn_not_refused():
    # rocky seed 1015: the first draw cannot place its 80th obstacle; the next attempt can
    world = generate_world("rocky", 1015)
    assert len(world.obstacles) == 80
    assert world.to_json() == generate_world("rocky", 1015).to_json()


def test_impossible_density_names_the_parameters():
    with pytest.raises(ValueError, match=r"no world with every obstacle placed and every goal "
                                         r"reachable after max_attempts=2 \(seed=0\); lower "
                                         r"density_per_m2=1\.0 or min_gap_m=0\.1"):
        generate_world("rocky", 0, density_per_m2=1.0, max_attempts=2, placement_tries=50)

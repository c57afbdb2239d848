"""Occupancy grids, cell conventions and ROS map export (fftnav.world.grid)."""

from __future__ import annotations

import numpy as np
import pytest

from fftnav.world import Circle, Polygon, World, generate_world
from fftnav.world.grid import occupancy_grid, write_ros_map


def _world(*obstacles):
    return World("x", 0, (4.0, 2.0), obstacles, np.array([[0.5, 0.5, 0.0]]), np.array([[3.5, 1.5]]))


def test_axis_order_origin_and_cell_round_trip():
    # a small square in the lower-right area of a wide world
    og = occupancy_grid(_world(Polygon(((3.0, 0.2), (3.5, 0.2), (3.5, 0.7), (3.0, 0.7)), 1.0)),
                        resolution_m=0.1)
    assert og.grid.shape == (20, 40) and og.origin_m == (0.0, 0.0)
    rows, cols = np.nonzero(og.grid)
    assert (rows.min(), rows.max(), cols.min(), cols.max()) == (2, 6, 30, 34)
    centres = og.cell_to_world(rows, cols)
    np.testing.assert_allclose(centres[0], [3.05, 0.25])
    back = og.world_to_cell(centres)
    np.testing.assert_array_equal(back[0], rows)
    np.testing.assert_array_equal(back[1], cols)


@pytest.mark.parametrize("inflate", [0.0, 0.15])
def test_cells_match_exact_distances(inflate):
    world = generate_world("rocky", 2)
    og = occupancy_grid(world, resolution_m=0.1, inflate_m=inflate)
    rows, cols = np.indices(og.grid.shape)
    dist = world.obstacle_distance(og.cell_to_world(rows.ravel(), cols.ravel()))
    np.testing.assert_array_equal(og.grid.ravel(), dist <= inflate)
    disc = occupancy_grid(_world(Circle((2.0, 1.0), 0.5, 1.0)), resolution_m=0.01)
    assert disc.grid.sum() * 1e-4 == pytest.approx(np.pi * 0.25, rel=0.01)


def test_ros_map_pair(tmp_path):
    og = occupancy_grid(_world(Circle((0.5, 1.5), 0.3, 1.0)), resolution_m=0.05)
    yaml, pgm = write_ros_map(og, tmp_path / "map")
    text = yaml.read_text()
    assert "image: map.pgm" in text and "resolution: 0.05" in text
    assert "origin: [0.0, 0.0, 0.0]" in text
    raw = pgm.read_bytes()
    header = b"P5\n80 40\n255\n"
    assert raw.startswith(header)
    img = np.frombuffer(raw[len(header):], dtype=np.uint8).reshape(40, 80)
    # image row 0 is the top of the map: the obstacle at y = 1.5 is in the upper half
    np.testing.assert_array_equal(img == 0, np.flipud(og.grid))
    assert (img[:20] == 0).sum() > 0 and (img[20:] == 0).sum() == 0
    assert set(np.unique(img)) == {0, 254}


def test_errors_name_the_parameter():
    world = _world()
    with pytest.raises(ValueError, match=r"resolution_m must be a finite number in \(0, 2\], got "
                                         "resolution_m=0"):
        occupancy_grid(world, resolution_m=0)
    with pytest.raises(ValueError, match=r"inflate_m must be a finite number in \[0, 4\], got "
                                         "inflate_m=-1"):
        occupancy_grid(world, inflate_m=-1)
    with pytest.raises(ValueError, match=r"grid cells \(world size / resolution_m\): "
                                         "8,000,000,000,000 estimated, above the limit of "
                                         "100,000,000; raise resolution_m"):
        occupancy_grid(world, resolution_m=1e-6)

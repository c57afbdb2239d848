"""Batched ray casts above Bullet's batch limit (fftnav.sim.rays)."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from fftnav.sim.rays import MAX_RAYS, cast_rays


@pytest.fixture()
def client():
    cid = p.connect(p.DIRECT)
    yield cid
    p.disconnect(physicsClientId=cid)


def test_more_rays_than_one_batch_come_back_in_order_at_the_analytic_fraction(client):
    ground = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=client)  # z = 0, exact
    p.createMultiBody(0, ground, physicsClientId=client)
    rng = np.random.default_rng(0)
    n = 2 * MAX_RAYS + 7  # three chunks, the last one short
    starts = np.c_[rng.uniform(-5, 5, (n, 2)), rng.uniform(0.5, 2.0, n)]
    ends = np.c_[rng.uniform(-5, 5, (n, 2)), rng.uniform(-2.0, 1.0, n)]
    got = cast_rays(client, starts, ends)
    z0, z1 = starts[:, 2], ends[:, 2]
    expected = np.where(z1 < 0, z0 / (z0 - z1), 1.0)  # where the ray crosses z = 0, else a miss
    assert got.shape == (n,) and 0.3 < (expected < 1).mean() < 0.9
    np.testing.assert_allclose(got, expected, atol=1e-6)
    assert MAX_RAYS == 16_383  # a batch of 16,384 rays returns nothing, a larger one raises


def test_the_mask_selects_the_bodies_and_shapes_are_checked(client):
    box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.5, 0.5, 0.5], physicsClientId=client)
    body = p.createMultiBody(0, box, basePosition=[2, 0, 0], physicsClientId=client)
    p.setCollisionFilterGroupMask(body, -1, 2, 1, physicsClientId=client)
    starts, ends = np.zeros((2, 3)), np.array([[4.0, 0, 0], [0, 4.0, 0]])
    np.testing.assert_allclose(cast_rays(client, starts, ends, mask=2), [1.5 / 4, 1.0])
    np.testing.assert_array_equal(cast_rays(client, starts, ends, mask=4), [1.0, 1.0])
    with pytest.raises(ValueError, match=r"starts and ends must both have shape \(N, 3\), got "
                                         r"starts.shape=\(2, 3\), ends.shape=\(2, 2\)"):
        cast_rays(client, starts, ends[:, :2])

"""collab: passage messages (<= 64 bytes), the passage board, determinism in episodes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fftnav.config import EpisodeConfig, SwarmConfig
from fftnav.episode import episode_csv, run_episode
from fftnav.episode.collab import (
    MAX_MESSAGE_BYTES,
    MAX_PASSAGES_PER_MESSAGE,
    PassageBoard,
    decode_passages,
    encode_passages,
)
from fftnav.world import Polygon, World

UP = math.pi / 2


def test_messages_round_trip_to_the_centimetre_and_stay_within_64_bytes():
    rng = np.random.default_rng(0)
    for n in range(MAX_PASSAGES_PER_MESSAGE + 1):
        pts = rng.uniform(-300, 300, (n, 2))
        data = encode_passages(pts)
        assert len(data) == 1 + 4 * n <= MAX_MESSAGE_BYTES
        np.testing.assert_allclose(decode_passages(data), pts, atol=0.005 + 1e-9)
    with pytest.raises(ValueError, match="points must hold at most 12 passages"):
        encode_passages(np.zeros((13, 2)))
    with pytest.raises(ValueError, match=r"points must lie within \+-327.67 m"):
        encode_passages(np.array([[400.0, 0.0]]))
    with pytest.raises(ValueError, match="data must be a passage message"):
        decode_passages(b"\x02\x00")
    board = PassageBoard(1)
    for k in range(40):  # a board of many passages still sends one message of <= 64 bytes
        board.add(0, (k * 1.0, 3.0))
    assert len(board.message(0)) <= MAX_MESSAGE_BYTES
    assert decode_passages(board.message(0))[-1].tolist() == [39.0, 3.0]  # the newest


def test_board_merges_close_passages_and_picks_the_side_of_the_best_way():
    board = PassageBoard(2)
    assert board.side(0, (5.0, 2.0), (5.0, 12.0)) is None  # knows nothing
    assert board.add(0, (9.0, 6.0)) and not board.add(0, (9.2, 6.1))  # merged
    assert board.version.tolist() == [1, 0]
    assert board.side(0, (5.0, 2.0), (5.0, 12.0)) == -1  # x = 9 is right of a robot going up
    board.add(0, (3.0, 6.0))  # closer to the straight way: left wins
    assert board.side(0, (5.0, 2.0), (5.0, 12.0)) == 1
    assert board.side(0, (5.0, 8.0), (5.0, 12.0)) is None  # both behind the robot
    board.add(1, (5.2, 6.0))
    assert board.side(1, (5.0, 2.0), (5.0, 12.0)) is None  # straight ahead: no side
    board.receive(1, 0, 7, board.message(0))
    assert len(board.known[1]) == 3
    board.known[1].clear()
    board.receive(1, 0, 7, board.message(0))  # the same packet again is not read twice
    assert board.known[1] == []


def _barrier_world():
    """A wall across the map with one gap on the right; four robots below it."""
    walls = (Polygon(((0.0, 4.0), (7.0, 4.0), (7.0, 4.3), (0.0, 4.3)), 1.0),
             Polygon(((8.5, 4.0), (10.0, 4.0), (10.0, 4.3), (8.5, 4.3)), 1.0))
    xs = [1.5, 3.5, 5.5, 7.5]
    return World("t", 0, (10.0, 9.0), walls, np.array([[x, 1.0, UP] for x in xs]),
                 np.array([[x, 8.0] for x in xs]), "walls")


def test_collab_episodes_are_deterministic_and_share_passages():
    world = _barrier_world()
    cfg = SwarmConfig(episode=EpisodeConfig(time_limit_s=60.0, departure="staggered",
                                            stagger_s=4.0)).replace({"packet_loss": 0.3})
    a = run_episode(world, "collab", seed=5, config=cfg)
    b = run_episode(world, "collab", seed=5, config=cfg)
    assert episode_csv(a.rows) == episode_csv(b.rows)
    assert all(np.array_equal(x, y) for x, y in zip(a.trajectories, b.trajectories, strict=True))
    assert sum(r.bytes_sent for r in a.rows) > 0
    assert all(r.bytes_sent <= MAX_MESSAGE_BYTES * r.messages_sent for r in a.rows)
    assert sum(r.arrived for r in a.rows) >= 3

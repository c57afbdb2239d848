import numpy as np
import pytest

from fftnav.episode.comms import Channel


def _poses(*xy):
    return np.array([[x, y, 0.0] for x, y in xy])


def test_range_delay_and_byte_count():
    ch = Channel(3, range_m=5.0, delay_ticks=2, rng=np.random.default_rng(0))
    poses = _poses((0, 0), (4, 0), (6, 0))
    active = np.ones(3, bool)
    ch.broadcast(0, b"abcd", tick=10, poses=poses, active=active)
    ch.deliver(12)
    assert ch.inbox(1, tick=12, max_age_ticks=10) == []  # due at tick 10 + 1 + 2
    ch.deliver(13)
    got = ch.inbox(1, tick=13, max_age_ticks=10)
    assert [p.payload for p in got] == [b"abcd"] and got[0].sender_pose == (0.0, 0.0, 0.0)
    assert ch.inbox(2, tick=13, max_age_ticks=10) == []  # 6 m away: out of range
    assert ch.inbox(0, tick=13, max_age_ticks=10) == []  # no echo to the sender
    assert ch.bytes_sent.tolist() == [4, 0, 0] and ch.messages_sent.tolist() == [1, 0, 0]


def test_newest_packet_per_sender_and_age_limit():
    ch = Channel(2, range_m=5.0, rng=np.random.default_rng(0))
    poses, active = _poses((0, 0), (1, 0)), np.ones(2, bool)
    ch.broadcast(0, b"old", tick=0, poses=poses, active=active)
    ch.broadcast(0, b"new", tick=3, poses=poses, active=active)
    ch.deliver(4)
    assert [p.payload for p in ch.inbox(1, tick=4, max_age_ticks=10)] == [b"new"]
    assert ch.inbox(1, tick=20, max_age_ticks=10) == []


def test_arrived_holds_each_packet_once_at_its_delivery_in_sender_order():
    ch = Channel(4, range_m=5.0, delay_ticks=1, rng=np.random.default_rng(0))
    poses, active = _poses((0, 0), (1, 0), (2, 0), (3, 0)), np.ones(4, bool)
    for sender in (3, 1, 2):
        ch.broadcast(sender, bytes([sender]), tick=5, poses=poses, active=active)
    ch.broadcast(1, b"later", tick=6, poses=poses, active=active)
    ch.deliver(6)
    assert ch.arrived(0) == []
    ch.deliver(7)  # due at 5 + 1 + 1
    assert [(p.sender, p.payload) for p in ch.arrived(0)] == [(1, b"\x01"), (2, b"\x02"),
                                                             (3, b"\x03")]
    assert [p.sender for p in ch.arrived(2)] == [1, 3]
    ch.deliver(8)
    assert [(p.sender, p.payload) for p in ch.arrived(0)] == [(1, b"later")]
    ch.deliver(9)
    assert ch.arrived(0) == [] and len(ch.inbox(0, tick=9, max_age_ticks=10)) == 3


def test_inactive_robots_receive_nothing():
    ch = Channel(2, range_m=5.0, rng=np.random.default_rng(0))
    ch.broadcast(0, b"x", tick=0, poses=_poses((0, 0), (1, 0)), active=np.array([True, False]))
    ch.deliver(1)
    assert ch.inbox(1, tick=1, max_age_ticks=10) == []


def test_packet_loss_rate_is_seeded_and_close_to_nominal():
    def received(seed):
        ch = Channel(2, range_m=5.0, loss=0.3, rng=np.random.default_rng(seed))
        n = 0
        for t in range(4000):
            ch.broadcast(0, b"x", tick=t, poses=_poses((0, 0), (1, 0)), active=np.ones(2, bool))
            ch.deliver(t + 1)
            n += len(ch.inbox(1, tick=t + 1, max_age_ticks=1))
        return n

    assert received(1) == received(1)
    assert abs(received(1) / 4000 - 0.7) < 0.03


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"range_m": 0.0}, r"range_m must be a finite number > 0, got range_m=0.0"),
        ({"range_m": 1.0, "loss": 1.0}, r"loss must be a finite number in \[0, 1\), got loss=1.0"),
        ({"range_m": 1.0, "delay_ticks": -1}, r"delay_ticks must be an integer >= 0, got delay_ticks=-1"),
    ],
)
def test_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Channel(2, rng=np.random.default_rng(0), **kwargs)


def test_each_receiver_places_the_sender_where_locate_says():
    """With a ``locate`` (odometry), each receiver's packet carries the sender as that
    receiver placed it; the lost and the out-of-range get none and no draw is asked for them."""
    ch = Channel(4, range_m=5.0, rng=np.random.default_rng(0))
    poses = _poses((0, 0), (1, 0), (2, 0), (9, 0))
    asked = []

    def locate(sender, receivers, truth):
        asked.append((sender, receivers.tolist()))
        return np.array([[10.0 * r, 0.0, 0.5] for r in receivers])

    ch.broadcast(0, b"x", tick=0, poses=poses, active=np.ones(4, bool), locate=locate)
    ch.deliver(1)
    assert asked == [(0, [1, 2])]
    assert [p.sender_pose for p in ch.arrived(1)] == [(10.0, 0.0, 0.5)]
    assert [p.sender_pose for p in ch.arrived(2)] == [(20.0, 0.0, 0.5)]
    assert ch.arrived(3) == []

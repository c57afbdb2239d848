import numpy as np
import pytest

pytest.importorskip("rosbags")

from fftnav.config import SwarmConfig  # noqa: E402
from fftnav.episode import episode_csv, run_episode  # noqa: E402
from fftnav.ros.episode import EpisodeBag  # noqa: E402
from fftnav.world.generate import generate_world  # noqa: E402


@pytest.fixture(scope="module")
def world():
    return generate_world("forest", 11, robots=3, size_m=(8.0, 8.0), goal_y_m=7.0)


CONFIG = SwarmConfig().replace({"time_limit_s": "2"})


def counts(path):
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        return {c.topic: (c.msgtype, c.msgcount) for c in reader.connections}


def test_every_kind_of_bag_holds_the_same_topics(world, tmp_path):
    found = {}
    for name in ("ep.mcap", "ep.db3", "ep.bag"):
        with EpisodeBag(tmp_path / name, world, CONFIG) as bag:
            result = run_episode(world, "fusion", seed=2, config=CONFIG, on_tick=bag)
        found[name] = counts(tmp_path / name)
    assert found["ep.mcap"] == found["ep.db3"] == found["ep.bag"]
    assert found["ep.bag"]["/tf"] == ("tf2_msgs/msg/TFMessage", 20)
    assert found["ep.bag"]["/robot_2/scan"] == ("sensor_msgs/msg/LaserScan", 20)
    sent = sum(r.messages_sent for r in result.rows)
    assert sum(n for t, (_, n) in found["ep.bag"].items() if t.endswith("/messages")) == sent
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ep.bag", "ep.db3", "ep.mcap"]


def test_the_hook_does_not_change_the_episode(world, tmp_path):
    plain = run_episode(world, "fusion", seed=2, config=CONFIG)
    with EpisodeBag(tmp_path / "e.mcap", world, CONFIG) as bag:
        hooked = run_episode(world, "fusion", seed=2, config=CONFIG, on_tick=bag)
    assert episode_csv(plain.rows) == episode_csv(hooked.rows)
    for a, b in zip(plain.trajectories, hooked.trajectories, strict=True):
        np.testing.assert_array_equal(a, b)


def test_an_episode_that_fails_leaves_no_bag(world, tmp_path):
    def broken(*args):
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"), \
            EpisodeBag(tmp_path / "e.mcap", world, CONFIG) as bag:
        run_episode(world, "fusion", seed=2, config=CONFIG,
                    on_tick=lambda *a: (bag(*a), broken()))
    assert list(tmp_path.iterdir()) == []


def test_bag_suffixes(world, tmp_path):
    with pytest.raises(ValueError, match=r"--bag must end in \.mcap, \.db3 or \.bag, got "
                                         r"--bag='x\.json'"):
        EpisodeBag("x.json", world, CONFIG)


def test_special_targets_are_refused_and_links_written_through(world, tmp_path):
    import os

    fifo = tmp_path / "f.mcap"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match=r"--bag must be a file path, not a folder, pipe or "
                                         r"device, got --bag='.*f\.mcap'"):
        EpisodeBag(fifo, world, CONFIG)
    (tmp_path / "d.mcap").mkdir()
    with pytest.raises(ValueError, match="not a folder"):
        EpisodeBag(tmp_path / "d.mcap", world, CONFIG)
    real = tmp_path / "real.mcap"
    real.write_bytes(b"old")
    link = tmp_path / "link.mcap"
    link.symlink_to(real)
    with EpisodeBag(link, world, CONFIG) as bag:
        run_episode(world, "fusion", seed=2, config=CONFIG.replace({"time_limit_s": "0.5"}),
                    on_tick=bag)
    assert link.is_symlink() and real.read_bytes()[:8] == b"\x89MCAP0\r\n"

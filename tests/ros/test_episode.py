import numpy as np
import pytest

pytest.importorskip("rosbags")

from fftnav.config import EpisodeConfig, SwarmConfig  # noqa: E402
from fftnav.episode import episode_csv, run_episode  # noqa: E402
from fftnav.episode.recording import read_recording  # noqa: E402
from fftnav.navigation.controllers import Controller  # noqa: E402
from fftnav.observe.geometry import RobotGeometry  # noqa: E402
from fftnav.report.replay import failure_ticks  # noqa: E402
from fftnav.ros.episode import EpisodeBag  # noqa: E402
from fftnav.states import Status  # noqa: E402
from fftnav.world import Circle, World  # noqa: E402
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


# -- what a viewer needs: latched topics, safe directions, robots and failures --------------

UP = np.pi / 2
LATCHED = {"/world", "/tf_static"}


class Straight(Controller):
    """Drives straight at its goal, no pipeline."""

    uses_pipeline = False

    def act(self, obs):
        return self.v_max_mps, 2.0 * obs.goal_bearing_rad


def read(path):
    """Every connection (topic -> Connection) and message (topic -> [(t_ns, msg)])."""
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        conns = {c.topic: c for c in reader.connections}
        msgs = {t: [] for t in conns}
        for conn, t_ns, raw in reader.messages():
            msgs[conn.topic].append((t_ns, reader.deserialize(raw, conn.msgtype)))
    return conns, msgs


def recorded(world, policy, config, path, seed=2):
    """The episode written to the bag ``path``, its result and its recording."""
    with EpisodeBag(path, world, config) as bag:
        result = run_episode(world, policy, seed=seed, config=config, on_tick=bag, record=True)
        bag.finish(result)
    rec_path = path.with_suffix(".npz")
    rec_path.write_bytes(result.recording())
    return result, read_recording(rec_path)


@pytest.mark.parametrize("name", ["ep.mcap", "ep.db3", "ep.bag"])
def test_world_and_tf_static_are_latched_and_nothing_else(world, tmp_path, name):
    config = CONFIG.replace({"time_limit_s": "0.3"})
    recorded(world, "fusion", config, tmp_path / name)
    conns, msgs = read(tmp_path / name)
    for topic, conn in conns.items():
        if name == "ep.bag":  # ROS 1: the connection header's latching flag
            assert bool(conn.ext.latching) == (topic in LATCHED), topic
            continue
        qos = conn.ext.offered_qos_profiles
        if topic in LATCHED:  # ROS 2: what RViz's transient-local subscription matches
            from rosbags.interfaces import QosDurability, QosHistory, QosReliability

            (q,) = qos
            assert (q.durability, q.history, q.depth, q.reliability) == (
                QosDurability.TRANSIENT_LOCAL, QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE)
        else:
            assert not qos, topic
    (_, static), = msgs["/tf_static"]
    assert [(t.header.frame_id, t.child_frame_id) for t in static.transforms] == [
        (f"robot_{i}/base_link", f"robot_{i}/laser") for i in range(3)]
    assert {t.transform.translation.z for t in static.transforms} == {config.robot.r0_m}
    assert [t for t, _ in msgs["/world"]] == [t for t, _ in msgs["/tf_static"]] == [0]


def test_each_robots_safe_directions_are_the_episodes_masks(world, tmp_path):
    """The oracle: the recording's safe mask of each robot at each tick it drove; a safe beam
    is safe to l_th (y1 = l_th / R there, the filter's clip); the wedges are deleted once
    (the robots are all out of time when the episode ends)."""
    _, rec = recorded(world, "fusion", CONFIG, tmp_path / "ep.mcap")
    _, msgs = read(tmp_path / "ep.mcap")
    l_th = RobotGeometry(r0_m=CONFIG.robot.r0_m, r_m=CONFIG.robot.r_m).l_th_m
    safe_beams = 0
    for i in range(3):
        moving = np.flatnonzero(rec.status[:-1, i] == Status.MOVING)
        scans = msgs[f"/robot_{i}/fftnav/safe_scan"]
        wedges = msgs[f"/robot_{i}/fftnav/safe_directions"]
        assert [t for t, _ in scans] == [t for t, _ in wedges[:-1]] == [
            round(rec.time_s[k] * 1e9) for k in moving]
        for k, (_, scan), (_, array) in zip(moving, scans, wedges[:-1], strict=True):
            ranges = np.asarray(scan.ranges)
            np.testing.assert_array_equal(np.isfinite(ranges), rec.safe[k, i])
            assert scan.header.frame_id == f"robot_{i}/laser"
            np.testing.assert_allclose(ranges[rec.safe[k, i]], l_th, atol=1e-6)
            (marker,) = array.markers
            assert marker.ns == f"robot_{i}/safe_directions"
            assert len(marker.points) == 3 * rec.safe[k, i].sum()
            safe_beams += rec.safe[k, i].sum()
        t_end, (deleted,) = wedges[-1][0], wedges[-1][1].markers
        assert (deleted.ns, deleted.action) == (f"robot_{i}/safe_directions", 2)
        assert t_end == round((rec.time_s[-2] + 1 / CONFIG.episode.control_hz) * 1e9)
    assert safe_beams > 0


def test_robot_markers_follow_the_robots_and_are_deleted_when_they_leave(tmp_path):
    """Robot 0 arrives after 1 m, robot 1 drives into a trunk, robot 2 departs 0.5 s late
    and runs out of time."""
    world = World("t", 0, (12.0, 14.0), (Circle((4.0, 3.0), 0.3, 1.0),),
                  np.array([[1, 1, UP], [4, 1, UP], [7, 1, UP]], float),
                  np.array([[1, 2], [4, 6], [7, 12]], float))
    config = SwarmConfig(episode=EpisodeConfig(time_limit_s=4.0, departure="staggered",
                                               stagger_s=0.5))
    result, rec = recorded(world, f"{__name__}:Straight", config, tmp_path / "ep.mcap")
    assert [(r.arrived, r.collided) for r in result.rows] == [(True, False), (False, True),
                                                              (False, False)]
    conns, msgs = read(tmp_path / "ep.mcap")
    assert not any("fftnav/safe" in t for t in conns)  # no pipeline, no safe directions
    shown = {}  # robot -> ticks its footprint was added
    for t_ns, array in msgs["/fftnav/robots"]:
        for m in array.markers:
            robot, ns = m.ns.split("/")
            assert robot.startswith("robot_") and ns in ("footprint", "heading", "label", "goal")
            if ns == "footprint" and m.action == 0:
                assert m.header.frame_id == f"{robot}/base_link" and m.frame_locked
                shown.setdefault(int(robot[6:]), []).append(t_ns)
    times = np.round(rec.time_s * 1e9).astype(int)
    present = (rec.status[:-1] == Status.MOVING) | (rec.status[:-1] == Status.WAITING)
    for i in range(3):
        assert shown[i] == times[:-1][present[:, i]].tolist()
    deletes = {(t, m.ns) for t, a in msgs["/fftnav/robots"] for m in a.markers if m.action == 2}
    end = round((rec.time_s[-2] + 1 / config.episode.control_hz) * 1e9)
    for i in range(3):  # deleted at the first tick it is gone; robot 2 when the episode ends
        gone = (times[np.argmax(~present[:, i] & (np.arange(len(present)) > 0))] if i < 2
                else end)
        for ns in ("footprint", "heading", "label", "goal"):
            assert (gone, f"robot_{i}/{ns}") in deletes
    assert len(deletes) == 3 * 4
    check_failures(msgs, rec, result, times)
    assert [r.failure for r in result.rows[1:]] == ["collision", "slow"]


def check_failures(msgs, rec, result, times):
    """``/fftnav/failures`` against the replays' failure ticks (fftnav.report.replay) and the
    recorded poses: each message holds every failure so far, the newest added at its tick."""
    ticks = failure_ticks(rec)
    order = sorted(ticks, key=lambda r: (ticks[r], r))
    assert [t for t, _ in msgs["/fftnav/failures"]] == [times[ticks[r]] for r in order]
    for n, (_, array) in enumerate(msgs["/fftnav/failures"]):
        assert [m.ns for m in array.markers] == [
            f"robot_{r}/{ns}" for r in order[:n + 1] for ns in ("failure", "cause")]
    for robot, tick in ticks.items():
        cross, text = [m for m in msgs["/fftnav/failures"][-1][1].markers
                       if m.ns.startswith(f"robot_{robot}/")]
        centre = np.mean([[p.x, p.y] for p in cross.points], axis=0)
        np.testing.assert_allclose(centre, rec.pose[tick, robot, :2], atol=1e-9)
        assert text.text == f"robot_{robot}: {result.rows[robot].failure}"


def test_a_lost_robots_failure_is_where_it_stopped(tmp_path):
    """Odometry with a gyro bias of 15 deg/s: robot 0 stops where its estimate puts its goal,
    far from it (lost); robot 1 arrives."""
    world = World("t", 0, (14.0, 14.0), (), np.array([[3, 1, UP], [9, 1, UP]], float),
                  np.array([[3, 6], [9, 2]], float))
    config = SwarmConfig().replace({"localization.mode": "odometry",
                                    "localization.drift": "custom",
                                    "localization.gyro_bias_degps": "15", "time_limit_s": "20"})
    result, rec = recorded(world, f"{__name__}:Straight", config, tmp_path / "ep.bag")
    assert [r.failure for r in result.rows] == ["lost", ""]
    _, msgs = read(tmp_path / "ep.bag")
    check_failures(msgs, rec, result, np.round(rec.time_s * 1e9).astype(int))


def test_the_mcap_file_passes_the_mcap_librarys_validating_reader(world, tmp_path):
    """The MCAP reference library reads the file with every CRC checked: each record, the
    summary and its channel counts agree with what rosbags reads."""
    mcap_reader = pytest.importorskip("mcap.reader")
    from mcap.stream_reader import StreamReader

    recorded(world, "fusion", CONFIG, tmp_path / "ep.mcap")
    conns, msgs = read(tmp_path / "ep.mcap")
    with open(tmp_path / "ep.mcap", "rb") as fh:
        records = list(StreamReader(fh, validate_crcs=True).records)
    assert type(records[-1]).__name__ == "Footer"
    with open(tmp_path / "ep.mcap", "rb") as fh:
        reader = mcap_reader.make_reader(fh, validate_crcs=True)
        summary = reader.get_summary()
        seen = {}
        for _, channel, _ in reader.iter_messages():
            seen[channel.topic] = seen.get(channel.topic, 0) + 1
    assert seen == {t: len(m) for t, m in msgs.items()}
    counts = summary.statistics.channel_message_counts
    assert {summary.channels[c].topic: n for c, n in counts.items()} == seen
    assert summary.schemas[summary.channels[next(iter(counts))].schema_id].encoding == "ros2msg"

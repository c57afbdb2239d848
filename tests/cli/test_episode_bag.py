"""``fftnav episode --bag``: the episode as a bag, read back; the round trip through
``fftnav scan``."""

import json
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("rosbags")

from fftnav.episode.recording import read_recording  # noqa: E402
from fftnav.states import Status  # noqa: E402


def fftnav(*args):
    return subprocess.run([sys.executable, "-m", "fftnav", *map(str, args)],
                          capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def episode(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ep")
    world = tmp / "w.json"
    made = fftnav("world", "generate", "--env", "forest", "--seed", "3", "--size", "8", "8",
                  "--robots", "2", "--out", world)
    assert made.returncode == 0, made.stderr
    proc = fftnav("episode", "--world", world, "--policy", "fusion", "--set",
                  "time_limit_s=6", "--bag", tmp / "ep.mcap", "--record", tmp / "ep.npz",
                  "--out", tmp / "ep.csv")
    assert proc.returncode == 0, proc.stderr
    return tmp / "ep.mcap", read_recording(tmp / "ep.npz")


def read_bag(path):
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        msgs = {t: [] for t in types}
        for conn, t_ns, raw in reader.messages():
            msgs[conn.topic].append((t_ns, reader.deserialize(raw, conn.msgtype)))
    return types, msgs


@pytest.mark.parametrize("robot", [0, 1])
def test_round_trip_gives_the_episodes_own_masks_message_by_message(episode, robot):
    bag, rec = episode
    proc = fftnav("scan", bag, "--topic", f"/robot_{robot}/scan", "--r0", "0.15", "--r", "0.3")
    assert proc.returncode == 0, proc.stderr
    rows = [json.loads(line) for line in proc.stdout.splitlines()]
    moving = rec.status[:, robot] == Status.MOVING
    expected = rec.safe[moving, robot]
    got = np.array([r["safe_mask"] for r in rows], dtype=bool)
    assert got.shape == expected.shape and len(got) > 10
    np.testing.assert_array_equal(got, expected)
    assert 0.05 < got.mean() < 0.95
    times = np.array([r["stamp_sec"] + r["stamp_nanosec"] * 1e-9 for r in rows])
    np.testing.assert_allclose(times, rec.time_s[moving], atol=1e-9)
    assert {r["frame_id"] for r in rows} == {f"robot_{robot}/laser"}


def test_the_bag_holds_world_tf_and_each_robots_topics(episode):
    bag, rec = episode
    types, msgs = read_bag(bag)
    failed = [f"robot_{r['robot']}: {r['failure']}" for r in rec.rows if not r["arrived"]]
    markers = "visualization_msgs/msg/MarkerArray"
    assert types == {
        "/world": markers, "/tf": "tf2_msgs/msg/TFMessage",
        "/tf_static": "tf2_msgs/msg/TFMessage", "/fftnav/robots": markers,
        **({"/fftnav/failures": markers} if failed else {}),
        **{f"/robot_{i}/{name}": kind for i in range(2) for name, kind in (
            ("scan", "sensor_msgs/msg/LaserScan"), ("odom", "nav_msgs/msg/Odometry"),
            ("cmd_vel", "geometry_msgs/msg/Twist"),
            ("messages", "std_msgs/msg/UInt8MultiArray"),
            ("fftnav/safe_scan", "sensor_msgs/msg/LaserScan"),
            ("fftnav/safe_directions", markers))}}
    last = msgs["/fftnav/failures"][-1][1]  # every failure so far
    assert [m.text for m in last.markers if m.ns.endswith("/cause")] == failed
    assert failed  # the CLI writes the failures (EpisodeBag.finish)
    (_, world), = msgs["/world"]
    outline = world.markers[0]
    assert len(outline.points) == 2 * sum(len(o.outline()) for o in rec.world.solids)
    assert len(world.markers[1].points) == len(rec.world.goals)
    ticks = rec.n_ticks - 1  # the last tick is the end: poses only
    assert len(msgs["/tf"]) == ticks
    for i in range(2):
        moving = np.flatnonzero(rec.status[:ticks, i] == Status.MOVING)
        odom = msgs[f"/robot_{i}/odom"]
        assert len(odom) == len(msgs[f"/robot_{i}/cmd_vel"]) == len(moving)
        for k, (t_ns, m) in zip(moving, odom, strict=True):
            assert t_ns == round(rec.time_s[k] * 1e9)
            p = m.pose.pose
            np.testing.assert_allclose([p.position.x, p.position.y], rec.pose[k, i, :2])
            yaw = 2 * np.arctan2(p.orientation.z, p.orientation.w)
            assert np.cos(yaw - rec.pose[k, i, 2]) == pytest.approx(1.0)
            assert m.twist.twist.linear.x == pytest.approx(rec.command[k, i, 0])
        sent = [p for p, r in zip(rec.sent_payloads, rec.sent_robot, strict=True) if r == i]
        assert [bytes(m.data) for _, m in msgs[f"/robot_{i}/messages"]] == sent
        assert len(sent) > 0
    first_tf = msgs["/tf"][0][1].transforms
    assert [t.child_frame_id for t in first_tf] == ["robot_0/base_link", "robot_1/base_link"]
    scan = msgs["/robot_0/scan"][0][1]
    assert len(scan.ranges) == 360 and scan.range_max == pytest.approx(3.0)
    assert (np.asarray(scan.ranges)[np.abs(rec.angles_rad) > np.radians(180 - 7.5)] == 0).all()


def test_a_bag_path_of_another_kind_is_refused_before_the_episode(tmp_path):
    proc = fftnav("episode", "--world", tmp_path / "missing.json", "--policy", "fusion",
                  "--bag", tmp_path / "ep.txt")
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.strip().splitlines() == [
        f"fftnav episode: error: --bag must end in .mcap, .db3 or .bag, got "
        f"--bag={str(tmp_path / 'ep.txt')!r}"]

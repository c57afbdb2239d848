"""The viewer configurations in docs/viewers/ against a bag ``fftnav episode --bag`` writes:
every topic they show is in the bag, with the durability they subscribe with."""

import json
from pathlib import Path

import pytest

pytest.importorskip("rosbags")

from fftnav.config import SwarmConfig  # noqa: E402
from fftnav.episode import run_episode  # noqa: E402
from fftnav.ros.episode import LATCHED, EpisodeBag  # noqa: E402
from fftnav.world.generate import generate_world  # noqa: E402

VIEWERS = Path(__file__).resolve().parents[2] / "docs" / "viewers"


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    """A Table I swarm's bag (15 robots, every one out of time after 0.3 s): topic -> type,
    and the frames of its /tf."""
    from rosbags.highlevel import AnyReader

    world = generate_world("forest", 1000, robots=15)
    config = SwarmConfig().replace({"time_limit_s": "0.3"})
    path = tmp_path_factory.mktemp("viewers") / "ep.mcap"
    with EpisodeBag(path, world, config) as episode_bag:
        result = run_episode(world, "fusion", seed=0, config=config, on_tick=episode_bag)
        episode_bag.finish(result)
    with AnyReader([path]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        (tf,) = [c for c in reader.connections if c.topic == "/tf"]
        _, _, raw = next(reader.messages(connections=[tf]))
        frames = {t.header.frame_id for t in reader.deserialize(raw, tf.msgtype).transforms}
    return types, frames


def test_the_foxglove_layout_shows_topics_the_bag_holds(bag):
    types, frames = bag
    layout = json.loads((VIEWERS / "episode-foxglove-layout.json").read_text())
    panels = layout["configById"]
    scene = panels["3D!fftnav"]
    shown = set(scene["topics"])
    shown.add(panels["RawMessages!failures"]["topicPath"])
    shown |= {p["value"].split(".")[0] for p in panels["Plot!speeds"]["paths"]}
    assert shown <= set(types), sorted(shown - set(types))
    assert {f"/robot_{i}/fftnav/safe_directions" for i in range(15)} <= shown
    assert scene["followTf"] in frames and scene["layers"]["grid"]["frameId"] in frames

    def leaves(node):
        return [node] if isinstance(node, str) else leaves(node["first"]) + leaves(
            node["second"])

    assert sorted(leaves(layout["layout"])) == sorted(panels)


def test_the_rviz_config_subscribes_as_the_bag_offers(bag):
    from ruamel.yaml import YAML

    types, frames = bag
    config = YAML(typ="safe").load((VIEWERS / "episode.rviz").read_text())
    manager = config["Visualization Manager"]
    assert manager["Global Options"]["Fixed Frame"] in frames
    topics = {d["Topic"]["Value"]: d for d in manager["Displays"] if "Topic" in d}
    assert set(topics) <= set(types), sorted(set(topics) - set(types))
    kinds = {"MarkerArray": "visualization_msgs/msg/MarkerArray",
             "LaserScan": "sensor_msgs/msg/LaserScan"}
    for name, display in topics.items():
        assert kinds[display["Class"].split("/")[1]] == types[name], name
        latched = display["Topic"]["Durability Policy"] == "Transient Local"
        assert latched == (name in LATCHED), name
    assert "/world" in topics and "/fftnav/failures" in topics

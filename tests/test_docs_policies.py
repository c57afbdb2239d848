"""docs/policies.md's worked examples run as written: the SideVote controller (with messages)
and the decision policy, named by file path."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from fftnav.config import EpisodeConfig, SwarmConfig
from fftnav.episode import episode_csv, run_episode
from fftnav.world import Circle, World

DOC = (Path(__file__).resolve().parents[1] / "docs" / "policies.md").read_text()
BLOCKS = re.findall(r"```python\n(.*?)```", DOC, re.S)
UP = math.pi / 2


def _plugin(tmp_path, needle, name):
    code = next(b for b in BLOCKS if needle in b)
    path = tmp_path / name
    path.write_text(code)
    return path


@pytest.mark.slow
def test_side_vote_example_runs_and_sends_its_votes(tmp_path):
    path = _plugin(tmp_path, "class SideVote", "side_vote.py")
    # two robots behind one wide trunk: robot 0 (left of centre, its own view says left) meets
    # it first and announces its side; robot 1 (right of centre, its own view says right)
    # follows the vote
    world = World("test", 0, (8.0, 12.0), (Circle((4.0, 6.0), 0.8, 1.0),),
                  np.array([[3.7, 2.0, UP], [4.3, 0.8, UP]]), np.array([[3.7, 11.0], [4.3, 11.0]]))
    res = run_episode(world, f"{path}:SideVote", seed=0,
                      config=SwarmConfig(episode=EpisodeConfig(time_limit_s=60.0)))
    assert [r.policy for r in res.rows] == ["side-vote", "side-vote"]
    assert all(r.arrived and not r.collided for r in res.rows)
    assert sum(r.messages_sent for r in res.rows) > 0
    assert all(r.bytes_sent == r.messages_sent for r in res.rows)  # one byte per vote
    # they agreed: both passed the trunk on the left (-x: x < 4 at the trunk's height)
    sides = [np.sign(t[np.argmin(np.abs(t[:, 1] - 6.0)), 0] - 4.0) for t in res.trajectories]
    assert sides == [-1, -1]


def test_decision_policy_example_resolves_and_decides(tmp_path):
    from fftnav.navigation.policies import DecisionContext
    from fftnav.navigation.resolve import resolve

    path = _plugin(tmp_path, "def confident_fusion", "confident.py")
    found = resolve(f"{path}:CONFIDENT_FUSION")
    assert found.name == "confident-fusion" and found.policy.uses_messages
    plain = resolve(f"{path}:confident_fusion")
    assert plain.name == "confident_fusion" and not plain.policy.uses_messages
    rng = np.random.default_rng(0)
    decide = found.policy.decide
    assert decide(DecisionContext(0, lambda: 0.9, lambda: 0.52, rng)) == 1  # own P_s decides
    assert decide(DecisionContext(0, lambda: 0.9, lambda: 0.2, rng)) == -1  # fused P is clear


def test_message_kind_example_sends_its_beacons_and_keeps_each_episodes_state(tmp_path,
                                                                               monkeypatch):
    """The Beacon kind, named by file path: its robots broadcast 8 bytes a second, each read
    packet is counted by the episode's own instance (a second episode starts from zero, and
    runs as the first)."""
    from fftnav.navigation import bugcontrol
    from fftnav.navigation.resolve import resolve

    path = _plugin(tmp_path, "class Beacon", "beacon.py")
    found = resolve(f"{path}:OWN_BEACON")
    assert found.name == "own-beacon" and found.policy.messages.__name__ == "Beacon"
    kinds = []
    init = bugcontrol.BugController.__init__

    def keep(self, *args, **kwargs):
        init(self, *args, **kwargs)
        kinds.append(self.messages)

    monkeypatch.setattr(bugcontrol.BugController, "__init__", keep)
    world = World("test", 0, (8.0, 12.0), (Circle((4.0, 6.0), 0.8, 1.0),),
                  np.array([[3.7, 2.0, UP], [4.3, 0.8, UP]]), np.array([[3.7, 11.0], [4.3, 11.0]]))
    config = SwarmConfig(episode=EpisodeConfig(time_limit_s=20.0))
    rows = [run_episode(world, f"{path}:OWN_BEACON", seed=0, config=config).rows
            for _ in range(2)]
    assert episode_csv(rows[0]) == episode_csv(rows[1])
    assert [r.policy for r in rows[0]] == ["own-beacon"] * 2
    assert all(r.messages_sent > 0 and r.bytes_sent == 8 * r.messages_sent for r in rows[0])
    assert kinds[0] is not kinds[1] and type(kinds[0]).__name__ == "Beacon"
    assert [kinds[0].read(i) for i in range(2)] == [kinds[1].read(i) for i in range(2)]
    assert min(kinds[1].read(i) for i in range(2)) > 0


def test_environment_example_runs():
    pytest.importorskip("pettingzoo", reason="the optional extra fftnav[marl] is not installed")
    code = next(b for b in BLOCKS if "SwarmNavEnv(" in b)
    code = code.replace("robots=15", "robots=2").replace(
        'options={"packet_loss": 0.2}', 'options={"packet_loss": 0.2, "time_limit_s": 1.0}')
    namespace: dict = {}
    exec(compile(code, "docs/policies.md", "exec"), namespace)
    assert namespace["frame"].ndim == 3 and namespace["env"].agents == []

"""Episode recordings: what the robots saw, decided and sent, read back against what the
controller was given and returned; the format's refusals; the runner's ``[record]``."""

from __future__ import annotations

import io
import json
import math
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fftnav.config import PAPER_MOTION, EpisodeConfig, SwarmConfig
from fftnav.episode import episode_csv, read_recording, run_episode
from fftnav.episode.recording import SCAN_STEP_M, VERSION, RecordingError, Tape, write_recording
from fftnav.errors import FftnavError
from fftnav.navigation.controllers import Action, Controller
from fftnav.states import State, Status
from fftnav.world import Circle, Polygon, World, generate_world
from tests.navigation.corridor import headon, keep_planners

CFG = SwarmConfig(episode=EpisodeConfig(time_limit_s=12.0))


def _world():
    """Two robots, a trunk in front of robot 0; robot 1 has an open way."""
    return World("test", 0, (8.0, 8.0), (Circle((2.0, 4.0), 0.5, 1.0),),
                 np.array([[2.0, 1.0, math.pi / 2], [6.0, 1.0, math.pi / 2]]), np.array([[2.0, 7.0], [6.0, 7.0]]))


class Spy(Controller):
    """Drives toward the goal, sends a message naming the tick every other tick, and remembers
    everything it was given and returned (the oracle of the recording)."""

    seen: list = []

    def __init__(self, setup):
        super().__init__(setup)
        Spy.seen = []
        self.count = {}

    def act(self, obs):
        v = self.v_max_mps * (0.5 + 0.5 * math.cos(obs.goal_bearing_rad))
        w = float(np.clip(2.0 * obs.goal_bearing_rad, -self.w_max_radps, self.w_max_radps))
        msg = f"{obs.robot}@{obs.tick}".encode() if obs.tick % 2 == 0 else None
        self.count[obs.robot] = self.count.get(obs.robot, 0) + 1
        Spy.seen.append((obs.tick, obs.robot, obs.ranges_m.copy(), obs.safe_mask.copy(),
                         (v, w), msg, [(p.sender, p.tick) for p in obs.inbox]))
        return Action(v, w, msg)

    def state(self, robot):
        return {"acts": float(self.count.get(robot, 0)), "half": 0.5}


@pytest.fixture(scope="module")
def spied():
    result = run_episode(_world(), "tests.episode.test_recording:Spy", seed=3, config=CFG,
                         record=True)
    return result, read_recording(io.BytesIO(result.recording())), list(Spy.seen)


def test_recording_changes_no_row():
    world = generate_world("forest", 11, robots=4, size_m=(8.0, 8.0), goal_y_m=7.0)
    plain = run_episode(world, "fusion", seed=2, config=CFG)
    recorded = run_episode(world, "fusion", seed=2, config=CFG, record=True)
    assert episode_csv(recorded.rows) == episode_csv(plain.rows)
    for a, b in zip(plain.trajectories, recorded.trajectories, strict=True):
        np.testing.assert_array_equal(a, b)


def test_scans_masks_commands_and_messages_are_those_the_controller_had(spied):
    _, rec, seen = spied
    assert len(seen) > 50
    for tick, robot, ranges, safe, (v, w), _, _ in seen:
        assert np.abs(rec.scan_m[tick, robot] - ranges).max() <= SCAN_STEP_M / 2 + 1e-9
        np.testing.assert_array_equal(rec.safe[tick, robot], safe)
        np.testing.assert_allclose(rec.command[tick, robot], (v, w), rtol=1e-6, atol=1e-6)
        assert rec.status[tick, robot] == Status.MOVING
    sent = {(t, r): p for t, r, p in zip(rec.sent_tick, rec.sent_robot, rec.sent_payloads,
                                         strict=True)}
    assert sent == {(t, r): m for t, r, _, _, _, m, _ in seen if m is not None}


def test_every_packet_in_an_inbox_was_delivered_by_then(spied):
    _, rec, seen = spied
    delivered = {(int(s), int(r), int(st)): int(t) for t, s, r, st in rec.delivered}
    assert delivered
    for tick, robot, *_, inbox in seen:
        for sender, sent_tick in inbox:
            assert delivered[(sender, robot, sent_tick)] <= tick
    for t, s, _, st in rec.delivered:
        assert t >= st and s in rec.sent_robot[rec.sent_tick == st]


def test_poses_state_and_final_status_follow_the_episode(spied):
    result, rec, seen = spied
    assert rec.n_ticks == max(t for t, *_ in seen) + 2  # the ticks, then the end
    for i, traj in enumerate(result.trajectories):
        np.testing.assert_allclose(rec.pose[:len(traj), i], traj, atol=1e-4)
        ticks = [t for t, r, *_ in seen if r == i]
        # the state after the tick's act
        np.testing.assert_array_equal(rec.state["acts"][ticks, i], np.arange(1, len(ticks) + 1))
        end = {"arrived": result.rows[i].arrived, "collided": result.rows[i].collided}
        how = next((k for k, v in end.items() if v), "timed_out")
        assert Status(rec.status[-1, i]).label == how
    assert set(rec.state) == {"acts", "half"}
    assert rec.policy == "Spy" and rec.seed == 3
    assert rec.world.to_json() == _world().to_json()
    assert rec.config == CFG
    assert [r["robot"] for r in rec.rows] == [0, 1]
    np.testing.assert_allclose(rec.time_s[:3], [0.0, 0.1, 0.2])


def test_bug_controller_state_names_its_mode_and_side():
    world = generate_world("rocky", 1003, robots=4, size_m=(10.0, 10.0), goal_y_m=9.0)
    rec = read_recording(io.BytesIO(run_episode(world, "fusion", seed=1, config=CFG,
                                                record=True).recording()))
    assert set(rec.state) == {"mode", "side", "decisions", "p_own", "p_fused"}
    moving = rec.status == Status.MOVING
    modes = rec.state["mode"][moving]
    assert set(np.unique(modes)) <= {State.GOAL, State.FOLLOW, State.ESCAPE}
    following = moving & np.isin(rec.state["mode"], [State.FOLLOW, State.ESCAPE])
    assert following.any() and set(np.unique(rec.state["side"][following])) <= {-1.0, 1.0}
    assert (rec.state["side"][moving & (rec.state["mode"] == State.GOAL)] == 0).all()
    for name in ("p_own", "p_fused"):  # fusion computes both at each decision
        values = rec.state[name][moving]
        asked = ~np.isnan(values)
        assert asked.any() and ((values[asked] >= 0) & (values[asked] <= 1)).all()
        np.testing.assert_array_equal(asked, rec.state["decisions"][moving] > 0)


def _barrier_world():
    """A wall across the map with one gap on the right; four robots below it
    (tests/navigation/test_collab.py)."""
    walls = (Polygon(((0.0, 4.0), (7.0, 4.0), (7.0, 4.3), (0.0, 4.3)), 1.0),
             Polygon(((8.5, 4.0), (10.0, 4.0), (10.0, 4.3), (8.5, 4.3)), 1.0))
    xs = [1.5, 3.5, 5.5, 7.5]
    return World("t", 0, (10.0, 9.0), walls, np.array([[x, 1.0, math.pi / 2] for x in xs]),
                 np.array([[x, 8.0] for x in xs]), "walls")


def _recorded_with_planner(monkeypatch, world, policy, seed, config):
    """The recording of an episode and its Bug planner (the oracle of the states: its
    counters)."""
    planners = keep_planners(monkeypatch)
    result = run_episode(world, policy, seed=seed, config=config, record=True)
    return read_recording(io.BytesIO(result.recording())), planners[0]


def test_guided_escaping_and_waiting_robots_report_their_states(monkeypatch):
    """``state/mode`` holds fftnav.states.State codes: a collab robot steering along its
    guided way reports GUIDED (5) on exactly the ticks the planner counts as guided, an
    escaping one ESCAPE (2) with its side, a robot standing for the robots in its way (the right
    of way) WAIT (4) on exactly the ticks the planner counts as waiting; and none of them
    reports GOAL (0) on those ticks."""
    config = SwarmConfig(episode=EpisodeConfig(time_limit_s=60.0, departure="staggered",
                                               stagger_s=4.0)).replace(PAPER_MOTION)
    rec, planner = _recorded_with_planner(monkeypatch, _barrier_world(), "collab", 5, config)
    moving = rec.status == Status.MOVING
    mode = np.where(moving, rec.state["mode"], np.nan)
    assert ((mode == State.GUIDED).sum(axis=0) == planner.stats.guided_ticks).all()
    assert planner.stats.guided_ticks.sum() > 0
    escaping = mode == State.ESCAPE
    assert escaping.any() and set(np.unique(rec.state["side"][escaping])) <= {-1.0, 1.0}
    assert (rec.state["side"][mode == State.GUIDED] == 0).all()
    rec, planner = _recorded_with_planner(monkeypatch, headon(0.8), "collab", 0, SwarmConfig())
    mode = np.where(rec.status == Status.MOVING, rec.state["mode"], np.nan)
    assert planner.stats.wait_ticks.sum() > 0
    assert ((mode == State.WAIT).sum(axis=0) == planner.stats.wait_ticks).all()


def test_a_version_1_recording_still_reads():
    """tests/data/recording_v1.npz was written by fftnav 0.2.0 (recording version 1):
    ``fftnav episode --world barrier.json --policy fusion --seed 0 --record recording_v1.npz
    --set time_limit_s=20 --set episode.departure=staggered --set episode.stagger_s=2 --set
    sensor.beams=90``, barrier.json being the wall with a gap of ``_barrier_world`` with two
    robots, at x = 5.5 and 7.5 m. Its codes read as today's: robot 1 waits at its start, then
    moves and arrives; robot 0 heads for its goal, follows the wall, escapes and runs out of
    time. A recording written now is of version 3 and names its state codes."""
    rec = read_recording(Path(__file__).resolve().parents[1] / "data" / "recording_v1.npz")
    assert rec.meta["version"] == 1 < VERSION == 3
    assert rec.meta["status"] == list(Status.labels())[:len(rec.meta["status"])]  # a prefix
    assert [r["arrived"] for r in rec.rows] == [False, True]
    assert rec.status[0].tolist() == [Status.MOVING, Status.WAITING]
    assert rec.status[-1].tolist() == [Status.TIMED_OUT, Status.ARRIVED]
    modes = rec.state["mode"][rec.status == Status.MOVING]
    assert set(np.unique(modes)) == {State.GOAL, State.FOLLOW, State.ESCAPE}
    assert rec.n_robots == 2 and rec.safe.shape[2] == 90 and rec.estimates is None
    now = json.loads(np.load(io.BytesIO(run_episode(_world(), "fusion", seed=0, config=CFG,
                                                    record=True).recording()))["meta"].tobytes())
    assert now["version"] == 3 and now["states"] == list(State.labels())


class Circle15(Controller):
    """Every robot drives a circle for the whole episode: 15 robots scanning for 120 s."""

    def act(self, obs):
        return 0.5 * self.v_max_mps, 0.3 * self.w_max_radps


@pytest.mark.slow
def test_a_15_robot_120_s_episode_with_noisy_scans_takes_at_most_3_mb():
    world = generate_world("rocky", 1003, robots=15)
    cfg = SwarmConfig().replace({"sensor.noise_std_m": 0.01})
    result = run_episode(world, f"{__file__}:Circle15", seed=1, config=cfg,
                         record=True)
    data = result.recording()
    rec = read_recording(io.BytesIO(data))
    assert rec.n_ticks == 1201 and (rec.status[:-1] == Status.MOVING).all()
    assert len(data) <= 3_000_000


def _npz(**columns):
    buffer = io.BytesIO()
    np.savez(buffer, **columns)
    buffer.seek(0)
    return buffer


def _meta(**fields):
    return np.frombuffer(json.dumps(fields).encode(), dtype=np.uint8)


@pytest.mark.parametrize(("source", "match"), [
    (io.BytesIO(b"not a zip"), r"path must be an fftnav recording, got path="),
    (io.BytesIO(b'{"format": "json"}'), r"\(not an \.npz archive of arrays: neither an fftnav "
                                        r"recording nor numpy data\)$"),
    (_npz(x=np.array([{"a": 1}], dtype=object)),
     r"\(an \.npz of Python objects, not of an fftnav recording's arrays\)$"),
    (_npz(x=np.zeros(3)), r"no readable meta: an \.npz without fftnav's meta member\)$"),
    (_npz(meta=_meta(format="other", version=1)), r"\(format 'other'\)"),
    (_npz(meta=_meta(format="fftnav-recording", version=VERSION + 1)),
     rf"path must be a recording of version <= {VERSION}, .*upgrade fftnav"),
    (_npz(meta=_meta(format="fftnav-recording", version=VERSION, beams=3)),
     r"path must be a complete fftnav recording, .*\(no column "),
])
def test_what_is_not_a_recording_is_refused_by_name(source, match):
    with pytest.raises(RecordingError, match=match) as caught:
        read_recording(source)
    assert "allow_pickle" not in str(caught.value)  # never numpy's advice to load it unsafely


def test_a_recording_is_written_atomically_into_a_new_folder(tmp_path, spied):
    result, _, _ = spied
    path = write_recording(tmp_path / "a" / "b" / "r.npz", result.recording())
    assert [p.name for p in path.parent.iterdir()] == ["r.npz"]
    with zipfile.ZipFile(path) as z:
        assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in z.infolist())
    assert read_recording(path).n_robots == 2


def test_cli_episode_record_writes_exactly_the_path(tmp_path):
    (tmp_path / "w.json").write_text(_world().to_json())
    proc = subprocess.run([sys.executable, "-m", "fftnav", "episode", "--world", "w.json",
                           "--policy", "fusion", "--set", "time_limit_s=5", "--out", "e.csv",
                           "--record", "rec/one.rec"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    rec = read_recording(tmp_path / "rec" / "one.rec")
    rows = pd.read_csv(tmp_path / "e.csv")
    assert [r["path_length_m"] for r in rec.rows] == pytest.approx(list(rows.path_length_m),
                                                                    abs=1e-6)
    assert rec.policy == "fusion" and rec.config.episode.time_limit_s == 5


def _rewritten(data, **changes):
    """The recording ``data`` with some columns replaced (``meta`` as a dict)."""
    with np.load(io.BytesIO(data)) as npz:
        cols = {k: npz[k] for k in npz.files}
    for key, value in changes.items():
        cols[key] = _meta(**value) if key == "meta" else value
    return _npz(**cols)


def test_damaged_or_inconsistent_recordings_are_refused_by_name(spied):
    result, rec, _ = spied
    data = result.recording()
    meta = json.loads(np.load(io.BytesIO(data))["meta"].tobytes())
    with pytest.raises(RecordingError, match=r"consistent fftnav recording, .*\(column command "
                                             r"has shape \(\d+, 2, 2\), expected \(\d+, 1, 2\)"):
        read_recording(_rewritten(data, pose=rec.pose[:, :1].astype(np.float32)))
    with pytest.raises(RecordingError, match=r"got path=.*\(column scan has shape"):
        read_recording(_rewritten(data, meta={**meta, "beams": 7}))
    with pytest.raises(RecordingError, match=r"no meta key 'seed'"):
        read_recording(_rewritten(data, meta={k: v for k, v in meta.items() if k != "seed"}))
    with pytest.raises(RecordingError, match=r"sent_offset does not index sent_bytes"):
        read_recording(_rewritten(data, sent_bytes=np.zeros(3, np.uint8)))
    # values a player cannot draw: NaN poses, time that stands still or runs back, unknown codes
    pose = rec.pose.astype(np.float32)
    pose[3, 1, 0] = np.nan
    with pytest.raises(RecordingError, match=r"consistent fftnav recording, got path=.*\(column "
                                             r"pose is not finite at tick 3, robot 1\)"):
        read_recording(_rewritten(data, pose=pose))
    for k, change in ((4, 0.0), (4, -0.05)):
        time_s = rec.time_s.copy()
        time_s[k] = time_s[k - 1] + change
        with pytest.raises(RecordingError, match=rf"column time_s does not increase at tick {k} "):
            read_recording(_rewritten(data, time_s=time_s))
    time_s = rec.time_s.copy()
    time_s[-1] = np.inf
    with pytest.raises(RecordingError, match=r"column time_s is not finite at tick"):
        read_recording(_rewritten(data, time_s=time_s))
    status = rec.status.copy()
    status[2, 0] = 9
    with pytest.raises(RecordingError, match=r"column status holds 9 at tick 2, robot 0: not a "
                                             r"Status code \(0 waiting, 1 moving"):
        read_recording(_rewritten(data, status=status))
    mode = np.zeros(rec.status.shape, np.float32)  # a Bug controller's mode column
    mode[0, 0] = np.nan  # absent: allowed
    mode[1, 1] = 7
    with pytest.raises(RecordingError, match=r"column state/mode holds 7 at tick 1, robot 1: "
                                             r"not a State code \(0 goal"):
        read_recording(_rewritten(data, **{"state/mode": mode}))
    # deflate data damaged inside the zip: the archive opens, the column does not
    raw = bytearray(data)
    with zipfile.ZipFile(io.BytesIO(data)) as z:
        info = z.getinfo("scan.npy")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    raw[start:start + 64] = b"\xff" * 64
    with pytest.raises(RecordingError, match=r"path must be an fftnav recording, got path="):
        read_recording(io.BytesIO(bytes(raw)))


@pytest.mark.parametrize(("record", "message"), [
    ("adir", "--record must be a file path, not a folder, got --record='adir'"),
    ("afile/r.npz", "--record must be in a folder that can be made, got --record='afile/r.npz'"),
])
def test_cli_record_path_that_cannot_be_written_is_refused_before_the_episode(tmp_path, record,
                                                                               message):
    (tmp_path / "adir").mkdir()
    (tmp_path / "afile").write_text("")
    proc = subprocess.run([sys.executable, "-m", "fftnav", "episode", "--world", "missing.json",
                           "--policy", "fusion", "--record", record], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and proc.stderr.splitlines() == [
        f"fftnav episode: error: {message} (File exists)"
        if record == "afile/r.npz" else f"fftnav episode: error: {message}"]


def test_the_obstacle_contact_is_on_the_tick_the_robot_collided(spied):
    result, rec, _ = spied
    assert result.rows[0].collided and not result.rows[1].collided
    moving = np.flatnonzero(rec.status[:, 0] == Status.MOVING)
    last = int(moving[-1])  # the tick whose command drove robot 0 into the trunk
    assert np.flatnonzero(rec.contact_obstacle[:, 0]).tolist() == [last]
    assert rec.status[last + 1, 0] == Status.COLLIDED
    assert not rec.contact_obstacle[:, 1].any() and not rec.contact_robot.any()


#: The beams of the tapes made by hand below.
BEAMS = 8


def _estimated(tick):
    """The oracle of the estimated poses at ``tick``: the true pose (:func:`_taped`) drifted
    along +x and turned."""
    return _true_pose(tick) + [0.01 * tick + 0.123456, -0.02 * tick, 0.05]


def _true_pose(tick):
    return _world().starts + [0.0, 0.1 * tick, 0.0]


def _taped(estimated_ticks=(), end_estimates=False, keyword=True):
    """The bytes of a tape of four ticks and the end of the two robots of :func:`_world`, with
    estimates on ``estimated_ticks`` (and the end with ``end_estimates``); ``keyword``: whether
    the ticks without estimates pass ``estimates=None`` or no keyword at all."""
    tape = Tape(_world(), CFG, "by-hand", 1, -math.pi + np.arange(BEAMS) * 2 * math.pi / BEAMS)
    for g in range(4):
        given = ({"estimates": _estimated(g) if g in estimated_ticks else None} if keyword
                 else {"estimates": _estimated(g)} if g in estimated_ticks else {})
        tape.tick(0.1 * g, _true_pose(g), np.full(2, int(Status.MOVING), np.uint8),
                  commands=np.full((2, 2), 0.5), ranges_m=np.full((2, BEAMS), 1.0),
                  safe=np.ones((2, BEAMS), bool), state={0: {"mode": 0.0}, 1: {"mode": 1.0}},
                  **given)
    tape.end(0.4, _true_pose(4), np.full(2, int(Status.ARRIVED), np.uint8),
             **({"estimates": _estimated(4)} if end_estimates else {}))
    return tape.to_bytes([{"robot": 0}, {"robot": 1}])


def test_estimated_poses_round_trip():
    data = _taped(range(4), end_estimates=True)
    with np.load(io.BytesIO(data)) as npz:
        column = npz["estimates"]
        assert column.dtype == npz["pose"].dtype == np.float32
    rec = read_recording(io.BytesIO(data))
    assert rec.estimates.shape == rec.pose.shape == (5, 2, 3)
    assert rec.estimates.dtype == np.float64
    for g in range(5):
        np.testing.assert_allclose(rec.estimates[g], _estimated(g), atol=1e-5)
        np.testing.assert_allclose(rec.pose[g], _true_pose(g), atol=1e-5)
    assert rec.meta["version"] == VERSION


def test_ticks_without_estimates_read_as_nan():
    rec = read_recording(io.BytesIO(_taped(estimated_ticks=(1, 2))))
    assert np.isnan(rec.estimates[[0, 3, 4]]).all()
    np.testing.assert_allclose(rec.estimates[1:3], [_estimated(1), _estimated(2)], atol=1e-5)


def test_a_recording_without_estimates_is_the_exact_one(monkeypatch):
    """Exact localization: no ``estimates`` column, the columns of a recording without
    estimates, and the same bytes whether the ticks pass ``estimates=None`` or nothing (the
    zip entries' times held still)."""
    monkeypatch.setattr("time.time", lambda: 1_800_000_000.0)
    plain, with_none = _taped(keyword=False), _taped(keyword=True)
    assert plain == with_none
    with zipfile.ZipFile(io.BytesIO(plain)) as z:
        names = [i.filename for i in z.infolist()]
    assert names == [f"{k}.npy" for k in (
        "time_s", "pose", "command", "status", "scan", "safe_bits", "contact_obstacle",
        "contact_robot", "state/mode", "sent_tick", "sent_robot", "sent_offset", "sent_bytes",
        "delivered", "meta")]
    assert read_recording(io.BytesIO(plain)).estimates is None
    with zipfile.ZipFile(io.BytesIO(_taped(range(4)))) as z:
        assert [i.filename for i in z.infolist()] == [*names[:2], "estimates.npy", *names[2:]]


def test_a_recording_of_exact_localization_has_no_estimates(spied):
    """A recording of an episode of exact localization (version 3, as written now) reads with
    no estimates."""
    result, rec, _ = spied
    assert json.loads(np.load(io.BytesIO(result.recording()))["meta"].tobytes())["version"] == 3
    assert rec.estimates is None


def test_estimates_of_another_shape_are_refused():
    tape = Tape(_world(), CFG, "by-hand", 1, np.zeros(BEAMS))
    with pytest.raises(FftnavError, match=r"^estimates must be an array of shape \(2, 3\), got "
                                          r"estimates.shape=\(2, 2\)$"):
        tape.tick(0.0, _true_pose(0), np.zeros(2, np.uint8), commands=np.zeros((2, 2)),
                  ranges_m=np.zeros((2, BEAMS)), safe=None, state={}, estimates=np.zeros((2, 2)))


def test_a_damaged_estimates_column_is_refused_by_name():
    data = _taped(range(4), end_estimates=True)
    with pytest.raises(RecordingError, match=r"consistent fftnav recording, got path=.*\(column "
                                             r"estimates has shape \(5, 1, 3\), expected "
                                             r"\(5, 2, 3\)\)"):
        read_recording(_rewritten(data, estimates=np.zeros((5, 1, 3), np.float32)))
    with pytest.raises(RecordingError, match=r"column estimates has shape \(4, 2, 3\)"):
        read_recording(_rewritten(data, estimates=np.zeros((4, 2, 3), np.float32)))

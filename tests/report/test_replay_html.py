"""The HTML player's data (fftnav.report.replay_html): the arrays the page reads, decoded here as
the page does, against the recording made by hand."""

from __future__ import annotations

import base64
import json
import re
import zlib

import numpy as np
import pytest

from fftnav.episode.recording import read_recording
from fftnav.report.frames import ESTIMATE_LABEL, KINDS, TRUTH_LABEL
from fftnav.report.replay_html import player_data, write_html
from fftnav.states import State, Status
from tests.report.recordings import (
    FAILURE_TICKS,
    MODES,
    TICKS,
    estimate,
    expected_kind,
    make_recording,
    pose,
    status,
)

TYPES = {"Float32Array": "<f4", "Uint8Array": "u1", "Uint16Array": "<u2", "Int32Array": "<i4"}


def _arrays(header, data):
    buffer = zlib.decompress(data)
    return {name: np.frombuffer(buffer, TYPES[kind], length, offset)
            for name, (offset, kind, length) in header["arrays"].items()}


def test_window_arrays_are_the_recordings(recording):
    header, data = player_data(recording, robot=2, from_s=1.0, to_s=3.0, speed=2)
    g = header["ticks"]
    assert g == 21 and header["robots"] == 4 and header["picked"] == 2 and header["speed"] == 2
    a = _arrays(header, data)
    np.testing.assert_allclose(a["time"], np.arange(10, 31) * 0.1, atol=1e-5)
    pose_ = a["pose"].reshape(g, 4, 3)
    for k, tick in enumerate(range(10, 31)):
        np.testing.assert_allclose(pose_[k], [pose(i, tick) for i in range(4)], atol=1e-5)
    kinds = a["kind"].reshape(g, 4)
    for k in (0, 19, 20, g - 1):  # ticks 10, 29, 30 (robot 3 touched the trunk), 30
        assert [header["kinds"][c] for c in kinds[k]] == [expected_kind(i, 10 + k)
                                                          for i in range(4)]
    drawn = a["status"].reshape(g, 4)  # robot 3 collided from its failure tick, 30
    assert [int(drawn[k, 3]) for k in (19, 20)] == [Status.MOVING, Status.COLLIDED]
    assert [int(drawn[19, i]) for i in range(3)] == [status(i, 29) for i in range(3)]
    assert header["kinds"] == list(KINDS)
    assert [header["kinds"][c] for c in header["driving"]] == [
        "moving", "following", "escaping", "guided"]
    assert (np.diff(a["msgStart"]) == 1).all() and a["msg"].reshape(-1, 2).tolist() == [[0, 1]] * g
    m = len(header["angles"])
    scan = a["scan"].reshape(g, 4, m) * header["scanStep"]
    ahead = np.abs(recording.angles_rad) < np.pi / 2  # the header rounds them to 1e-6
    np.testing.assert_allclose(scan[5, 1, ahead], 1.0)
    safe = np.unpackbits(a["safe"].reshape(g, 4, -1), axis=-1, count=m).astype(bool)
    assert (safe[5, 1] == ~ahead).all() and not safe[5, 0].any()
    names = header["stateNames"]
    state = a["state"].reshape(len(names), g, 4)
    assert names[:3] == ["mode", "side", "decisions"]
    assert state[names.index("mode"), 0].tolist() == [float(m) for m in MODES]
    assert state[names.index("command v (m/s)"), 0, 0] == pytest.approx(0.5)
    assert [o["failure"] for o in header["outcomes"]] == ["", "", "slow", "collision"]
    # robot 3 failed at tick 30 (20 ticks into the window), at 3.0 s; robot 2 after the window
    assert header["failTicks"] == [None, None, None, FAILURE_TICKS[3] - 10]
    assert [o["failedAt"] for o in header["outcomes"]] == [None, None, TICKS * 0.1, 3.0]
    assert header["limitS"] == 120.0 and header["limitText"] == "120"  # the default limit
    assert header["safeM"] == pytest.approx(0.3 ** 2 / 0.15)  # l_th = r^2 / r0
    assert header["keyLabels"]["safe"] == "safe (to l_th = 0.60 m)"
    assert header["stateLabels"][int(State.FOLLOW)] == "follow"
    assert header["sideNames"] == {"1": "left", "-1": "right"}
    assert [header["statusLabels"][c] for c in (Status.MOVING, Status.LOST)] == ["moving",
                                                                                 "lost"]


def _page(text):
    """The pane headers and the data blocks of a player page, as the page reads them."""
    panes = json.loads(re.search(r'id="fftnav-header">(.*?)</script>', text, re.S)
                       .group(1))["panes"]
    blocks = [base64.b64decode(re.search(rf'id="fftnav-data-{k}">(.*?)</script>', text, re.S)
                               .group(1)) for k in range(len(panes))]
    return panes, blocks


def test_html_embeds_header_and_data(recording, tmp_path):
    out = write_html(recording, tmp_path / "p.html")
    (header,), (data,) = _page(out.read_text())
    assert header["ticks"] == TICKS + 1 and header["picked"] == 1  # the first not to arrive
    assert _arrays(header, data)["pose"].size == (TICKS + 1) * 4 * 3
    assert header["failTicks"] == [None, None, FAILURE_TICKS[2], FAILURE_TICKS[3]]


def test_recordings_side_by_side_are_panes_of_one_page(recording, tmp_path):
    """Each recording beside the first is a pane of its own with its own data; the window and
    the robot are the first's, clamped to each recording's episode."""
    make_recording(tmp_path / "e.npz", estimates=True)
    other = read_recording(tmp_path / "e.npz")
    out = write_html(recording, tmp_path / "p.html", beside=[other], robot=2, from_s=1.0,
                     to_s=3.0)
    panes, blocks = _page(out.read_text())
    assert len(panes) == 2 and [h["picked"] for h in panes] == [2, 2]
    assert [h["estimates"] for h in panes] == [False, True] and "estimate" in panes[1]["arrays"]
    for header, data in zip(panes, blocks, strict=True):
        a = _arrays(header, data)
        np.testing.assert_allclose(a["time"], np.arange(10, 31) * 0.1, atol=1e-5)
    with pytest.raises(ValueError, match=r"from_s must be <= to_s, got from_s=3.0, to_s=1.0"):
        write_html(recording, tmp_path / "x.html", beside=[other], from_s=3, to_s=1)


def test_bad_window_and_robot(recording):
    with pytest.raises(ValueError, match=r"from_s must be <= to_s, got from_s=3.0, to_s=1.0"):
        player_data(recording, from_s=3, to_s=1)
    with pytest.raises(ValueError, match=r"robot must be an integer in \[0, 3\], got robot=7"):
        player_data(recording, robot=7)


def test_the_estimated_poses_are_in_the_data_only_when_recorded(recording, tmp_path):
    header, data = player_data(recording)
    assert header["estimates"] is False and "estimate" not in header["arrays"]
    make_recording(tmp_path / "e.npz", estimates=True)
    header, data = player_data(read_recording(tmp_path / "e.npz"), from_s=1.0, to_s=3.0)
    assert header["estimates"] is True
    assert header["estimateLabels"] == {"truth": TRUTH_LABEL, "estimate": ESTIMATE_LABEL}
    g = header["ticks"]
    a = _arrays(header, data)
    est = a["estimate"].reshape(g, 4, 3)
    for k, tick in enumerate(range(10, 31)):
        np.testing.assert_allclose(est[k], [estimate(i, tick) for i in range(4)], atol=1e-5)
        np.testing.assert_allclose(a["pose"].reshape(g, 4, 3)[k],
                                   [pose(i, tick) for i in range(4)], atol=1e-5)

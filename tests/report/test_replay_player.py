"""The HTML player's views in headless Chromium (the DevTools session of
tests/report/test_replay_browser.py): opening at a URL hash ``#robot=R&t=S``, the step keys, zoom
and pan (wheel, drag, keys, reset), every robot's scan, two recordings side by side on one clock,
and no console error, exception or network request. The recording is the hand-made one of
tests/report/recordings.py, whose every pose, state and failure tick is known."""

from __future__ import annotations

import numpy as np
import pytest

from fftnav.episode.recording import read_recording
from fftnav.report.frames import kind_rgb
from fftnav.report.replay_html import write_html
from tests.report.recordings import FAILURE_TICKS, TICKS, expected_kind, make_recording, pose
from tests.report.test_replay_browser import DevTools, _browser, _errors, _open

#: Virtual key codes of the keys the tests press (Chromium needs them for the non-text keys).
KEY_CODES = {"ArrowLeft": 37, "ArrowRight": 39, "Home": 36, "End": 35, " ": 32, ",": 188,
             ".": 190, "+": 187, "-": 189, "0": 48}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """The hand-made recording's player (robot 1 picked), and a page of it beside the same
    recording with estimated poses."""
    folder = tmp_path_factory.mktemp("player")
    make_recording(folder / "r.npz")
    make_recording(folder / "e.npz", estimates=True)
    rec, est = read_recording(folder / "r.npz"), read_recording(folder / "e.npz")
    write_html(rec, folder / "r.html", robot=1)
    write_html(rec, folder / "pair.html", robot=1, beside=[est])
    return folder


@pytest.fixture(scope="module")
def hashed(folder):
    """The player opened at ``#robot=3&t=2.96``: robot 3, tick 30 (3.0 s, nearer than 2.9)."""
    tools = _open(_browser(), folder / "r.html", folder / "profile-hash", "#robot=3&t=2.96")
    try:
        yield tools
    finally:
        tools.close()


def _press(tools: DevTools, key: str, shift: bool = False) -> None:
    """Press and release ``key`` (a KeyboardEvent key) on the page."""
    text = {"ArrowLeft": "", "ArrowRight": "", "Home": "", "End": ""}.get(key, key)
    for kind in ("keyDown", "keyUp"):
        tools.call("Input.dispatchKeyEvent", type=kind, key=key, text=text if kind == "keyDown"
                   else "", windowsVirtualKeyCode=KEY_CODES[key], modifiers=8 if shift else 0)


def _pixel(tools: DevTools, shot: np.ndarray, x: float, y: float, pane: int = 0) -> tuple:
    """The screenshot's colour at the world point (x, y) of pane ``pane``."""
    px, py = tools.evaluate(f"window.fftnavPlayer.toPage({x}, {y}, {pane})")
    return tuple(int(c) for c in shot[int(round(py)), int(round(px))])


def _state(tools: DevTools) -> dict:
    return tools.evaluate("({tick: fftnavPlayer.tick, picked: fftnavPlayer.picked, playing: "
                          "fftnavPlayer.playing, zoom: fftnavPlayer.view.zoom})")


def test_the_hash_opens_the_robot_and_the_time_paused(hashed):
    """#robot=3&t=2.96: robot 3 picked, the tick nearest 2.96 s (30), paused; robot 3 touched
    the trunk in tick 30, so it is red there, its line saying so."""
    assert _state(hashed) == {"tick": 30, "picked": 3, "playing": False, "zoom": 1}
    assert hashed.evaluate("document.getElementById('robot').value") == "3"
    assert hashed.evaluate("document.getElementById('robot-title').textContent") == "robot 3"
    info = hashed.evaluate("document.getElementById('robot-info').textContent")
    assert info == "collided; did not arrive (collision at 3.0 s)"
    assert hashed.evaluate("document.getElementById('clock').textContent") == \
        "t = 3.0 s / 120 s"
    shot = hashed.screenshot()
    assert _pixel(hashed, shot, *pose(3, 30)[:2]) == kind_rgb("failed")
    assert not _errors(hashed.events)


def test_keys_step_one_tick_and_the_failure_shows_from_its_tick(hashed):
    """'.' and '→' one tick forward, ',' and '←' back, Home and End the ends, Space plays and
    pauses; robot 3 is guided (pink) at tick 29, failed (red) from 30 on."""
    hashed.evaluate("window.fftnavPlayer.seek(3.0)")
    for key, tick in ((".", 31), ("ArrowRight", 32), (",", 31), ("ArrowLeft", 30),
                      ("ArrowLeft", 29)):
        _press(hashed, key)
        assert _state(hashed)["tick"] == tick, key
    assert FAILURE_TICKS[3] == 30 and expected_kind(3, 29) == "guided"
    assert _pixel(hashed, hashed.screenshot(), *pose(3, 29)[:2]) == kind_rgb("guided")
    _press(hashed, ".")
    assert _pixel(hashed, hashed.screenshot(), *pose(3, 30)[:2]) == kind_rgb("failed")
    _press(hashed, "End")
    assert _state(hashed)["tick"] == TICKS
    _press(hashed, "Home")
    assert _state(hashed)["tick"] == 0
    _press(hashed, " ")
    assert _state(hashed)["playing"] is True
    _press(hashed, " ")
    assert _state(hashed)["playing"] is False
    keys = " ".join(hashed.evaluate("document.getElementById('keys').textContent").split())
    for listed in ("one tick back", "one tick forward", "play / pause", "zoom in / out",
                   "reset the view", "#robot=3&t=54.2"):
        assert listed in keys
    assert not _errors(hashed.events)


def test_wheel_drag_keys_and_reset_zoom_and_pan_the_view(hashed):
    """The wheel zooms at the pointer (the point under it stays), '+' zooms further, a drag
    moves the map with the pointer without picking, the reset button brings the view back;
    every robot is still drawn in its colour where the view puts it."""
    hashed.evaluate("window.fftnavPlayer.seek(2.0)")
    x, y, _ = pose(2, 20)
    before = hashed.evaluate(f"window.fftnavPlayer.toPage({x}, {y})")
    hashed.call("Input.dispatchMouseEvent", type="mouseWheel", x=before[0], y=before[1],
                deltaX=0, deltaY=-100)
    assert _state(hashed)["zoom"] == pytest.approx(1.25)
    assert hashed.evaluate(f"window.fftnavPlayer.toPage({x}, {y})") == pytest.approx(before,
                                                                                    abs=0.5)
    _press(hashed, "+")
    assert _state(hashed)["zoom"] == pytest.approx(1.25 ** 2)
    zoomed = hashed.evaluate(f"window.fftnavPlayer.toPage({x}, {y})")
    start = (zoomed[0] + 30, zoomed[1] + 30)  # off the robots: a drag, not a pick
    hashed.call("Input.dispatchMouseEvent", type="mousePressed", x=start[0], y=start[1],
                button="left", clickCount=1)
    for k in range(1, 5):
        hashed.call("Input.dispatchMouseEvent", type="mouseMoved", x=start[0] + 10 * k,
                    y=start[1] + 5 * k, button="left", buttons=1)
    hashed.call("Input.dispatchMouseEvent", type="mouseReleased", x=start[0] + 40,
                y=start[1] + 20, button="left", clickCount=1)
    moved = hashed.evaluate(f"window.fftnavPlayer.toPage({x}, {y})")
    assert moved == pytest.approx([zoomed[0] + 40, zoomed[1] + 20], abs=0.5)
    assert _state(hashed)["picked"] == 3  # a drag picks no robot
    shot = hashed.screenshot()
    left, top, right, bottom = hashed.evaluate(
        "(({left, top, right, bottom}) => [left, top, right, bottom])"
        "(document.getElementById('map').getBoundingClientRect())")
    inside = []
    for i in range(4):
        px, py = hashed.evaluate(f"window.fftnavPlayer.toPage({pose(i, 20)[0]}, "
                                 f"{pose(i, 20)[1]})")
        if left + 5 < px < right - 5 and top + 5 < py < bottom - 5:
            inside.append(i)
    assert 2 in inside and len(inside) >= 2  # the robots the zoomed view still shows
    for i in inside:
        assert _pixel(hashed, shot, *pose(i, 20)[:2]) == kind_rgb(expected_kind(i, 20)), i
    hashed.evaluate("document.getElementById('reset-view').click()")
    assert _state(hashed)["zoom"] == 1
    assert hashed.evaluate(f"window.fftnavPlayer.toPage({x}, {y})") == pytest.approx(before,
                                                                                    abs=0.5)
    _press(hashed, "+")
    _press(hashed, "0")
    assert _state(hashed)["zoom"] == 1
    assert not _errors(hashed.events)


def _dark_near(tools: DevTools, shot: np.ndarray, x: float, y: float) -> int:
    """How many near-black pixels lie within 3 px of the world point (x, y)."""
    px, py = (int(round(v)) for v in tools.evaluate(f"window.fftnavPlayer.toPage({x}, {y})"))
    return int((shot[py - 3:py + 4, px - 3:px + 4].max(axis=-1) < 60).sum())


def test_every_robots_scan_when_checked(hashed):
    """Robot 1 sees returns 1 m ahead (the other robots none): with robot 2 picked, its returns
    are drawn only under "every robot's scan"."""
    hashed.evaluate("window.fftnavPlayer.seek(2.0); window.fftnavPlayer.pick(2)")
    x, y, _ = pose(1, 20)
    ahead = [(x + np.cos(a), y + np.sin(a)) for a in np.radians([-60, -30, 30, 60])]
    assert hashed.evaluate("document.getElementById('layer-allscans').checked") is False
    off = hashed.screenshot()
    hashed.evaluate("document.getElementById('layer-allscans').click()")
    on = hashed.screenshot()
    for point in ahead:
        assert _dark_near(hashed, off, *point) == 0
        assert _dark_near(hashed, on, *point) > 0
    hashed.evaluate("window.fftnavPlayer.setLayer('allscans', false)")
    assert not _errors(hashed.events)


def test_a_hash_that_names_nothing_is_ignored(folder):
    """A robot or a time the recording does not have, or another key, changes nothing and logs
    no error; a later hash is followed (hashchange)."""
    tools = _open(_browser(), folder / "r.html", folder / "profile-bad",
                  "#robot=99&t=500&zoom=3")
    try:
        assert _state(tools) == {"tick": 0, "picked": 1, "playing": False, "zoom": 1}
        tools.evaluate("location.hash = '#robot=2&t=1.04'")
        tools.evaluate("new Promise((done) => setTimeout(done, 50))")
        assert _state(tools)["tick"] == 10 and _state(tools)["picked"] == 2
        for bad in ("#robot=abc&t=nan", "#robot=-1&t=-3", "#robot=1.5&t=", "#t=6.2"):
            tools.evaluate(f"location.hash = {bad!r}")
            tools.evaluate("new Promise((done) => setTimeout(done, 50))")
            assert (_state(tools)["tick"], _state(tools)["picked"]) == (10, 2), bad
        assert not _errors(tools.events)
    finally:
        tools.close()


def test_two_recordings_side_by_side_share_the_clock_and_the_view(folder):
    """Two panes, each drawing its recording at the same time; a step moves both, a zoom
    zooms both; the estimates' check box shows for the pane that has them."""
    tools = _open(_browser(), folder / "pair.html", folder / "profile-pair", "#t=2")
    try:
        tools.call("Emulation.setDeviceMetricsOverride", width=1300, height=900,
                   deviceScaleFactor=1, mobile=False)
        assert tools.evaluate("document.querySelectorAll('canvas.map').length") == 2
        assert tools.evaluate("document.getElementById('estimates-control').hidden") is False
        titles = tools.evaluate("[...document.querySelectorAll('.pane-title')]"
                                ".map((e) => e.textContent)")
        assert len(titles) == 2 and all(t.startswith("by-hand on forest") for t in titles)
        _press(tools, ".")
        panes = tools.evaluate("window.fftnavPlayer.panes")
        assert [p["tick"] for p in panes] == [21, 21] and [p["picked"] for p in panes] == [1, 1]
        shot = tools.screenshot()
        for pane in (0, 1):
            for i in range(4):
                assert _pixel(tools, shot, *pose(i, 21)[:2], pane) == kind_rgb(
                    expected_kind(i, 21)), (pane, i)
        x, y, _ = pose(0, 21)
        before = [tools.evaluate(f"window.fftnavPlayer.toPage({x}, {y}, {k})") for k in (0, 1)]
        _press(tools, "+")
        after = [tools.evaluate(f"window.fftnavPlayer.toPage({x}, {y}, {k})") for k in (0, 1)]
        assert after[0] != pytest.approx(before[0], abs=1.0)
        # the same world point moves the same way in both panes (one view)
        shift = [np.subtract(a, b) for a, b in zip(after, before, strict=True)]
        np.testing.assert_allclose(shift[0], shift[1], atol=0.5)
        assert not _errors(tools.events)
    finally:
        tools.close()

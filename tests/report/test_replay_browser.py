"""The HTML replay player in a real browser: headless Chromium (Debian's ``chromium``, ``make
install-browser``) driven over the Chrome DevTools Protocol through a pipe (no Python package
needed). The page must load from file:// with no network request and no console error, draw each
robot in its state's colour where the recording puts it, at the start and after playing, and
pick a robot by a click; with a recording of estimated poses (odometry), draw each robot's
estimate beside its true pose under the "show estimates" check box, and tell how far off the
picked robot's estimate is.

Skipped only when Chromium is missing on a developer's machine; with ``CI`` set, a missing
Chromium fails.
"""

from __future__ import annotations

import base64
import fcntl
import io
import json
import os
import queue
import re
import shutil
import subprocess
import threading
import time

import numpy as np
import pytest
from PIL import Image

from fftnav.episode.recording import read_recording
from fftnav.report.frames import ESTIMATE_LABEL, KINDS, TRUTH_LABEL, kind_rgb
from fftnav.report.replay import robot_kinds
from fftnav.report.replay_html import write_html
from tests.report.recordings import TICKS, estimate, expected_kind, make_recording, pose
from tests.report.small_results import fftnav, make_small_results

BROWSERS = ("chromium", "chromium-browser", "google-chrome")


def _browser() -> str:
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    if os.environ.get("CI"):
        pytest.fail("Chromium is missing in CI: run `make install-browser` before `make test`")
    pytest.skip("Chromium is not installed (make install-browser)")


def _above(fd: int, low: int) -> int:
    """``fd`` moved to a number >= ``low`` (close-on-exec, like the original)."""
    moved = fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, low)
    os.close(fd)
    return moved


class DevTools:
    """A Chrome DevTools Protocol session over ``--remote-debugging-pipe`` (fd 3: commands to
    the browser, fd 4: its answers and events, JSON messages ended by a NUL byte)."""

    def __init__(self, browser: str, profile: str) -> None:
        to_child, self._write = os.pipe()
        self._read, from_child = os.pipe()
        # the child's ends above fd 4, so that putting them at 3 and 4 clobbers neither
        to_child, from_child = (_above(fd, 10) for fd in (to_child, from_child))

        def fds() -> None:  # in the child, before exec: fds 3 and 4, inherited
            os.dup2(to_child, 3)
            os.dup2(from_child, 4)

        self.proc = subprocess.Popen(
            [browser, "--headless", "--no-sandbox", "--disable-gpu", "--remote-debugging-pipe",
             "--no-first-run", "--no-default-browser-check", "--disable-extensions",
             "--disable-background-networking", "--disable-component-update",
             f"--user-data-dir={profile}", "about:blank"],
            close_fds=False, preexec_fn=fds,
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_child)
        os.close(from_child)
        self.events: list[dict] = []
        self._answers: queue.Queue = queue.Queue()
        self._next = 0
        threading.Thread(target=self._reader, daemon=True).start()
        self.session = None

    def _reader(self) -> None:
        buffer = b""
        while True:
            chunk = os.read(self._read, 1 << 16)
            if not chunk:
                self._answers.put(None)
                return
            buffer += chunk
            while b"\0" in buffer:
                message, buffer = buffer.split(b"\0", 1)
                data = json.loads(message)
                (self._answers.put if "id" in data else self.events.append)(data)

    def call(self, method: str, timeout: float = 15.0, **params) -> dict:
        self._next += 1
        message = {"id": self._next, "method": method, "params": params}
        if self.session and not method.startswith("Target."):
            message["sessionId"] = self.session
        os.write(self._write, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout
        while True:
            answer = self._answers.get(timeout=max(deadline - time.monotonic(), 0.01))
            assert answer is not None, "the browser closed the DevTools pipe"
            if answer["id"] == self._next:
                assert "error" not in answer, (method, answer["error"])
                return answer["result"]

    def evaluate(self, expression: str):
        result = self.call("Runtime.evaluate", expression=expression, awaitPromise=True,
                           returnByValue=True)
        assert "exceptionDetails" not in result, result["exceptionDetails"]
        return result["result"].get("value")

    def screenshot(self) -> np.ndarray:
        data = self.call("Page.captureScreenshot", format="png")["data"]
        return np.asarray(Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB"))

    def close(self) -> None:
        try:
            self.call("Browser.close", timeout=5)
        except (AssertionError, queue.Empty, OSError):
            pass
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        os.close(self._write)


def _open(browser: str, html, profile, hash: str = "") -> DevTools:
    """A DevTools session on ``html`` (opened at ``hash``, e.g. ``#robot=3&t=2``) once its
    player is ready."""
    tools = DevTools(browser, str(profile))
    target = tools.call("Target.createTarget", url="about:blank")["targetId"]
    tools.session = tools.call("Target.attachToTarget", targetId=target,
                               flatten=True)["sessionId"]
    for domain in ("Runtime", "Log", "Page", "Network"):
        tools.call(f"{domain}.enable")
    tools.call("Emulation.setDeviceMetricsOverride", width=1100, height=800,
               deviceScaleFactor=1, mobile=False)
    tools.call("Page.navigate", url=html.as_uri() + hash)
    deadline = time.monotonic() + 10
    while not tools.evaluate("!!(window.fftnavPlayer && window.fftnavPlayer.ready)"):
        assert time.monotonic() < deadline, "the player did not start"
        time.sleep(0.05)
    assert tools.evaluate("window.fftnavPlayer.ready") is True
    return tools


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    browser = _browser()
    folder = tmp_path_factory.mktemp("browser")
    make_recording(folder / "r.npz")
    html = folder / "r.html"
    write_html(read_recording(folder / "r.npz"), html, robot=1, speed=4.0)
    tools = _open(browser, html, folder / "profile")
    try:
        yield tools
    finally:
        tools.close()


def _errors(events: list[dict]) -> list[dict]:
    bad = []
    for e in events:
        method, params = e.get("method"), e.get("params", {})
        if method == "Runtime.exceptionThrown":
            bad.append(params)
        elif method == "Runtime.consoleAPICalled" and params.get("type") in ("error", "assert"):
            bad.append(params)
        elif method == "Log.entryAdded" and params["entry"]["level"] == "error":
            bad.append(params["entry"])
        elif method == "Network.requestWillBeSent":
            url = params["request"]["url"]
            if not url.startswith(("file:", "data:", "blob:", "about:")):
                bad.append({"network request": url})
    return bad


def _robot_pixels(tools: DevTools, shot: np.ndarray, tick: int) -> dict[int, tuple]:
    """Each robot's colour in the screenshot at its recorded pose (the player's transform)."""
    out = {}
    for i in range(4):
        x, y, _ = pose(i, tick)
        px, py = tools.evaluate(f"window.fftnavPlayer.toPage({x}, {y})")
        out[i] = tuple(int(c) for c in shot[int(round(py)), int(round(px))])
    return out


def read_recording_of(tools: DevTools):
    """The recording the page was written from (the fixture's folder)."""
    path = tools.evaluate("location.pathname").replace(".html", ".npz")
    return read_recording(path)


def test_start_frame_draws_every_robot_in_its_state_colour(page):
    shot = page.screenshot()
    assert page.evaluate("window.fftnavPlayer.tick") == 0
    for i, rgb in _robot_pixels(page, shot, 0).items():
        assert rgb == kind_rgb(expected_kind(i, 0)), (i, rgb)
    assert not _errors(page.events)


def test_playing_moves_the_robots_to_their_recorded_poses(page):
    page.evaluate("document.getElementById('play').click()")
    deadline = time.monotonic() + 8
    while page.evaluate("window.fftnavPlayer.playing"):  # 6 s at 4x: 1.5 s
        assert time.monotonic() < deadline, "the player did not reach the end"
        time.sleep(0.1)
    tick = page.evaluate("window.fftnavPlayer.tick")
    assert tick == TICKS
    shot = page.screenshot()
    kinds = robot_kinds(read_recording_of(page))[tick]
    for i, rgb in _robot_pixels(page, shot, tick).items():
        assert expected_kind(i, tick) == KINDS[kinds[i]]
        assert rgb == kind_rgb(expected_kind(i, tick)), (i, rgb)
    page.evaluate("window.fftnavPlayer.seek(2.0)")  # mid-episode: robot 0 still moving
    assert page.evaluate("window.fftnavPlayer.tick") == 20
    shot = page.screenshot()
    for i, rgb in _robot_pixels(page, shot, 20).items():
        assert rgb == kind_rgb(expected_kind(i, 20)), (i, rgb)
    assert not _errors(page.events)


def test_a_click_picks_the_robot_under_the_pointer(page):
    page.evaluate("window.fftnavPlayer.seek(1.0)")
    x, y, _ = pose(2, 10)
    px, py = page.evaluate(f"window.fftnavPlayer.toPage({x}, {y})")
    for kind in ("mousePressed", "mouseReleased"):
        page.call("Input.dispatchMouseEvent", type=kind, x=px, y=py, button="left",
                  clickCount=1)
    assert page.evaluate("window.fftnavPlayer.picked") == 2
    assert page.evaluate("document.getElementById('robot-title').textContent") == "robot 2"
    page.evaluate("window.fftnavPlayer.setLayer('trails', false)")
    assert not _errors(page.events)


def test_a_page_without_estimates_shows_none(page):
    assert page.evaluate("window.fftnavPlayer.estimates") is False
    assert page.evaluate("document.getElementById('estimates-control').hidden") is True
    assert "estimate" not in page.evaluate("document.getElementById('robot-info').textContent")
    legend = page.evaluate("document.getElementById('legend').textContent")
    assert ESTIMATE_LABEL not in legend and TRUTH_LABEL not in legend
    assert not _errors(page.events)


@pytest.fixture(scope="module")
def estimated_page(tmp_path_factory):
    """The player of the hand-made recording with estimated poses, robot 1 picked."""
    browser = _browser()
    folder = tmp_path_factory.mktemp("estimated")
    make_recording(folder / "e.npz", estimates=True)
    html = folder / "e.html"
    write_html(read_recording(folder / "e.npz"), html, robot=1)
    tools = _open(browser, html, folder / "profile")
    try:
        yield tools
    finally:
        tools.close()


def _around(tools: DevTools, shot: np.ndarray, x: float, y: float, px_radius: int) -> np.ndarray:
    """The screenshot's pixels within ``px_radius`` of the world point (x, y)."""
    px, py = (int(round(v)) for v in tools.evaluate(f"window.fftnavPlayer.toPage({x}, {y})"))
    return shot[py - px_radius:py + px_radius + 1, px - px_radius:px + px_radius + 1].astype(int)


def test_estimates_are_drawn_beside_the_true_poses(estimated_page):
    """At 4.2 s every estimate is 0.42 m off along +x (tests/report/recordings.py): a dashed
    hollow disc there in the robot's colour, gone when "show estimates" is unchecked; the true
    discs unchanged; the picked robot's line tells how far off its estimate is."""
    page = estimated_page
    assert page.evaluate("window.fftnavPlayer.estimates") is True
    assert page.evaluate("document.getElementById('estimates-control').hidden") is False
    assert page.evaluate("document.getElementById('layer-estimates').checked") is True
    legend = page.evaluate("document.getElementById('legend').textContent")
    assert ESTIMATE_LABEL in legend and TRUTH_LABEL in legend
    page.evaluate("window.fftnavPlayer.seek(4.2)")
    assert page.evaluate("window.fftnavPlayer.tick") == 42
    info = page.evaluate("document.getElementById('robot-info').textContent")
    assert info == "follow (left); did not arrive; estimate off by 0.42 m"  # its mode and side
    on = page.screenshot()
    page.evaluate("window.fftnavPlayer.setLayer('estimates', false)")
    off = page.screenshot()
    page.evaluate("window.fftnavPlayer.setLayer('estimates', true)")
    radius = int(page.evaluate("Math.max(window.fftnavPlayer.header.r0 * "
                               "(640 - 24) / window.fftnavPlayer.header.size[0], 3)")) + 3
    for i in range(4):
        colour = np.array(kind_rgb(expected_kind(i, 42)))
        for shot in (on, off):  # the true disc, as without estimates
            assert tuple(_around(page, shot, *pose(i, 42)[:2], 0)[0, 0]) == tuple(colour), i
        ex, ey, _ = estimate(i, 42)
        near = [int((np.abs(_around(page, shot, ex, ey, radius) - colour).max(axis=-1)
                     <= 40).sum()) for shot in (on, off)]
        assert near[0] >= near[1] + 8, (i, near)  # drawn there, and gone when unchecked
    assert not _errors(page.events)


def test_a_recording_made_on_demand_opens_in_the_player(tmp_path):
    """The done-when of recordings on demand: a failure listed in a results folder's report.md,
    made by ``fftnav replay RESULTS_DIR --task TASK --out r.html`` without the recording the
    run kept, opens in the player, every robot drawn where and as the run's own recording
    says."""
    browser = _browser()
    results = make_small_results(tmp_path)
    listed = re.search(r"--task (\S+) --out", (results / "report.md").read_text()).group(1)
    kept = read_recording(results / "records" / f"{listed}.npz")  # the oracle, then removed
    shutil.rmtree(results / "records")
    done = fftnav("replay", results, "--task", listed, "--out", tmp_path / "r.html",
                  cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    tools = _open(browser, tmp_path / "r.html", tmp_path / "profile")
    try:
        tools.evaluate("window.fftnavPlayer.seek(2.0)")
        tick = tools.evaluate("window.fftnavPlayer.tick")
        assert tick == kept.tick_at(2.0 + 1e-9)
        shot = tools.screenshot()
        kinds = robot_kinds(kept)[tick]
        for i in range(kept.n_robots):
            x, y = kept.pose[tick, i, :2]
            px, py = tools.evaluate(f"window.fftnavPlayer.toPage({x}, {y})")
            rgb = tuple(int(c) for c in shot[int(round(py)), int(round(px))])
            assert rgb == kind_rgb(KINDS[kinds[i]]), (i, rgb)
        assert not _errors(tools.events)
    finally:
        tools.close()

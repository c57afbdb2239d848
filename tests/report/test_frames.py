"""The frame drawer (fftnav.report.frames) and the replay's frames of a recording
(fftnav.report.replay): pixels of rendered PNGs against the axes transform, states against a
recording made by hand."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from PIL import Image

from fftnav.episode.record import EpisodeRow
from fftnav.episode.recording import read_recording
from fftnav.report.frames import (
    ESTIMATE_LABEL,
    KIND_COLOURS,
    KINDS,
    MESSAGE_COLOUR,
    SAFE_COLOUR,
    STATUS_KINDS,
    TRUTH_LABEL,
    ScanView,
    SwarmFrame,
    draw_frame,
    kind_rgb,
    kinds_of,
    runs_of,
)
from fftnav.report.replay import (
    default_robot,
    frame_ticks,
    recording_frame,
    robot_kinds,
    write_image,
    write_video,
)
from fftnav.report.trajectories import episode_frame, plot_episode
from fftnav.states import Status
from fftnav.world import World
from tests.report.recordings import TICKS, estimate, expected_kind, make_recording, pose

R0 = 0.15
WORLD = World("forest", 0, (12.0, 8.0), (), np.zeros((7, 3)), np.array([[11.0, 7.5]] * 7))


def _render(frame: SwarmFrame, world: World = WORLD, painted: list | None = None):
    """The frame as pixels, and a function from world (m) to pixel (row, col); the painter
    is appended to ``painted``."""
    fig = Figure(figsize=(6, 4), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    painter = draw_frame(ax, world, frame, R0)
    if painted is not None:
        painted.append(painter)
    fig.canvas.draw()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")  # same size and layout as the canvas
    pixels = np.asarray(Image.open(buffer).convert("RGB"))
    height = fig.canvas.get_width_height()[1]
    transform = ax.transData

    def at(x, y):
        px, py = transform.transform((x, y))
        return pixels[int(height - py), int(px)]

    return pixels, at


def _blend(colour: str, alpha: float) -> np.ndarray:
    return 255 * (alpha * np.array(to_rgb(colour)) + (1 - alpha))


def test_every_state_has_its_colour_at_the_robots_pixel():
    poses = np.array([[1.0 + 1.6 * i, 4.0, 0.3 * i] for i in range(len(KINDS))])
    frame = SwarmFrame(poses=poses, kinds=np.arange(len(KINDS)))
    _, at = _render(frame)
    for i, kind in enumerate(KINDS):
        assert tuple(at(*poses[i, :2])) == kind_rgb(kind), kind
    # the heading: a dark tick out of the disc, 1.5 r0 ahead of robot 0 (yaw 0)
    assert at(1.0 + 1.5 * R0, 4.0).max() < 60
    assert tuple(at(1.0 - 1.5 * R0, 4.0)) == (255, 255, 255)  # nothing behind it


def test_a_failed_robot_has_a_cross_beyond_its_disc_and_its_cause():
    frame = SwarmFrame(poses=np.array([[6.0, 4.0, 0.0]]), kinds=np.array([KINDS.index("failed")]),
                       causes=["stuck"])
    pixels, at = _render(frame)
    d = 1.5 * R0
    for sx, sy in ((1, 1), (1, -1), (-1, 1), (-1, -1)):  # on the cross's diagonals
        assert tuple(at(6.0 + sx * d, 4.0 + sy * d)) == kind_rgb("failed")
    assert tuple(at(6.0 - d, 4.0)) == (255, 255, 255)  # between its arms
    moving = SwarmFrame(poses=np.array([[6.0, 4.0, 0.0]]), kinds=np.array([1]))
    _, at_moving = _render(moving)
    assert tuple(at_moving(6.0 + d, 4.0 + d)) == (255, 255, 255)  # no cross while moving


def test_picked_scan_safe_sectors_trails_goal_lines_and_messages():
    """Returns 1 m ahead; the beams behind safe, their sectors drawn out to l_th = 1.5 m (not
    to the 3 m range)."""
    angles = -math.pi + np.arange(360) * 2 * math.pi / 360
    ahead = np.abs(angles) < math.pi / 2
    scan = ScanView(angles, np.where(ahead, 1.0, 3.0), ~ahead, 3.0, safe_m=1.5)
    poses = np.array([[6.0, 4.0, 0.0], [2.0, 1.0, 0.0]])
    frame = SwarmFrame(poses=poses, kinds=np.array([1, 1]), picked=0, scan=scan,
                       trails=[np.array([[6.0, 1.0], [6.0, 4.0]]), np.zeros((0, 2))],
                       messages=np.array([[1, 0]]))
    _, at = _render(frame)
    assert at(7.0, 4.0).max() < 60  # a return 1 m ahead
    for behind_m in (0.5, 1.0, 1.4):  # safe, behind, within l_th
        assert np.abs(at(6.0 - behind_m, 4.0) - _blend(SAFE_COLOUR, 0.22)).max() <= 3
    for behind_m in (1.6, 2.0, 2.8):  # beyond l_th, within the range: no sector
        assert tuple(at(6.0 - behind_m, 4.0)) == (255, 255, 255), behind_m
    assert tuple(at(6.8, 5.0)) == (255, 255, 255)  # ahead, beyond the returns: nothing
    trail = at(6.0, 2.5).astype(int)
    assert trail[2] > trail[0] + 60  # the trail, in the moving colour (blue)
    message = at(*(poses[0, :2] + poses[1, :2]) / 2)
    assert np.abs(message - _blend(MESSAGE_COLOUR, 0.8)).max() <= 40
    # the dashed line to the goal (11, 7.5): drawn, with gaps
    line = [tuple(at(6.0 + 5.0 * f, 4.0 + 3.5 * f)) for f in np.linspace(0.3, 0.7, 40)]
    assert 5 <= sum(px != (255, 255, 255) for px in line) < 40


def test_runs_of_safe_beams_wrap_round_a_full_circle():
    mask = np.array([True, False, False, True, True, False, True])
    assert runs_of(mask, wrap=False) == [(0, 1), (3, 5), (6, 7)]
    assert runs_of(mask, wrap=True) == [(6, 1), (3, 5)]
    assert runs_of(np.ones(4, bool), wrap=True) == [(0, 4)]
    assert runs_of(np.zeros(4, bool), wrap=True) == []


def test_robot_kinds_follow_status_and_mode(recording):
    """By status and mode, a failed robot failed from its failure tick: robot 3 from the tick
    it touched the trunk (29: guided, 30: failed), robot 2 at the end tick."""
    kinds = robot_kinds(recording)
    for tick in (0, 29, 30, 31, 40, 41, TICKS - 1, TICKS):
        for i in range(4):
            assert KINDS[kinds[tick, i]] == expected_kind(i, tick), (i, tick)
    assert [KINDS[k] for k in kinds[29:32, 3]] == ["guided", "failed", "failed"]
    assert [KINDS[k] for k in kinds[TICKS - 1:, 2]] == ["escaping", "failed"]


def test_recording_frame_has_poses_trails_messages_and_the_picked_scan(recording):
    frame = recording_frame(recording, 20, 1)
    np.testing.assert_allclose(frame.poses, [pose(i, 20) for i in range(4)], atol=1e-5)
    assert len(frame.trails[2]) == 21 and frame.trails[2][0] == pytest.approx([4.0, 2.0])
    assert frame.messages.tolist() == [[0, 1]] and frame.time_s == pytest.approx(2.0)
    ahead = np.abs(recording.angles_rad) < math.pi / 2
    assert np.allclose(frame.scan.ranges_m[ahead], 1.0) and (frame.scan.safe == ~ahead).all()
    assert list(frame.causes) == ["", "", "slow", "collision"]
    assert default_robot(recording) == 1  # the first that did not arrive


def test_frame_ticks_window_and_speed(recording):
    assert frame_ticks(recording).tolist() == list(range(TICKS + 1))
    assert frame_ticks(recording, from_s=1.0, to_s=2.0, speed=5).tolist() == [10, 15, 20]
    with pytest.raises(ValueError, match=r"from_s must be <= to_s, got from_s=3.0, to_s=1.0"):
        frame_ticks(recording, from_s=3, to_s=1)
    with pytest.raises(ValueError, match=r"speed must be a finite number in \[0.1, 1000\], got speed=0"):
        frame_ticks(recording, speed=0)
    with pytest.raises(ValueError, match=r"to_s must be a finite number in \[0, 6\], got to_s=7"):
        frame_ticks(recording, to_s=7)


def test_write_image_refuses_a_robot_out_of_range(recording, tmp_path):
    with pytest.raises(ValueError, match=r"robot must be an integer in \[0, 3\], got robot=4"):
        write_image(recording, tmp_path / "x.png", robot=4)


def _row(robot, arrived, failure=""):
    return EpisodeRow(robot, "p", arrived, False, 1, 1, 1, 1.0 if arrived else 0.0, 1,
                      *[0] * 7, failure=failure)


def test_episode_plot_is_the_last_frame_of_the_same_drawing(tmp_path):
    paths = [np.array([[1.0, 1.0, 0.0], [1.0, 7.0, 1.5]]), np.array([[5.0, 1.0, 0.0],
                                                                      [5.0, 3.0, 0.5]])]
    frame = episode_frame(paths, [_row(0, True), _row(1, False, "stuck")])
    assert [KINDS[k] for k in frame.kinds] == ["arrived", "failed"]
    np.testing.assert_allclose(frame.poses, [[1.0, 7.0, 1.5], [5.0, 3.0, 0.5]])
    assert list(frame.causes) == ["", "stuck"] and len(frame.trails[0]) == 2
    _, at = _render(frame)
    assert tuple(at(5.0, 3.0)) == kind_rgb("failed") and tuple(at(1.0, 7.0)) == kind_rgb(
        "arrived")
    out = plot_episode(WORLD, paths, [_row(0, True), _row(1, False, "stuck")], tmp_path / "e.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_gif_frames_are_the_png_frames_on_the_gif_palette(recording, tmp_path):
    gif = write_video(recording, tmp_path / "r.gif", robot=1, from_s=2.0, to_s=4.0, speed=10)
    with Image.open(gif) as frames:
        assert frames.n_frames == 3  # 2, 3, 4 s
        frames.seek(2)
        last = np.asarray(frames.convert("RGB")).astype(int)
    png = np.asarray(Image.open(write_image(recording, tmp_path / "r.png", at_s=4.0, robot=1))
                     .convert("RGB")).astype(int)
    assert last.shape == png.shape
    assert (np.abs(last - png).max(axis=-1) > 40).mean() < 0.002
    for kind in ("moving", "following", "escaping", "failed"):  # exact on the palette
        where = (png == kind_rgb(kind)).all(-1)
        assert where.sum() > 20 and (last[where] == kind_rgb(kind)).all()


def test_every_gif_frame_over_the_ones_before_is_the_png_of_its_time(recording, tmp_path):
    """Frames after the first carry only what changed (the rest transparent): decoded in
    order, each is the PNG of its time, at any width."""
    gif = write_video(recording, tmp_path / "r.gif", robot=2, from_s=1.0, to_s=5.0, speed=20,
                      width_px=320)
    with Image.open(gif) as frames:
        assert frames.n_frames == 3 and frames.size[0] == 320  # 1, 3, 5 s
        decoded = []
        for k in range(frames.n_frames):
            frames.seek(k)
            decoded.append(np.asarray(frames.convert("RGB")).astype(int))
    for at_s, frame in zip((1.0, 3.0, 5.0), decoded, strict=True):
        png = write_image(recording, tmp_path / f"{at_s}.png", at_s=at_s, robot=2, width_px=320)
        png = np.asarray(Image.open(png).convert("RGB")).astype(int)
        assert frame.shape == png.shape
        assert (np.abs(frame - png).max(axis=-1) > 40).mean() < 0.002, at_s
    assert not np.array_equal(decoded[0], decoded[2])
    with pytest.raises(ValueError, match=r"width_px must be an integer in \[160, 4096\], got "):
        write_image(recording, tmp_path / "x.png", width_px=100)


def test_every_status_is_drawn_as_a_kind_with_a_colour_of_its_own():
    """Whatever statuses fftnav.states has: each is drawn (its kind in KINDS, with a colour),
    a status without a shared kind as a kind of its own named by its label, in a colour no
    other kind has; lost robots (Status.LOST) as "lost"."""
    assert set(STATUS_KINDS) == set(Status)
    drawn = [KINDS[k] for k in kinds_of(np.array([int(s) for s in Status]))]
    assert drawn == [STATUS_KINDS[s] for s in Status]
    assert STATUS_KINDS[Status.LOST] == "lost" and "lost" in KINDS
    assert set(KIND_COLOURS) == set(KINDS)
    assert len(set(KIND_COLOURS.values())) == len(KINDS)  # a colour of its own, each


def _near(pixels: np.ndarray, rgb, tolerance: int = 40) -> int:
    """How many pixels of ``pixels`` are within ``tolerance`` of ``rgb``."""
    return int((np.abs(pixels.astype(int) - np.array(rgb)).max(axis=-1) <= tolerance).sum())


def test_estimated_poses_are_dashed_hollow_discs_with_headings_and_paths():
    """A robot at (3, 4) that believes it is at (6, 4), heading +y: a hollow disc there (white
    inside) with its heading, in the robot's colour, its estimated path dashed, and a legend
    telling truth from estimate; the true disc as without estimates."""
    poses = np.array([[3.0, 4.0, 0.0]])
    est = np.array([[6.0, 4.0, math.pi / 2]])
    trail = np.array([[6.0, 1.0], [6.0, 4.0]])
    frame = SwarmFrame(poses=poses, kinds=np.array([KINDS.index("following")]),
                       estimates=est, estimate_trails=[trail])
    painted: list = []
    pixels, at = _render(frame, painted=painted)
    colour = kind_rgb("following")
    assert tuple(at(3.0, 4.0)) == colour  # the true disc, filled
    for dx in (-0.5 * R0, 0.5 * R0):  # the estimate: hollow (beside its path, which ends in it)
        assert tuple(at(6.0 + dx, 4.0)) == (255, 255, 255)
    heading = np.array([at(6.0 + dx, 4.0 + 1.5 * R0 + dy) for dx in (-0.02, 0, 0.02)
                        for dy in (-0.02, 0, 0.02)])
    assert _near(heading, colour, 60) >= 3  # the heading tick, +y, out of the hollow disc
    ring = np.array([at(6.0 + R0 * math.cos(a), 4.0 + R0 * math.sin(a))
                     for a in np.linspace(0, 2 * math.pi, 48, endpoint=False)])
    assert _near(ring, colour, 60) >= 12  # dashed: on much of the outline, not all of it
    path = np.array([at(6.0, y) for y in np.linspace(1.5, 3.5, 60)]).astype(int)
    tinted = path[(255 - path).max(axis=-1) > 15]
    assert 10 <= len(tinted) < 60  # dashed: drawn, with gaps
    assert (tinted[:, 0] > tinted[:, 2] + 15).all()  # in the robot's colour (orange)
    texts = [t.get_text() for t in painted[0].legend.get_texts()]
    assert texts[-2:] == [TRUTH_LABEL, ESTIMATE_LABEL]  # the key lists truth and estimate


def _legend_texts(painter) -> list[str]:
    return [t.get_text() for t in painter.legend.get_texts()]


def test_a_frame_without_estimates_draws_none_of_them():
    """A frame without estimates lists no estimates in its key and draws no estimated pose or
    path; a painter that drew estimates hides them again for such a frame."""
    frame = SwarmFrame(poses=np.array([[3.0, 4.0, 0.0]]), kinds=np.array([1]),
                       trails=[np.array([[1.0, 4.0], [3.0, 4.0]])])
    painted: list = []
    _render(frame, painted=painted)
    painter = painted[0]
    assert ESTIMATE_LABEL not in _legend_texts(painter)
    assert len(painter.estimate_robots.get_offsets()) == 0
    assert not painter.estimate_trails.get_segments()
    # a later frame with estimates lists them; one without drops them again
    painter.update(SwarmFrame(poses=frame.poses, kinds=frame.kinds,
                              estimates=np.array([[5.0, 4.0, 0.0]])))
    assert _legend_texts(painter)[-2:] == [TRUTH_LABEL, ESTIMATE_LABEL]
    painter.update(frame)
    assert TRUTH_LABEL not in _legend_texts(painter)
    assert len(painter.estimate_robots.get_offsets()) == 0


@pytest.fixture(scope="module")
def estimated(tmp_path_factory):
    """The hand-made recording with its estimated poses (tests/report/recordings.py)."""
    path = tmp_path_factory.mktemp("rec") / "estimated.npz"
    make_recording(path, estimates=True)
    return read_recording(path)


def test_recording_frame_has_the_estimated_poses_and_paths(recording, estimated):
    assert recording_frame(recording, 20, 1).estimates is None
    frame = recording_frame(estimated, 42, 1)
    np.testing.assert_allclose(frame.estimates, [estimate(i, 42) for i in range(4)], atol=1e-5)
    np.testing.assert_allclose(frame.poses, [pose(i, 42) for i in range(4)], atol=1e-5)
    assert len(frame.estimate_trails[2]) == 43
    assert frame.estimate_trails[2][-1] == pytest.approx(estimate(2, 42)[:2], abs=1e-5)


def test_png_and_gif_frames_draw_the_estimates(recording, estimated, tmp_path):
    """The PNG of a recording with estimates is that of the same recording without them but
    near the estimated poses and paths (and the legend); a GIF of it is written."""
    with_est = np.asarray(Image.open(write_image(estimated, tmp_path / "e.png", at_s=4.2,
                                                 robot=1)).convert("RGB")).astype(int)
    exact = np.asarray(Image.open(write_image(recording, tmp_path / "x.png", at_s=4.2,
                                              robot=1)).convert("RGB")).astype(int)
    # the same title and map (640 x 512 px under a 24 px title); the key lists two entries more
    assert with_est.shape[1] == exact.shape[1] and with_est.shape[0] > exact.shape[0]
    changed = np.abs(with_est[:536] - exact[:536]).max(axis=-1) > 40
    assert 0.002 < changed.mean() < 0.05
    gif = write_video(estimated, tmp_path / "e.gif", robot=1, from_s=2.0, to_s=4.0, speed=10)
    with Image.open(gif) as frames:
        assert frames.n_frames == 3

"""The HTML replay player: one self-contained file that works offline (``fftnav replay
PATH [PATH ...] --out X.html``), one pane per recording, side by side on one clock.

The page is the template ``replay_player.html`` (package data of :mod:`fftnav.report`) with two
things put in: a JSON header, ``{"panes": [...]}``, one object per recording (the world's
obstacle outlines, goals, robot radius, the beam angles, the safe sectors' radius ``safeM``
(l_th), the time limit ``limitS`` the clock counts to, the colours and opacities of
:mod:`fftnav.report.frames` and its legend's names, the drawn kinds' names (and which of them
drive), the labels of :mod:`fftnav.states` (``statusLabels``, ``stateLabels``, ``sideNames``) to
name the planner's mode and side, each robot's outcome and failure tick
(:func:`fftnav.report.replay.failure_ticks`, ``failTicks``, counted from the window's first
tick), whether the recording has estimated poses (``estimates``) with the legend's names for
them, and where each array lies in the data), and each recording's data, one zlib-deflated
block of little-endian arrays, base64-encoded (script ``fftnav-data-K`` of pane K), which the
page inflates with the browser's own ``DecompressionStream``:

=============== ========= ==========================================================
array           type      shape
=============== ========= ==========================================================
``time``        float32   (G,) episode time of each tick (s)
``pose``        float32   (G, N, 3) x, y (m), yaw (rad)
``kind``        uint8     (G, N) drawn state (:func:`fftnav.report.replay.robot_kinds`)
``status``      uint8     (G, N) drawn status (:func:`fftnav.report.replay.drawn_status`)
``scan``        uint8/16  (G, N, M) range in steps of ``scanStep`` m (0: none)
``safe``        uint8     (G, N, ceil(M / 8)) safe mask, bit-packed (``numpy.packbits``)
``state``       float32   (S, G, N) the controller's state values, then command v, w
``msgStart``    int32     (G + 1,) messages delivered in tick g: ``msg[msgStart[g]:...]``
``msg``         int32     (D, 2) sender, receiver
``estimate``    float32   (G, N, 3) estimated x, y (m), yaw (rad), NaN: none; only
                          when the recording has estimates
=============== ========= ==========================================================

No script, style or data comes from elsewhere: the page makes no network request. The page
opens at its URL's hash ``#robot=R&t=S``: robot R picked, the clock at the tick nearest S s,
paused (a value that is not a robot or a time of the window is ignored). The player exposes
``window.fftnavPlayer`` (``ready``, ``play``, ``pause``, ``seek``, ``step``, ``pick``,
``zoom``, ``resetView``, ``setLayer``, ``toCanvas``, ``toPage``, ``tick``, ``time``, ``picked``,
``view``, ``panes``, and ``estimates``: whether the page has estimated poses) for scripting and
the browser test. With estimates, the page draws each robot's estimated pose (a dashed hollow
disc and its heading) and path (dashed) in its colour, under a check box "show estimates", and
the picked robot's line tells how far its estimate is from its true position.
"""

from __future__ import annotations

import base64
import json
import zlib
from collections.abc import Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from fftnav.episode.recording import Recording
from fftnav.report.frames import (
    DRIVING,
    ESTIMATE_LABEL,
    FAILED_KINDS,
    KEY_LABELS,
    KIND_COLOURS,
    KINDS,
    MESSAGE_ALPHA,
    MESSAGE_COLOUR,
    SAFE_ALPHA,
    SAFE_COLOUR,
    SIDE_NAMES,
    TRAIL_ALPHA,
    TRUTH_LABEL,
    safe_label,
    seconds_text,
)
from fftnav.report.replay import (
    MIN_SPEED,
    check_robot,
    drawn_status,
    end_s,
    failure_ticks,
    limit_s,
    robot_kinds,
    safe_radius_m,
    window,
)
from fftnav.states import State, Status
from fftnav.validate import check_number

__all__ = ["TEMPLATE", "player_data", "write_html"]

#: The player's page, with ``/*FFTNAV_HEADER*/`` (the header) and ``<!--FFTNAV_DATA-->`` (the
#: data scripts) to fill in.
TEMPLATE = "replay_player.html"


def _window(rec: Recording, from_s: float | None, to_s: float | None) -> tuple[int, int]:
    """The ticks ``g0 .. g1 - 1`` of the window (:func:`fftnav.report.replay.window`)."""
    start, stop = window(rec, from_s, to_s)
    return rec.tick_at(start + 1e-9), rec.tick_at(stop + 1e-9) + 1


def _arrays(rec: Recording, g0: int, g1: int) -> tuple[dict[str, np.ndarray], list[str]]:
    """The player's arrays of ticks ``g0 .. g1 - 1`` and the names of its state plots."""
    step = float(rec.meta.get("scan_step_m", 0.02))
    status = drawn_status(rec)
    scan = np.rint(rec.scan_m[g0:g1] / step)
    delivered = rec.delivered[(rec.delivered[:, 0] >= g0) & (rec.delivered[:, 0] < g1)]
    delivered = delivered[np.argsort(delivered[:, 0], kind="stable")]
    names = [*rec.state, "command v (m/s)", "command w (rad/s)"]
    state = np.stack([*(rec.state[k][g0:g1] for k in rec.state),
                      rec.command[g0:g1, :, 0], rec.command[g0:g1, :, 1]])
    arrays = {
        "time": rec.time_s[g0:g1].astype("<f4"),
        "pose": rec.pose[g0:g1].astype("<f4"),
        "kind": robot_kinds(rec, status)[g0:g1].astype(np.uint8),
        "status": status[g0:g1].astype(np.uint8),
        "scan": scan.astype("<u2" if scan.max(initial=0) > 255 else np.uint8),
        "safe": np.packbits(rec.safe[g0:g1], axis=-1),
        "state": state.astype("<f4"),
        "msgStart": np.searchsorted(delivered[:, 0], np.arange(g0, g1 + 1)).astype("<i4"),
        "msg": delivered[:, 1:3].astype("<i4"),
    }
    if rec.estimates is not None:
        arrays["estimate"] = rec.estimates[g0:g1].astype("<f4")
    return arrays, names


def _pack(arrays: dict[str, np.ndarray]) -> tuple[bytes, dict[str, list[Any]]]:
    """The arrays in one buffer, each at an offset that is a multiple of 4 (typed-array views),
    and where each lies: name -> [offset, type, length]."""
    types = {"<f4": "Float32Array", "|u1": "Uint8Array", "<u2": "Uint16Array",
             "<i4": "Int32Array"}
    chunks, layout, offset = [], {}, 0
    for name, array in arrays.items():
        data = np.ascontiguousarray(array).tobytes()
        layout[name] = [offset, types[array.dtype.str], int(array.size)]
        pad = -len(data) % 4
        chunks.append(data + b"\0" * pad)
        offset += len(data) + pad
    return b"".join(chunks), layout


def player_data(rec: Recording, *, robot: int | None = None, from_s: float | None = None,
                to_s: float | None = None, speed: float = 1.0) -> tuple[dict[str, Any], bytes]:
    """The player's JSON header and its deflated data (module docstring)."""
    picked = check_robot(rec, robot)
    speed = check_number("speed", speed, low=MIN_SPEED, high=1000.0)
    g0, g1 = _window(rec, from_s, to_s)
    arrays, names = _arrays(rec, g0, g1)
    blob, layout = _pack(arrays)
    world = rec.world
    failed = failure_ticks(rec)
    header = {
        "title": f"{rec.policy} on {world.env} (map seed {world.seed}, episode seed {rec.seed})",
        "size": list(world.size_m), "boundary": world.boundary,
        "obstacles": [np.round(o.outline(), 3).tolist() for o in world.obstacles],
        "goals": np.round(world.goals, 3).tolist(), "r0": rec.config.robot.r0_m,
        "rangeM": rec.config.sensor.range_m, "scanStep": float(rec.meta.get("scan_step_m", 0.02)),
        "angles": np.round(rec.angles_rad, 6).tolist(), "ticks": g1 - g0, "robots": rec.n_robots,
        "kinds": list(KINDS), "colours": [KIND_COLOURS[k] for k in KINDS],
        "driving": [KINDS.index(k) for k in DRIVING],
        "messageColour": MESSAGE_COLOUR, "safeColour": SAFE_COLOUR, "stateNames": names,
        "alphas": {"trail": TRAIL_ALPHA, "safe": SAFE_ALPHA, "message": MESSAGE_ALPHA},
        "failed": [KINDS.index(k) for k in FAILED_KINDS],
        "outcomes": [{"arrived": bool(r.get("arrived")), "failure": r.get("failure") or "",
                      "failedAt": (round(float(rec.time_s[failed[i]]), 6) if i in failed
                                   else None)}
                     for i, r in enumerate(rec.rows)],
        "failTicks": [max(failed[i] - g0, 0) if i in failed and failed[i] < g1 else None
                      for i in range(rec.n_robots)],
        "limitS": limit_s(rec), "limitText": seconds_text(limit_s(rec)),
        "safeM": safe_radius_m(rec),
        "keyLabels": {**KEY_LABELS, "safe": safe_label(safe_radius_m(rec))},
        "statusLabels": list(Status.labels()), "stateLabels": list(State.labels()),
        "sideNames": {str(k): v for k, v in SIDE_NAMES.items()},
        "picked": picked, "speed": speed, "arrays": layout,
        "estimates": rec.estimates is not None,
        "estimateLabels": {"truth": TRUTH_LABEL, "estimate": ESTIMATE_LABEL},
    }
    return header, zlib.compress(blob, 9)


def write_html(rec: Recording, path: str | Path, *, robot: int | None = None,
               from_s: float | None = None, to_s: float | None = None,
               speed: float = 1.0, beside: Sequence[Recording] = ()) -> Path:
    """Write the self-contained HTML player of ``rec`` (or of its window ``from_s`` ..
    ``to_s``), the robot ``robot`` picked, playing at ``speed``, with a pane for each recording
    of ``beside`` to its right on the same clock (each window clamped to its episode's end, the
    same robot picked where it has it, else its default); returns the path."""
    header, data = player_data(rec, robot=robot, from_s=from_s, to_s=to_s, speed=speed)
    panes, blocks = [header], [data]
    for other in beside:
        end = end_s(other)
        pane, block = player_data(
            other, robot=header["picked"] if header["picked"] < other.n_robots else None,
            from_s=None if from_s is None else min(from_s, end),
            to_s=None if to_s is None else min(to_s, end), speed=speed)
        panes.append(pane)
        blocks.append(block)
    page = resources.files("fftnav.report").joinpath(TEMPLATE).read_text(encoding="utf-8")
    text = json.dumps({"panes": panes}, separators=(",", ":")).replace("<", "\\u003c")
    scripts = "\n".join(f'<script type="application/octet-stream" id="fftnav-data-{k}">'
                        f'{base64.b64encode(block).decode("ascii")}</script>'
                        for k, block in enumerate(blocks))
    # the data first: the header's names (a policy, an env) may hold any text
    page = page.replace("<!--FFTNAV_DATA-->", scripts, 1)
    page = page.replace("/*FFTNAV_HEADER*/", text, 1)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(page, encoding="utf-8")
    return path

"""Episode recordings: everything one episode's robots saw, decided, sent and touched, per tick.

A recording is one file per episode that replays with nothing else: the world, the swarm
configuration, the policy's name and the seed, and per control tick and robot the pose, the
command, the controller's state (:meth:`fftnav.navigation.controllers.Controller.state`), the
lidar scan (quantised), the FFT pipeline's safe mask (bit-packed), the contacts, the
messages sent and delivered, and, when the robots localize by their own odometry
(``[localization] mode = "odometry"``), the pose each robot estimated. ``fftnav replay`` draws it
(docs/analysis.md).

Format: a NumPy ``.npz`` archive (a zip of ``.npy`` arrays, deflate-compressed), one array per
column. It needs nothing beyond NumPy to read, each column loads on its own, and the deflate
pass shrinks the scans (mostly "no return") several times. The ``meta`` entry is UTF-8 JSON
with ``format`` (:data:`FORMAT`) and ``version`` (:data:`VERSION`); the reader refuses other
formats and newer versions, and reads every earlier one: version 1 differs only in that its
``state/mode`` never holds ``GUIDED`` (5), version 2 in that its ``status`` never holds
``LOST`` (5) and it has no ``estimates``, so their codes read the same. The columns, with
G ticks, N robots and M beams:

========================= ================ ==================================================
column                    dtype, shape     meaning
========================= ================ ==================================================
``time_s``                float64 (G,)     episode time at the start of the tick (s)
``pose``                  float32 (G,N,3)  x (m), y (m), yaw (rad) the tick's scan was taken at
``estimates``             float32 (G,N,3)  the pose each robot estimated at that time (x, y,
                                           yaw), NaN at a tick without one; only in a
                                           recording whose episode passed estimates
``command``               float32 (G,N,2)  the command of the tick: v (m/s), w (rad/s)
``status``                uint8 (G,N)      :class:`~fftnav.states.Status` code: 0 waiting,
                                           1 moving, 2 arrived, 3 collided, 4 timed_out,
                                           5 lost (at the start of the tick)
``scan``                  uint8/16 (G,N,M) range in steps of ``meta["scan_step_m"]`` (0.02 m:
                                           at most 1 cm error); 0 for robots not moving
``safe_bits``             uint8 (G,N,M/8)  the safe mask, ``numpy.packbits`` along beams
``contact_obstacle``      bool (G,N)       Bullet contact with an obstacle during the tick
``contact_robot``         bool (G,N)       ... with another robot
``state/<name>``          float32 (G,N)    the controller's state after the tick's step, NaN
                                           when absent; the Bug controller's ``state/mode``
                                           is a :class:`~fftnav.states.State` code: 0 goal,
                                           1 follow, 2 escape, 3 done, 4 wait, 5 guided
``sent_tick``             int32 (S,)       messages broadcast: tick, sender
``sent_robot``            int16 (S,)
``sent_offset``           int64 (S+1,)     ``sent_bytes[sent_offset[k]:sent_offset[k+1]]``
``sent_bytes``            uint8 (B,)       the payloads, concatenated
``delivered``             int32 (D,4)      packets delivered: tick, sender, receiver, sent tick
========================= ================ ==================================================

The ``estimates`` column is optional: the reader reads a recording with or without it (of any
version), and an episode without estimates (``Tape.tick(..., estimates=None)``) writes no such
column.

The last tick (``G - 1``) is the end of the episode: poses and statuses only.

>>> import numpy as np
>>> bits = np.packbits(np.array([[True, False, True]]), axis=-1)
>>> np.unpackbits(bits, axis=-1, count=3).astype(bool)
array([[ True, False,  True]])
"""

from __future__ import annotations

import io
import json
import math
import os
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fftnav.config import SwarmConfig
from fftnav.errors import FftnavError
from fftnav.files import check_input, check_target, write_atomic
from fftnav.states import State, Status
from fftnav.world.model import World

__all__ = ["FORMAT", "SCAN_STEP_M", "VERSION", "Recording", "RecordingError", "Tape",
           "read_recording", "write_recording"]

#: The ``format`` of a recording's ``meta``.
FORMAT = "fftnav-recording"
#: Schema version written (2: ``state/mode`` may hold ``State.GUIDED``); the reader reads this
#: version and earlier ones.
VERSION = 3
#: Quantisation step of the recorded scans (m): the error is at most half of it.
SCAN_STEP_M = 0.02


class RecordingError(FftnavError):
    """A file that is not a readable recording."""


@dataclass(frozen=True)
class Recording:
    """One recorded episode (:func:`read_recording`); arrays as in the module's table, with the
    scans in metres and the safe masks unpacked.

    Attributes
    ----------
    world : World
    config : SwarmConfig
    policy : str
    seed : int
    rows : list of dict
        The episode's rows (``episodes.csv`` columns), one per robot.
    angles_rad : ndarray, (M,)
        Beam angles, CCW from the heading.
    estimates : ndarray, (G, N, 3), or None
        Each robot's estimated pose (x, y in m, yaw in rad; NaN at a tick without one), or None
        when the recording has none (exact localization).
    """

    world: World
    config: SwarmConfig
    policy: str
    seed: int
    rows: list[dict[str, Any]]
    angles_rad: np.ndarray
    time_s: np.ndarray
    pose: np.ndarray
    command: np.ndarray
    status: np.ndarray
    scan_m: np.ndarray
    safe: np.ndarray
    contact_obstacle: np.ndarray
    contact_robot: np.ndarray
    state: dict[str, np.ndarray]
    sent_tick: np.ndarray
    sent_robot: np.ndarray
    sent_payloads: list[bytes]
    delivered: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)
    estimates: np.ndarray | None = None

    @property
    def n_ticks(self) -> int:
        return len(self.time_s)

    @property
    def n_robots(self) -> int:
        return self.pose.shape[1]

    def tick_at(self, time_s: float) -> int:
        """The last tick at or before ``time_s`` (clamped to the recording)."""
        return int(np.clip(np.searchsorted(self.time_s, time_s, side="right") - 1,
                           0, self.n_ticks - 1))


class Tape:
    """Collects an episode tick by tick (:class:`fftnav.episode.core.EpisodeCore` calls it)
    and packs it into a recording's columns (:meth:`to_bytes`)."""

    def __init__(self, world: World, config: SwarmConfig, policy: str, seed: int,
                 angles_rad: np.ndarray) -> None:
        self.world, self.config, self.policy, self.seed = world, config, policy, seed
        self.angles_rad = np.asarray(angles_rad, dtype=np.float64)
        n = len(world.starts)
        self.n = n
        self.pose = np.zeros((n, 3))
        self.ticks: list[dict[str, Any]] = []
        self.sent: list[tuple[int, int, bytes]] = []
        self.delivered: list[tuple[int, int, int, int]] = []
        self.state_names: dict[str, None] = {}
        self.estimated = False  # whether any tick had estimates: then the column is stored
        steps = math.ceil(config.sensor.range_m / SCAN_STEP_M)
        self.scan_dtype = np.uint8 if steps <= np.iinfo(np.uint8).max else np.uint16

    def tick(self, time_s: float, poses: np.ndarray, status: np.ndarray, *,
             commands: np.ndarray, ranges_m: np.ndarray, safe: np.ndarray | None,
             state: Mapping[int, Mapping[str, float]],
             estimates: np.ndarray | None = None) -> None:
        """One control tick: poses at the scan, statuses (:class:`~fftnav.states.Status` codes),
        commands, ranges (m, finite, >= 0) and safe masks of every robot (zeros for robots not
        moving; arrays the episode does not modify afterwards), the controller's state of the
        moving robots, and the poses the robots estimated (``estimates``, (N, 3): x, y, yaw;
        None when the robots know their true poses). The scans are quantised now, the rest
        packed by :meth:`columns`.

        Raises
        ------
        FftnavError
            ``estimates`` is not of shape (N, 3).
        """
        for values in state.values():
            self.state_names.update(dict.fromkeys(values))
        scan = ranges_m * (1.0 / SCAN_STEP_M) + 0.5  # rounded by the cast (ranges >= 0)
        self.ticks.append({"time_s": time_s, "pose": poses.copy(), "status": status,
                           "command": commands.copy(), "scan": scan.astype(self.scan_dtype),
                           "safe": safe, "estimates": self._estimates(estimates),
                           "state": state, "contact_obstacle": None, "contact_robot": None})

    def _estimates(self, estimates: np.ndarray | None) -> np.ndarray | None:
        """A copy of a tick's estimated poses, checked to be (N, 3); None stays None."""
        if estimates is None:
            return None
        array = np.array(estimates, dtype=np.float64)
        if array.shape != (self.n, 3):
            raise FftnavError(f"estimates must be an array of shape ({self.n}, 3), got "
                              f"estimates.shape={array.shape}")
        self.estimated = True
        return array

    def contacts(self, obstacle: np.ndarray, robot: np.ndarray) -> None:
        """The contacts Bullet reported while the last tick's commands ran."""
        self.ticks[-1]["contact_obstacle"] = np.asarray(obstacle, bool).copy()
        self.ticks[-1]["contact_robot"] = np.asarray(robot, bool).copy()

    def message(self, tick: int, sender: int, payload: bytes) -> None:
        self.sent.append((tick, sender, bytes(payload)))

    def delivery(self, tick: int, sender: int, receiver: int, sent_tick: int) -> None:
        self.delivered.append((tick, sender, receiver, sent_tick))

    def end(self, time_s: float, poses: np.ndarray, status: np.ndarray, *,
            estimates: np.ndarray | None = None) -> None:
        """The end of the episode: a last tick with poses, statuses and (``estimates``, as in
        :meth:`tick`) the estimated poses only."""
        zeros = np.zeros((self.n, len(self.angles_rad)))
        self.tick(time_s, poses, status, commands=np.zeros((self.n, 2)), ranges_m=zeros,
                  safe=None, state={}, estimates=estimates)

    def columns(self, rows: Sequence[Mapping[str, Any]]) -> dict[str, np.ndarray]:
        """The recording's columns (the ``meta`` column carries ``rows``)."""
        g, shape = len(self.ticks), (self.n, len(self.angles_rad))
        no_contact = np.zeros(self.n, bool)
        cols: dict[str, np.ndarray] = {
            "time_s": np.array([t["time_s"] for t in self.ticks], dtype=np.float64),
            "pose": np.stack([t["pose"] for t in self.ticks]).astype(np.float32),
            **self._estimates_column(),
            "command": np.stack([t["command"] for t in self.ticks]).astype(np.float32),
            "status": np.stack([t["status"] for t in self.ticks]).astype(np.uint8),
            "scan": np.stack([t["scan"] for t in self.ticks]),
            "safe_bits": np.packbits(np.stack([np.zeros(shape, bool) if t["safe"] is None
                                               else t["safe"] for t in self.ticks]), axis=-1),
        }
        for key in ("contact_obstacle", "contact_robot"):
            cols[key] = np.stack([no_contact if t[key] is None else t[key] for t in self.ticks])
        for name in self.state_names:
            col = np.full((g, self.n), np.nan, dtype=np.float32)
            for k, t in enumerate(self.ticks):
                for i, values in t["state"].items():
                    col[k, i] = values.get(name, np.nan)
            cols[f"state/{name}"] = col
        cols.update(self._messages())
        cols["meta"] = np.frombuffer(json.dumps(self._meta(rows)).encode(), dtype=np.uint8)
        return cols

    def _estimates_column(self) -> dict[str, np.ndarray]:
        """``{"estimates": (G, N, 3) float32}``, NaN at the ticks without estimates, when any
        tick had them; else nothing."""
        if not self.estimated:
            return {}
        missing = np.full((self.n, 3), np.nan)
        return {"estimates": np.stack([missing if t["estimates"] is None else t["estimates"]
                                       for t in self.ticks]).astype(np.float32)}

    def _messages(self) -> dict[str, np.ndarray]:
        payloads = [p for _, _, p in self.sent]
        return {
            "sent_tick": np.array([t for t, _, _ in self.sent], dtype=np.int32),
            "sent_robot": np.array([r for _, r, _ in self.sent], dtype=np.int16),
            "sent_offset": np.concatenate([[0], np.cumsum([len(p) for p in payloads])]
                                          ).astype(np.int64),
            "sent_bytes": np.frombuffer(b"".join(payloads), dtype=np.uint8),
            "delivered": np.array(self.delivered, dtype=np.int32).reshape(-1, 4),
        }

    def _meta(self, rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
        return {"format": FORMAT, "version": VERSION, "policy": self.policy, "seed": self.seed,
                "scan_step_m": SCAN_STEP_M, "beams": len(self.angles_rad),
                "angles_rad": self.angles_rad.tolist(), "status": list(Status.labels()),
                "states": list(State.labels()),
                "world": json.loads(self.world.to_json()),
                "config": self.config.to_sections(),
                "rows": [_jsonable(row) for row in rows]}

    def to_bytes(self, rows: Sequence[Mapping[str, Any]]) -> bytes:
        """The recording file's bytes (a compressed ``.npz``)."""
        buffer = io.BytesIO()
        np.savez_compressed(buffer, allow_pickle=False, **self.columns(rows))
        return buffer.getvalue()


def _jsonable(row: Mapping[str, Any]) -> dict[str, Any]:
    out = {}
    for key, value in row.items():
        if isinstance(value, (np.generic,)):
            value = value.item()
        if isinstance(value, float) and not math.isfinite(value):
            value = None
        out[key] = value
    return out


def write_recording(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write a recording's bytes to ``path`` atomically (:func:`fftnav.files.write_atomic`: a
    temporary file beside it, renamed over it), creating the folder.

    Raises
    ------
    ValueError
        ``path`` cannot be written (:func:`fftnav.files.check_target`: a folder, a FIFO or a
        device, a folder that cannot be made).
    """
    check_target(path, make_folder=True)
    write_atomic(path, data)
    return Path(path)


def read_recording(path: str | os.PathLike[str]) -> Recording:
    """Read a recording written by an episode (``fftnav episode --record``, or an experiment's
    ``records/``).

    Raises
    ------
    RecordingError
        ``path`` is not a recording (not an ``.npz``, damaged data, no ``meta``, another format
        or a newer version, a missing column or meta key, columns whose shapes disagree, times
        that are not finite or do not increase, poses that are not finite, status or mode codes
        that do not exist), naming the column and the tick.
    """
    if isinstance(path, (str, os.PathLike)):
        check_input(path)  # a FIFO or device refused by stat, never opened
    try:
        with np.load(path, allow_pickle=False) as npz:
            cols = {key: npz[key] for key in npz.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError, zlib.error) as exc:
        raise RecordingError(f"path must be an fftnav recording, got path={str(path)!r} "
                             f"({_why_not(exc)})") from None
    meta = _read_meta(path, cols)
    try:
        _check_shapes(cols, meta)
        _check_values(cols)
        return _decode(cols, meta)
    except KeyError as exc:
        where = "meta key" if exc.args and exc.args[0] in _META_KEYS else "column"
        raise RecordingError(f"path must be a complete fftnav recording, got path={str(path)!r}"
                             f" (no {where} {exc})") from None
    except (TypeError, ValueError, IndexError) as exc:
        raise RecordingError(f"path must be a consistent fftnav recording, got "
                             f"path={str(path)!r} ({exc})") from None


def _why_not(exc: Exception) -> str:
    """What numpy's refusal to load a file means for a recording, in our words: numpy's advice to
    load pickled data unsafely is never the way to a recording."""
    text = str(exc).lower()
    if "object arrays" in text:
        return "an .npz of Python objects, not of an fftnav recording's arrays"
    if "pickle" in text:
        return "not an .npz archive of arrays: neither an fftnav recording nor numpy data"
    return str(exc)


#: The keys of a recording's ``meta`` that the reader needs.
_META_KEYS = ("beams", "angles_rad", "scan_step_m", "world", "config", "policy", "seed", "rows")


def _check_shapes(cols: Mapping[str, np.ndarray], meta: dict[str, Any]) -> None:
    """Every column's shape against the schema's (G ticks, N robots, M beams); ValueError
    naming the first that disagrees."""
    g, n, _ = cols["pose"].shape
    m = int(meta["beams"])
    expected = {"time_s": (g,), "pose": (g, n, 3), "command": (g, n, 2), "status": (g, n),
                "contact_obstacle": (g, n), "contact_robot": (g, n), "scan": (g, n, m),
                "safe_bits": (g, n, (m + 7) // 8),
                **{key: (g, n) for key in cols if key.startswith("state/")},
                "sent_offset": (len(cols["sent_tick"]) + 1,),
                "sent_robot": (len(cols["sent_tick"]),),
                **({"estimates": (g, n, 3)} if "estimates" in cols else {})}
    for key, shape in expected.items():
        if cols[key].shape != shape:
            raise FftnavError(f"column {key} has shape {cols[key].shape}, expected {shape}")
    offsets = cols["sent_offset"]
    if offsets[0] != 0 or (np.diff(offsets) < 0).any() or offsets[-1] != len(cols["sent_bytes"]):
        raise FftnavError("column sent_offset does not index sent_bytes")
    if len(meta["angles_rad"]) != m or len(meta["rows"]) != n:
        raise FftnavError(f"meta has {len(meta['angles_rad'])} beam angles and "
                          f"{len(meta['rows'])} rows for {m} beams and {n} robots")


def _check_values(cols: Mapping[str, np.ndarray]) -> None:
    """What a player relies on: times finite and increasing, poses (and estimates) finite,
    every status a :class:`~fftnav.states.Status` code and every ``state/mode`` a
    :class:`~fftnav.states.State` code (or NaN: absent); ValueError naming the first
    column that breaks it and where."""
    time_s = cols["time_s"].astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(time_s))
    if bad.size:
        raise FftnavError(f"column time_s is not finite at tick {bad[0]} ({time_s[bad[0]]})")
    bad = np.flatnonzero(np.diff(time_s) <= 0)
    if bad.size:
        t = bad[0] + 1
        raise FftnavError(f"column time_s does not increase at tick {t} ({time_s[t - 1]} s, "
                          f"then {time_s[t]} s)")
    for key in ("pose", "command"):  # estimates: NaN where a tick has none
        if key in cols:
            bad = np.argwhere(~np.isfinite(cols[key].astype(np.float64)))
            if bad.size:
                raise FftnavError(f"column {key} is not finite at tick {bad[0][0]}, robot "
                                  f"{bad[0][1]}")
    for key, codes in (("status", Status), ("state/mode", State)):
        if key not in cols:
            continue
        values = cols[key].astype(np.float64)
        valid = np.isin(values, [int(c) for c in codes]) | (np.isnan(values) & (key != "status"))
        bad = np.argwhere(~valid)
        if bad.size:
            i, j = bad[0]
            known = ", ".join(f"{int(c)} {c.name.lower()}" for c in codes)
            raise FftnavError(f"column {key} holds {values[i, j]:g} at tick {i}, robot {j}: not "
                              f"a {codes.__name__} code ({known})")


def _read_meta(path: Any, cols: Mapping[str, np.ndarray]) -> dict[str, Any]:
    try:
        meta = json.loads(cols["meta"].tobytes().decode())
    except (KeyError, ValueError) as exc:
        raise RecordingError(f"path must be an fftnav recording, got path={str(path)!r} "
                             f"(no readable meta: an .npz without fftnav's meta member)"
                             if isinstance(exc, KeyError) else
                             f"path must be an fftnav recording, got path={str(path)!r} "
                             f"(no readable meta: {exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise RecordingError(f"path must be an fftnav recording, got path={str(path)!r} "
                             f"(format {meta.get('format') if isinstance(meta, dict) else meta!r})")
    if not isinstance(meta.get("version"), int) or meta["version"] > VERSION:
        raise RecordingError(f"path must be a recording of version <= {VERSION}, got "
                             f"path={str(path)!r} (version {meta.get('version')!r}); "
                             "upgrade fftnav to read it")
    return meta


def _decode(cols: Mapping[str, np.ndarray], meta: dict[str, Any]) -> Recording:
    beams = int(meta["beams"])
    offsets = cols["sent_offset"]
    data = cols["sent_bytes"].tobytes()
    return Recording(
        world=World.from_json(json.dumps(meta["world"])),
        config=SwarmConfig.from_sections(meta["config"]),
        policy=str(meta["policy"]), seed=int(meta["seed"]), rows=list(meta["rows"]),
        angles_rad=np.asarray(meta["angles_rad"], dtype=np.float64),
        time_s=cols["time_s"].astype(np.float64),
        pose=cols["pose"].astype(np.float64), command=cols["command"].astype(np.float64),
        status=cols["status"],
        scan_m=cols["scan"].astype(np.float64) * float(meta["scan_step_m"]),
        safe=np.unpackbits(cols["safe_bits"], axis=-1, count=beams).astype(bool),
        contact_obstacle=cols["contact_obstacle"], contact_robot=cols["contact_robot"],
        state={key.split("/", 1)[1]: col.astype(np.float64)
               for key, col in cols.items() if key.startswith("state/")},
        sent_tick=cols["sent_tick"].astype(np.int64), sent_robot=cols["sent_robot"].astype(
            np.int64),
        sent_payloads=[data[a:b] for a, b in zip(offsets[:-1], offsets[1:], strict=True)],
        delivered=cols["delivered"].astype(np.int64),
        meta={k: v for k, v in meta.items() if k not in ("world", "config", "rows")},
        estimates=cols["estimates"].astype(np.float64) if "estimates" in cols else None,
    )

"""Swarm messages: compressed observations broadcast as real bytes (paper Sec. III-D/E, IV-B).

A :class:`Channel` carries each robot's message (for ``fusion`` the encoded Sigma of
:mod:`fftnav.observe.codec`) to the robots within a communication range, with independent
packet loss and a fixed delay in control ticks, as :class:`~fftnav.navigation.controllers.Packet`
objects. Receivers keep the newest packet of each sender. It counts the bytes and messages each
robot sends, and tells why a robot has no packet from another (:meth:`Channel.unheard`). All
randomness (packet loss) comes from the episode's seeded ``numpy.random.Generator``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from fftnav.navigation.controllers import Packet
from fftnav.validate import check_integer, check_number

__all__ = ["Channel", "Locate"]

#: ``locate(sender, receivers, poses)``: where each of ``receivers`` (indices, ``(k,)``) places
#: ``sender``, in its own frame ``(k, 3)``, given the true ``poses`` at sending time
#: (:meth:`fftnav.episode.localize.Localizer.locate`).
Locate = Callable[[int, np.ndarray, np.ndarray], np.ndarray]


class Channel:
    """Broadcast medium for ``n_robots`` robots.

    Parameters
    ----------
    n_robots : int
        Number of robots.
    range_m : float
        Communication range in metres (> 0): a packet reaches the robots within this distance
        of the sender at sending time.
    loss : float
        Probability in ``[0, 1)`` that a given receiver misses a given packet.
    delay_ticks : int
        Extra control ticks of latency (>= 0). A packet broadcast during tick ``t`` (after the
        robots have decided for that tick) is in the receivers' inboxes from tick
        ``t + 1 + delay_ticks`` on: with no delay, neighbours use it on the next tick.
    rng : numpy.random.Generator
        Source of the packet-loss draws.
    """

    def __init__(
        self,
        n_robots: int,
        *,
        range_m: float,
        loss: float = 0.0,
        delay_ticks: int = 0,
        rng: np.random.Generator,
    ) -> None:
        check_integer("n_robots", n_robots, low=1)
        check_number("range_m", range_m, low=0, low_open=True)
        check_number("loss", loss, low=0, high=1, high_open=True)
        check_integer("delay_ticks", delay_ticks, low=0)
        self.n_robots = int(n_robots)
        self.range_m = float(range_m)
        self.loss = float(loss)
        self.delay_ticks = int(delay_ticks)
        self._rng = rng
        self.bytes_sent = np.zeros(self.n_robots, dtype=np.int64)
        self.messages_sent = np.zeros(self.n_robots, dtype=np.int64)
        # in flight: (deliver_at_tick, receiver, packet); inbox: receiver -> {sender: packet}
        self._in_flight: list[tuple[int, int, Packet]] = []
        self._inbox: list[dict[int, Packet]] = [{} for _ in range(self.n_robots)]
        # delivered by the latest deliver(): receiver -> {sender: packet}
        self._arrived: list[dict[int, Packet]] = [{} for _ in range(self.n_robots)]
        #: Tick of each sender's last broadcast, and per (sender, receiver) the tick of the last
        #: packet lost on the way and of the last one the receiver was out of range for
        #: (``NEVER`` if none): why a robot has no message from another (:meth:`unheard`).
        self.last_sent = np.full(self.n_robots, self.NEVER, dtype=np.int64)
        self.last_lost = np.full((self.n_robots, self.n_robots), self.NEVER, dtype=np.int64)
        self.last_out_of_range = np.full((self.n_robots, self.n_robots), self.NEVER,
                                         dtype=np.int64)

    #: "No such packet" in the tick logs (far in the past).
    NEVER = -(1 << 40)

    def broadcast(
        self, sender: int, payload: bytes, *, tick: int, poses: np.ndarray, active: np.ndarray,
        locate: Locate | None = None,
    ) -> None:
        """Send ``payload`` from ``sender`` to every other active robot within range.

        ``poses`` is the ``(n_robots, 3)`` array of ground-truth poses at sending time and
        ``active`` a boolean mask of robots still in the world. Each packet's ``sender_pose``
        is where its receiver places the sender (``locate``; default: the sender's true pose,
        the same for every receiver).
        """
        self.bytes_sent[sender] += len(payload)
        self.messages_sent[sender] += 1
        xy = poses[:, :2]
        dist = np.hypot(*(xy - xy[sender]).T)
        reach = active & (dist <= self.range_m)
        reach[sender] = False
        receivers = np.flatnonzero(reach)
        self.last_sent[sender] = tick
        self.last_out_of_range[sender, active & ~reach] = tick
        if self.loss > 0.0:
            kept = self._rng.random(len(receivers)) >= self.loss
            self.last_lost[sender, receivers[~kept]] = tick
            receivers = receivers[kept]
        due = tick + 1 + self.delay_ticks
        if locate is None:
            pose = tuple(float(v) for v in poses[sender])
            packet = Packet(sender=sender, tick=tick, payload=payload, sender_pose=pose)  # type: ignore[arg-type]
            self._in_flight.extend((due, int(r), packet) for r in receivers)
            return
        placed = locate(sender, receivers, poses)
        for r, where in zip(receivers.tolist(), placed, strict=True):
            pose = tuple(float(v) for v in where)
            self._in_flight.append((due, int(r), Packet(sender=sender, tick=tick, payload=payload,
                                                        sender_pose=pose)))  # type: ignore[arg-type]

    def deliver(self, tick: int) -> None:
        """Move the packets due at or before ``tick`` into the receivers' inboxes; they are
        the ones :meth:`arrived` returns until the next call."""
        keep = []
        self._arrived = [{} for _ in range(self.n_robots)]
        for due, receiver, packet in self._in_flight:
            if due <= tick:
                self._inbox[receiver][packet.sender] = packet
                self._arrived[receiver][packet.sender] = packet
            else:
                keep.append((due, receiver, packet))
        self._in_flight = keep

    def inbox(self, receiver: int, *, tick: int, max_age_ticks: int) -> list[Packet]:
        """Newest packet of each sender, sent no more than ``max_age_ticks`` before ``tick``."""
        return [
            p
            for _, p in sorted(self._inbox[receiver].items())
            if tick - p.tick <= max_age_ticks
        ]

    def arrived(self, receiver: int) -> list[Packet]:
        """The packets the latest :meth:`deliver` brought to ``receiver`` (the newest of each
        sender), in sender order."""
        return [p for _, p in sorted(self._arrived[receiver].items())]

    def delivered(self) -> list[tuple[int, int, int]]:
        """Every packet the latest :meth:`deliver` brought: ``(sender, receiver, sent tick)``,
        by receiver then sender (what :meth:`arrived` returns, for all receivers at once)."""
        return [(sender, receiver, packet.tick)
                for receiver, packets in enumerate(self._arrived)
                for sender, packet in sorted(packets.items())]

    def unheard(self, receiver: int, *, tick: int, max_age_ticks: int,
                present: np.ndarray) -> dict[int, str]:
        """Why ``receiver`` has no packet of each other robot of ``present`` (a mask) in its
        inbox (``inbox(receiver, tick=tick, max_age_ticks=max_age_ticks)``): ``"no_message"``
        (the robot sent nothing since ``tick - max_age_ticks``, or its packet is still in
        flight), ``"lost"`` (its packet to ``receiver`` was lost) or ``"out_of_range"``
        (``receiver`` was out of range when it sent). Robot index -> reason, in index order."""
        heard = {p.sender for p in self.inbox(receiver, tick=tick, max_age_ticks=max_age_ticks)}
        oldest = tick - max_age_ticks
        reasons: dict[int, str] = {}
        for j in np.flatnonzero(present).tolist():
            if j == receiver or j in heard:
                continue
            if self.last_sent[j] < oldest:
                reasons[j] = "no_message"
            elif self.last_lost[j, receiver] >= oldest:
                reasons[j] = "lost"
            elif self.last_out_of_range[j, receiver] >= oldest:
                reasons[j] = "out_of_range"
            else:  # sent, reached, still in flight (delay_ticks)
                reasons[j] = "no_message"
        return reasons

"""Swarm messages: compressed observations broadcast as real bytes (paper Sec. III-D/E, IV-B).

A :class:`Channel` carries each robot's encoded Sigma (the compact codec of
:mod:`fftnav.observe.codec`) to the robots within a communication range, with independent packet
loss and a fixed delay in control ticks. Receivers keep the newest packet of each sender.
It counts the bytes and messages each robot sends. All randomness (packet loss) comes from
the episode's seeded ``numpy.random.Generator``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fftnav.validate import check_integer, check_number

__all__ = ["Packet", "Channel"]


@dataclass(frozen=True)
class Packet:
    """One received message.

    Attributes
    ----------
    sender : int
        Index of the sending robot.
    tick : int
        Control tick at which it was sent.
    payload : bytes
        The encoded message (compact Sigma layout).
    sender_pose : tuple of float
        The sender's ground-truth pose ``(x_m, y_m, yaw_rad)`` when it sent the message; the
        receiver turns it into a relative pose (optionally with noise) to rotate Sigma into its
        own frame.
    """

    sender: int
    tick: int
    payload: bytes
    sender_pose: tuple[float, float, float]


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
        #: Tick of each sender's last broadcast, and per (sender, receiver) the tick of the last
        #: packet lost on the way and of the last one the receiver was out of range for
        #: (``NEVER`` if none): why a robot has no message from another (the neighbour
        #: accounting of :class:`fftnav.episode.decider.Decider`).
        self.last_sent = np.full(self.n_robots, self.NEVER, dtype=np.int64)
        self.last_lost = np.full((self.n_robots, self.n_robots), self.NEVER, dtype=np.int64)
        self.last_out_of_range = np.full((self.n_robots, self.n_robots), self.NEVER,
                                         dtype=np.int64)

    #: "No such packet" in the tick logs (far in the past).
    NEVER = -(1 << 40)

    def broadcast(
        self, sender: int, payload: bytes, *, tick: int, poses: np.ndarray, active: np.ndarray
    ) -> None:
        """Send ``payload`` from ``sender`` to every other active robot within range.

        ``poses`` is the ``(n_robots, 3)`` array of ground-truth poses at sending time and
        ``active`` a boolean mask of robots still in the world.
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
        pose = tuple(float(v) for v in poses[sender])
        packet = Packet(sender=sender, tick=tick, payload=payload, sender_pose=pose)  # type: ignore[arg-type]
        for r in receivers:
            self._in_flight.append((tick + 1 + self.delay_ticks, int(r), packet))

    def deliver(self, tick: int) -> None:
        """Move the packets due at or before ``tick`` into the receivers' inboxes."""
        keep = []
        for due, receiver, packet in self._in_flight:
            if due <= tick:
                self._inbox[receiver][packet.sender] = packet
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

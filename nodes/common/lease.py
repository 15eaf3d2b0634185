"""One commander at a time: a device's lease book and its holder's side, free of ROS.

A UR accepts one external control client at a time; densepack's arm and gripper nodes do the
same for the nodes that command them. A node takes a device's lease (``/arm/lease``,
``/gripper/lease``, ``densepack_interfaces/srv/ControlLease``) under its fully qualified node
name; while it holds it, the device node takes commands only on the holder's private topic
(``/arm/lease/<token>/cartesian_setpoint``) and refuses, counts and names those on the public
one (``/arm/cartesian_setpoint``). ROS messages carry no sender (rclpy Jazzy's message info
has only stamps and sequence numbers), so a refusal names every node the graph lists as a
publisher on the public topic but the holder: one of them sent it.

* ``LeaseBook`` is the device's side: who holds the lease, since when, under which token;
  a second holder is refused with the holder's name, the same holder asking again (an
  executor that came back under its name) gets a new token and its old one ends; a holder
  missing from the graph at ``absent_checks`` looks in a row has left, and its lease ends.
* ``LeaseKeeper`` is the holder's side: when to ask and when to give back, and whether its
  commands go on the private topic yet (only once the device's subscriber is seen there, so
  no command is lost in the switch; one whose subscriber goes away, a device node that
  restarted, is asked for again).

Names are taken as given: this guards against mistakes and strays (a tool left running, a
second executor, a test on the wrong domain), not against someone who means harm, who can
publish on the private topic or ask under another's name. DDS security (SROS2) would be the
answer to that, and pip's Fast DDS has no security plugins.
"""

from __future__ import annotations

import enum
import math
import secrets
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass

from nodes.common.params import param

#: How many names a device keeps of the commanders it refused (the most recent first).
MAX_NAMED = 8


@dataclass(frozen=True)
class LeaseConfig:
    """The device node's lease parameters (``lease.*`` of the arm and the gripper)."""

    check_period_s: float = param(
        1.0, "how often the node looks at the ROS graph for its lease holder (steady time)",
        unit="s")
    absent_checks: int = param(
        2, "a lease holder missing from the ROS graph at this many looks in a row has left: "
        "its lease ends and the public command topic works again")

    def __post_init__(self) -> None:
        if not self.check_period_s > 0.0:
            raise ValueError(f"check_period_s must be > 0, got {self.check_period_s}")
        if self.absent_checks < 1:
            raise ValueError(f"absent_checks must be >= 1, got {self.absent_checks}")


@dataclass(frozen=True)
class Lease:
    holder: str  #: the holder's fully qualified node name (/executor)
    token: str  #: names its private topics
    since_s: float  #: granted at (the device node's clock, s)


@dataclass(frozen=True)
class LeaseAnswer:
    """The answer to an ask or a give-back: does the asker hold the lease now, the lease in
    force (the asker's, or the one that refused it), why in words, and a lease the call
    ended (given back, or replaced by its holder's new one), whose private topic goes."""

    granted: bool
    lease: Lease | None
    message: str
    ended: Lease | None = None


@dataclass(frozen=True)
class LeaseStatus:
    """What a device says of its lease on its status."""

    holder: str = ""
    refused_commands: int = 0
    refused_commanders: tuple[str, ...] = ()


def new_token() -> str:
    """A fresh token: a topic name part (a letter first), unlikely to repeat."""
    return "t" + secrets.token_hex(4)


def holder_problem(holder: str) -> str:
    """Why ``holder`` cannot be a fully qualified node name ("" when it can)."""
    if not holder.startswith("/") or holder.endswith("/") or " " in holder:
        return f"'{holder}' is not a fully qualified node name (like /executor)"
    return ""


class LeaseBook:
    """Who holds one device, and who was refused."""

    def __init__(self, device: str, absent_checks: int = 2,
                 token_fn: Callable[[], str] = new_token) -> None:
        self.device = device
        self.absent_checks = absent_checks
        self.lease: Lease | None = None
        self.refused = 0  #: commands refused on the public topic since start
        self.named: list[str] = []  #: refused commanders, the most recent first
        self._token_fn = token_fn
        self._misses = 0

    @property
    def holder(self) -> str:
        return "" if self.lease is None else self.lease.holder

    def request(self, holder: str, now_s: float) -> LeaseAnswer:
        """``holder`` asks for the lease at ``now_s``."""
        problem = holder_problem(holder)
        if problem:
            return LeaseAnswer(False, self.lease, f"refused: {problem}")
        current = self.lease
        if current is not None and current.holder != holder:
            self.name(holder)
            return LeaseAnswer(False, current, f"refused: {current.holder} holds {self.device} "
                                               f"(since {current.since_s:.1f} s)")
        self.lease = Lease(holder, self._token_fn(), now_s)
        self._misses = 0
        again = " again (its old token ends)" if current is not None else ""
        return LeaseAnswer(True, self.lease, f"{holder} holds {self.device}{again}",
                           ended=current)

    def release(self, holder: str, token: str = "") -> LeaseAnswer:
        """``holder`` gives the lease back; ``token`` (when given) must be the lease's, so a
        late give-back of an old lease never ends its holder's new one."""
        current = self.lease
        if current is None:
            return LeaseAnswer(False, None, f"nothing to give back: nobody holds {self.device}")
        if current.holder != holder or (token and token != current.token):
            whose = "an old lease" if current.holder == holder else f"{current.holder}'s lease"
            return LeaseAnswer(False, current, f"nothing given back: {holder} named {whose}")
        self.lease = None
        return LeaseAnswer(False, None, f"{holder} gave {self.device} back", ended=current)

    def refuse(self, publishers: Iterable[str]) -> list[str]:
        """One command on the public topic refused while the lease is held. ``publishers``:
        the nodes publishing there now (the message names no sender); returns those charged
        with it, every one but the holder (none: the holder's own, sent just before it
        switched, or a sender already gone)."""
        self.refused += 1
        charged = sorted({p for p in publishers if p != self.holder})
        for name in charged:
            self.name(name)
        return charged

    def on_graph(self, nodes: Collection[str]) -> Lease | None:
        """One look at the nodes in the graph; returns the lease that ended because its
        holder was missing at ``absent_checks`` looks in a row."""
        if self.lease is None:
            return None
        if self.lease.holder in nodes:
            self._misses = 0
            return None
        self._misses += 1
        if self._misses < self.absent_checks:
            return None
        ended, self.lease = self.lease, None
        return ended

    def status(self) -> LeaseStatus:
        return LeaseStatus(self.holder, self.refused, tuple(self.named))

    def name(self, name: str) -> None:
        """Name a refused commander (the most recent first, MAX_NAMED kept)."""
        if name in self.named:
            self.named.remove(name)
        self.named.insert(0, name)
        del self.named[MAX_NAMED:]


class Ask(enum.Enum):
    """What the holder's side sends next."""

    TAKE = "take"
    GIVE_BACK = "give back"


#: How long (s) a device's status may name another holder than the one holding its lease
#: before the holder takes the lease as lost (``LeaseKeeper.on_device_holder``).
HOLDER_MISMATCH_S = 0.5


class LeaseKeeper:
    """The holder's side for one device: asks while it wants the lease and holds none (again
    each ``retry_s`` while refused or unanswered), gives it back when it no longer wants it,
    and says where its commands go (``connected``: on the private topic)."""

    def __init__(self, device: str, retry_s: float = 1.0, answer_timeout_s: float = 5.0,
                 connect_timeout_s: float = 5.0) -> None:
        self.device = device
        self.retry_s = retry_s
        self.answer_timeout_s = answer_timeout_s
        self.connect_timeout_s = connect_timeout_s
        self.token = ""
        self.topic = ""  #: the private command topic while a lease is held
        self.connected = False  #: the device's subscriber is seen there: commands go there
        #: set when commands switch to the private topic (the caller clears it): the device may
        #: have refused one sent on the public topic just before, so the last one goes again
        self.switched = False
        self.log: list[str] = []
        self._granted_at = 0.0
        self._pending: tuple[Ask, float] | None = None
        self._next_try = -math.inf
        self._refusal = ""
        self._mismatch_since: float | None = None

    @property
    def holds(self) -> bool:
        return bool(self.token)

    def step(self, want: bool, now: float, server_ready: bool, subscribers: int) -> Ask | None:
        """One look at ``now`` (s, steady): ``subscribers`` on the private topic; returns the
        request to send, if any."""
        self._watch_topic(now, subscribers)
        if self._pending is not None:
            if now - self._pending[1] < self.answer_timeout_s:
                return None
            self.log.append(f"{self.device} lease: no answer to '{self._pending[0].value}' in "
                            f"{self.answer_timeout_s:.0f} s")
            self._pending = None
            self._next_try = now + self.retry_s
        if now < self._next_try or want == self.holds:
            return None
        if not server_ready:
            if not want:  # the device node is gone, and its lease with it
                self._drop(f"{self.device} lease dropped: its service is gone")
            self._next_try = now + self.retry_s
            return None
        self._pending = (Ask.TAKE if want else Ask.GIVE_BACK, now)
        return self._pending[0]

    def on_answer(self, granted: bool, token: str, topic: str, message: str,
                  now: float) -> None:
        """The device's answer to the pending request."""
        asked = self._pending[0] if self._pending is not None else None
        self._pending = None
        if granted and token and topic:
            if token != self.token:
                self.log.append(f"{self.device} lease taken: commands go on {topic}")
            self.token, self.topic, self.connected = token, topic, False
            self._granted_at, self._refusal = now, ""
            return
        if asked is Ask.GIVE_BACK or (not granted and self.holds):
            self._drop(f"{self.device} lease given back ({message})")
            return
        if message != self._refusal:  # said once per reason, asked again each retry_s
            self.log.append(f"{self.device} lease {message}; asking again every "
                            f"{self.retry_s:.0f} s, commanding on the public topic meanwhile")
            self._refusal = message
        self._next_try = now + self.retry_s

    def on_failed(self, why: str, now: float) -> None:
        """The request failed (the device node went away while answering)."""
        self._pending = None
        self._next_try = now + self.retry_s
        self.log.append(f"{self.device} lease request failed: {why}")

    def on_device_holder(self, holder: str, me: str, now: float) -> None:
        """The holder the device's status names. A device that restarted holds no lease and
        says so at once, while its private topic's subscriber may be seen gone only when DDS
        notices the dead process (many seconds): a lease held and connected that the device
        names another holder for ``HOLDER_MISMATCH_S`` (a status from before the grant may
        still arrive) is lost, and asked for again."""
        if not (self.holds and self.connected) or holder == me:
            self._mismatch_since = None
            return
        if self._mismatch_since is None:
            self._mismatch_since = now
        elif now - self._mismatch_since >= HOLDER_MISMATCH_S:
            self._drop(f"{self.device} lease lost (the device says {holder or 'nobody'} holds "
                       "it: it restarted): asking again")
            self._mismatch_since = None
            self._next_try = now

    def take_log(self) -> list[str]:
        out, self.log = self.log, []
        return out

    def _watch_topic(self, now: float, subscribers: int) -> None:
        if not self.holds:
            return
        if subscribers > 0:
            self.switched = self.switched or not self.connected
            self.connected = True
        elif self.connected:  # the device's subscriber went: it restarted, or ended the lease
            self._drop(f"{self.device} lease lost (nobody listens on {self.topic} any more): "
                       "asking again")
            self._next_try = now
        elif now - self._granted_at > self.connect_timeout_s:
            self._drop(f"{self.device} lease dropped: nobody listened on {self.topic} in "
                       f"{self.connect_timeout_s:.0f} s")
            self._next_try = now

    def _drop(self, line: str) -> None:
        self.log.append(line)
        self.token, self.topic, self.connected = "", "", False

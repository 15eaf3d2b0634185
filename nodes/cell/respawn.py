"""Which of the cell's nodes come back when their process ends, when, and when to give up.

A ROS launch file restarts a node marked ``respawn`` after ``respawn_delay``; the cell file
says the same per node (``respawn``, ``respawn_delay``), and adds a limit
(``respawn_max``): a node that keeps dying is a fault to report, not to hide. Pure logic
(no processes, no ROS): the launcher tells ``RespawnBook`` which node ended and when, asks
which are due to start again, and stops the cell when the book says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from nodes.common.transports import TRANSPORTS_ENV, UDP_AFTER_RESPAWN

#: A ROS launch file's default respawn_delay is 0; a node that died of a transient (its DDS
#: peer not yet up, a port still bound) needs a moment before it starts again.
DEFAULT_DELAY_S = 2.0
DEFAULT_MAX_RESPAWNS = 3

#: Fast DDS's built-in transports for a node started again after its process died: UDP only
#: (``nodes.common.transports``). A SIGKILLed process leaves its shared-memory port behind.
#: In one chaos run an executor back under the dead one's participant id (its port) heard
#: nothing for 8 minutes (not its goal, sent 26 times, nor the latched plan) while its own
#: messages went out; the same run again heard everything, so the cause is inferred, not
#: shown: over UDP nothing of the dead process is reused.
RESPAWN_TRANSPORTS = {TRANSPORTS_ENV: UDP_AFTER_RESPAWN}


def respawn_env(env: dict[str, str]) -> dict[str, str]:
    """The environment of a node started again: ``env`` with ``RESPAWN_TRANSPORTS`` (a
    transport the user chose is kept)."""
    return {**RESPAWN_TRANSPORTS, **env}


@dataclass(frozen=True, slots=True)
class Respawn:
    """A node's rule: whether it comes back, after how long (s), how many times at most."""

    enabled: bool = False
    delay_s: float = DEFAULT_DELAY_S
    max_respawns: int = DEFAULT_MAX_RESPAWNS

    def __post_init__(self) -> None:
        if not isinstance(self.enabled, bool):
            raise ValueError(f"respawn must be true or false, not {self.enabled!r}")
        if (isinstance(self.delay_s, bool) or not isinstance(self.delay_s, int | float)
                or not math.isfinite(self.delay_s) or self.delay_s < 0.0):
            raise ValueError(f"respawn_delay must be a number of seconds >= 0, not "
                             f"{self.delay_s!r}")
        if isinstance(self.max_respawns, bool) or not isinstance(self.max_respawns, int) or (
                self.max_respawns < 0):
            raise ValueError(f"respawn_max must be a whole number >= 0, not "
                             f"{self.max_respawns!r}")

    @classmethod
    def from_spec(cls, name: str, spec: dict[str, Any]) -> Respawn:
        """The rule of a cell file's node entry; ValueError names the node and the key."""
        try:
            return cls(spec.get("respawn", False), spec.get("respawn_delay", DEFAULT_DELAY_S),
                       spec.get("respawn_max", DEFAULT_MAX_RESPAWNS))
        except ValueError as err:
            raise ValueError(f"node '{name}': {err}") from None


class RespawnBook:
    """The nodes that ended, when each starts again, and why the cell stops (``fatal``)."""

    def __init__(self, rules: dict[str, Respawn]) -> None:
        self.rules = rules
        self.respawns = dict.fromkeys(rules, 0)  #: restarts so far, per node
        self.due_at: dict[str, float] = {}  #: node -> when it starts again (s)
        self.fatal: str | None = None

    def on_exit(self, name: str, code: int, now: float) -> str:
        """Node ``name`` ended with ``code`` at ``now`` (s), unasked: schedule it again or
        say the cell must stop. Returns the line to log."""
        rule = self.rules.get(name, Respawn())
        how = f"node {name} exited (code {code})"
        if not rule.enabled:
            if code != 0 and self.fatal is None:
                self.fatal = f"{how}; it does not respawn"
            return f"{how}; stopping the cell" if code != 0 else f"{how}; not respawned"
        if self.respawns[name] >= rule.max_respawns:
            if self.fatal is None:
                self.fatal = f"{how}; respawned {rule.max_respawns} time(s) already"
            return f"{how}; no respawn left ({rule.max_respawns} used); stopping the cell"
        self.respawns[name] += 1
        self.due_at[name] = now + rule.delay_s
        return (f"{how}; respawning in {rule.delay_s:g} s ({self.respawns[name]} of "
                f"{rule.max_respawns})")

    def due(self, now: float) -> list[str]:
        """The nodes to start again now (each returned once)."""
        ready = sorted(n for n, t in self.due_at.items() if t <= now)
        for name in ready:
            del self.due_at[name]
        return ready

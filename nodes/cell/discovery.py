"""The nodes a run expects on other computers, seen or not (issue 29, item 3).

A cell split over several computers runs only if DDS discovery crosses between them: the same
``ROS_DOMAIN_ID``, a discovery range that reaches the other computer (multicast on the
subnet, or static peers naming it) and the UDP ports open. When it does not, nothing fails:
every node waits for the others. ``DiscoveryWatch`` turns that silence into a report within
seconds, naming each node it cannot see and what to check (``discovery_hint``).

A node counts as seen when the ROS graph lists it by name, or when a topic only it publishes
has a publisher: the names come from ROS's node-info topic, which under load reaches a new
participant seconds after its endpoints do (seen across two network namespaces: a
subscriber that heard every other process's messages still listed none of their nodes).

Pure logic, but for ``graph_view``, which asks a node for the graph (any object with rclpy's
``get_node_names_and_namespaces`` and ``count_publishers``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

#: Per node, a topic no other node of the cell publishes, as long as the node runs.
SIGNATURE_TOPICS = {
    "sim": "/sim/ground_truth",
    "detector": "/blocks/detected",
    "planner": "/planner/status",
    "executor": "/executor/status",
    "arm": "/arm/status",
    "gripper": "/gripper/status",
}
#: A node expected elsewhere must be seen this soon after the run starts (s).
FIRST_SEEN_S = 10.0
#: A node seen, then gone from the graph this long, is lost (s). Longer than a remote node's
#: respawn (its respawn_delay and start-up) and than DDS's lease (Fast DDS: 20 s), after which a
#: killed process leaves the graph.
LOST_AFTER_S = 45.0
#: A node whose data the run hears steadily (the sim's ground truth, 10 Hz), silent this long, is
#: cut off (s): the graph keeps a node for DDS's lease after its link went down, its data stops
#: at once.
SILENT_AFTER_S = 5.0
#: The RTPS well-known ports (DDSI-RTPS 9.6.1.1, Fast DDS's defaults): base, per domain, per
#: participant, and the offsets of multicast discovery, multicast data, unicast discovery and
#: unicast data.
PORT_BASE, DOMAIN_GAIN, PARTICIPANT_GAIN = 7400, 250, 2
D0, D1, D2, D3 = 0, 10, 1, 11


@dataclass(frozen=True, slots=True)
class GraphView:
    """What the graph shows at one moment: node names (no namespace) and the topics that
    have a publisher."""

    nodes: frozenset[str] = frozenset()
    published: frozenset[str] = frozenset()


def graph_view(node: Any, topics: Iterable[str]) -> GraphView:
    """The graph as ``node`` sees it now, publishers looked up only on ``topics``."""
    names = frozenset(name for name, _ in node.get_node_names_and_namespaces())
    return GraphView(names, frozenset(t for t in topics if node.count_publishers(t) > 0))


def discovery_ports(domain: int, participants: int = 10) -> str:
    """The UDP ports DDS uses on domain ``domain`` for ``participants`` ROS processes on a
    computer: multicast discovery and data, then unicast discovery and data (two per
    process)."""
    base = PORT_BASE + DOMAIN_GAIN * domain
    last = base + D3 + PARTICIPANT_GAIN * (participants - 1)
    return f"{base + D0}-{base + D2} (multicast) and {base + D1}-{last} (unicast)"


def discovery_hint(env: Mapping[str, str]) -> str:
    """What this computer's discovery settings are and what both computers need."""
    domain = int(env.get("ROS_DOMAIN_ID") or 0)
    scope = (env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") or "SUBNET").upper()
    peers = env.get("ROS_STATIC_PEERS", "").strip()
    said = (f"here ROS_DOMAIN_ID={domain}, ROS_AUTOMATIC_DISCOVERY_RANGE={scope}, "
            f"ROS_STATIC_PEERS={peers or '(none)'}")
    if scope == "OFF":
        said += " (OFF finds nothing, static peers included)"
    elif scope in ("LOCALHOST", "SYSTEM_DEFAULT") and not peers:
        said += f" ({scope} without static peers stays on this computer)"
    return (f"{said}; both computers need the same ROS_DOMAIN_ID, and either multicast "
            "between them (SUBNET) or ROS_STATIC_PEERS naming the other; UDP ports "
            f"{discovery_ports(domain)} open both ways")


@dataclass
class DiscoveryWatch:
    """Watches for ``remote`` nodes (by name) in the views it is given, from the first one
    on. ``update`` returns None while all is well, and the report once: a node not seen
    within ``first_seen_s``, seen and then gone for ``lost_after_s``, or, for a node whose
    data the caller hears steadily, seen but silent for ``silent_after_s``."""

    remote: Sequence[str]
    first_seen_s: float = FIRST_SEEN_S
    lost_after_s: float = LOST_AFTER_S
    silent_after_s: float = SILENT_AFTER_S
    signatures: Mapping[str, str] = field(default_factory=lambda: dict(SIGNATURE_TOPICS))
    started_at: float | None = None
    first_seen: dict[str, float] = field(default_factory=dict)
    last_seen: dict[str, float] = field(default_factory=dict)
    report: str | None = None

    @property
    def topics(self) -> list[str]:
        """The topics whose publishers tell the remote nodes are there."""
        return [self.signatures[n] for n in self.remote if n in self.signatures]

    def seen(self, name: str, view: GraphView) -> bool:
        topic = self.signatures.get(name)
        return name in view.nodes or (topic is not None and topic in view.published)

    def update(self, now: float, view: GraphView,
               heard: Mapping[str, float | None] | None = None) -> str | None:
        """``heard``: for the nodes whose data the caller listens to steadily, when it last
        came (None: not yet), on ``now``'s clock."""
        if self.report is not None:
            return None
        if self.started_at is None:
            self.started_at = now
        for name in self.remote:
            if self.seen(name, view):
                self.first_seen.setdefault(name, now)
                self.last_seen[name] = now
        self.report = self._silent(now, heard or {})
        never = [n for n in self.remote if n not in self.last_seen]
        if never and now - self.started_at >= self.first_seen_s and self.report is None:
            self.report = (f"cannot see node{'s' if len(never) > 1 else ''} "
                           f"{', '.join(never)} (expected on another computer) "
                           f"{now - self.started_at:.0f} s after the start")
        gone = [n for n, t in self.last_seen.items() if now - t >= self.lost_after_s]
        if gone and self.report is None:
            self.report = (f"lost node{'s' if len(gone) > 1 else ''} {', '.join(gone)} "
                           f"(expected on another computer): not seen for "
                           f"{self.lost_after_s:.0f} s")
        return self.report

    def _silent(self, now: float, heard: Mapping[str, float | None]) -> str | None:
        for name, at in heard.items():
            if name not in self.remote or name not in self.first_seen:
                continue
            if at is None and now - self.first_seen[name] >= self.silent_after_s:
                return (f"sees node {name} (expected on another computer) but none of its "
                        f"data arrives after {now - self.first_seen[name]:.0f} s: the data "
                        "ports are blocked between the computers")
            if at is not None and now - at >= self.silent_after_s:
                return (f"no data from node {name} (expected on another computer) for "
                        f"{now - at:.0f} s: the link to its computer is down, or it hangs")
        return None

"""Fast DDS for a node process: transports sized for camera frames, lost samples re-sent soon.

A 1280x960 rgb8 frame is 3.7 MB, sent as 57 fragments of 64 kB. Between processes on one
computer Fast DDS puts each fragment in the writer's shared-memory segment, 512 kB unless
told otherwise: eight fragments at a time. When the readers have not yet taken the oldest,
the writer takes them back ("Buffer is being invalidated, segment_size may be insufficient"),
those fragments never arrive, and the reliable reader waits for the writer's next heartbeat
to ask for them again. Measured here (one writer, two readers at nice 19 beside a running
cell, 40 frames at 2 Hz): 1133 buffers taken back with the default segment, 1 with a 16 MB
one (docs/benchmarks.md, "The camera's transport"). So the node that publishes frames asks
for ``FASTDDS_BUILTIN_TRANSPORTS=DEFAULT?sockets_size=8MB`` (the segment is twice the sockets'
size), and a node started again after a crash for UDP only (``nodes.cell.respawn``).

Any sample can be lost on a loaded computer (a reader's shared-memory port full, a UDP buffer
overrun), and a reliable writer repairs it on its next heartbeat: 3 s by default in Fast DDS.
In a 200-goal shift, from goal 155 on, detections came 3 s after their frame 82 times, the
whole stream held back behind the lost one. ``use_profile`` therefore gives every node
process a Fast DDS profile with a 0.1 s heartbeat (``HEARTBEAT_PERIOD_S``). Loading a profile
makes Fast DDS ignore ``FASTDDS_BUILTIN_TRANSPORTS``, so the profile declares the transports
that variable names itself; a profile file or transports the user chose are never replaced
(then Fast DDS's own heartbeat stays).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile
from collections.abc import Iterator, MutableMapping
from dataclasses import dataclass
from pathlib import Path

TRANSPORTS_ENV = "FASTDDS_BUILTIN_TRANSPORTS"
#: The profile file Fast DDS 2.x (ROS 2 Jazzy) loads at start; the second name is Fast DDS 3's.
PROFILES_ENV = "FASTRTPS_DEFAULT_PROFILES_FILE"
PROFILES_ENVS = (PROFILES_ENV, "FASTDDS_DEFAULT_PROFILES_FILE")

#: Socket buffers asked for; the shared-memory segment is twice this (16 MB: four frames).
SOCKETS_SIZE = "8MB"

#: The node that publishes camera frames: shared memory on this computer, UDP beyond it.
FRAME_WRITER_TRANSPORTS = f"DEFAULT?sockets_size={SOCKETS_SIZE}"

#: A node started again after its process died: UDP only (``nodes.cell.respawn``), with
#: socket buffers large enough for a frame's fragments where the kernel allows it.
UDP_AFTER_RESPAWN = f"UDPv4?sockets_size={SOCKETS_SIZE}"

#: How often a reliable writer with unacknowledged samples says so (s): the longest a lost
#: sample waits to be asked for again. Measured with a 4-slot shared-memory port (bursts of 20
#: samples, 2 Hz): 285 of 400 samples later than 0.3 s (up to 3.0 s) with Fast DDS's 3 s; none
#: with 0.1 s (at most 0.12 s).
HEARTBEAT_PERIOD_S = 0.1

#: How often a participant announces itself to the others (s; Fast DDS's own: 3 s). A node
#: started beside six others on two cores may miss their first announcements and then meets
#: them only at the next one: the node graph of a cell starting up was complete 0.4 s after
#: its last node in some runs and 3 s after it in others (the run waited for it each time).
ANNOUNCEMENT_PERIOD_S = 0.5

#: The built-in transport sets ``FASTDDS_BUILTIN_TRANSPORTS`` may name that a profile can
#: declare the same way: (shared memory, UDPv4).
_MODES = {"DEFAULT": (True, True), "SHM": (True, False), "UDPv4": (False, True)}
_UNITS = {"B": 1, "KB": 1000, "MB": 1000**2, "GB": 1000**3}


@dataclass(frozen=True, slots=True)
class Transports:
    """What a node's participant talks over; None sizes are Fast DDS's own defaults."""

    shared_memory: bool = True
    udp: bool = True
    sockets_bytes: int | None = None


def size_for_frames(env: MutableMapping[str, str]) -> None:
    """Before ``rclpy.init`` in a node that publishes camera frames: transports sized for
    them, unless the environment already names transports (the user's, or a respawn's)."""
    env.setdefault(TRANSPORTS_ENV, FRAME_WRITER_TRANSPORTS)


def parse_builtin(value: str | None) -> Transports | None:
    """``FASTDDS_BUILTIN_TRANSPORTS`` as a profile would declare it (unset: Fast DDS's
    default, shared memory and UDP); None for a value a profile is not written for
    (``LARGE_DATA``, other options): the user's choice, left to Fast DDS."""
    if not value:
        return Transports()
    mode, _, options = value.partition("?")
    if mode not in _MODES:
        return None
    shared_memory, udp = _MODES[mode]
    if not options:
        return Transports(shared_memory, udp)
    key, _, size = options.partition("=")
    number = size.rstrip("BKMG")
    unit = size[len(number):]
    if key != "sockets_size" or "&" in options or not number.isdigit() or unit not in _UNITS:
        return None
    return Transports(shared_memory, udp, int(number) * _UNITS[unit])


def _seconds(period_s: float) -> str:
    sec = int(period_s)
    return f"<sec>{sec}</sec><nanosec>{round((period_s - sec) * 1e9)}</nanosec>"


def profile_xml(transports: Transports, heartbeat_s: float = HEARTBEAT_PERIOD_S,
                announce_s: float = ANNOUNCEMENT_PERIOD_S) -> str:
    """A Fast DDS profile: the default participant over ``transports``, announcing itself
    every ``announce_s``, the default writer with a ``heartbeat_s`` heartbeat (ROS QoS still
    set per topic: rmw_fastrtps applies it over the profile)."""
    size = transports.sockets_bytes
    descriptors, ids = [], []
    if transports.shared_memory:
        segment = "" if size is None else f"<segment_size>{2 * size}</segment_size>"
        descriptors.append(f"<transport_descriptor><transport_id>shm</transport_id>"
                           f"<type>SHM</type>{segment}</transport_descriptor>")
        ids.append("shm")
    if transports.udp:
        buffers = "" if size is None else (f"<sendBufferSize>{size}</sendBufferSize>"
                                           f"<receiveBufferSize>{size}</receiveBufferSize>")
        descriptors.append(f"<transport_descriptor><transport_id>udp</transport_id>"
                           f"<type>UDPv4</type>{buffers}</transport_descriptor>")
        ids.append("udp")
    user = "".join(f"<transport_id>{i}</transport_id>" for i in ids)
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"><profiles>\n'
        f"<transport_descriptors>{''.join(descriptors)}</transport_descriptors>\n"
        '<participant profile_name="densepack_participant" is_default_profile="true"><rtps>'
        "<builtin><discovery_config>"
        f"<leaseAnnouncement>{_seconds(announce_s)}</leaseAnnouncement>"
        "</discovery_config></builtin>"
        f"<userTransports>{user}</userTransports>"
        "<useBuiltinTransports>false</useBuiltinTransports></rtps></participant>\n"
        '<data_writer profile_name="densepack_writer" is_default_profile="true"><times>'
        f"<heartbeatPeriod>{_seconds(heartbeat_s)}</heartbeatPeriod></times></data_writer>\n"
        "</profiles></dds>\n")


def profiles_dir() -> Path:
    """Where the profiles are written: one directory per user under the system's temp dir."""
    return Path(tempfile.gettempdir()) / f"densepack-{os.getuid()}"


def use_profile(env: MutableMapping[str, str], directory: Path | None = None) -> Path | None:
    """Before ``rclpy.init`` in a node process: write the profile for the transports ``env``
    names and point Fast DDS at it. Returns its path; None (``env`` unchanged) when the user
    chose a profile file or transports no profile is written for."""
    if any(env.get(name) for name in PROFILES_ENVS):
        return None
    transports = parse_builtin(env.get(TRANSPORTS_ENV))
    if transports is None:
        return None
    text = profile_xml(transports)
    directory = profiles_dir() if directory is None else directory
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"fastdds-{hashlib.sha1(text.encode()).hexdigest()[:12]}.xml"
    if not path.exists():  # the name is the content's: another process may write it too
        scratch = path.with_suffix(f".{os.getpid()}.tmp")
        scratch.write_text(text)
        os.replace(scratch, path)
    env[PROFILES_ENV] = str(path)
    return path


@contextlib.contextmanager
def own_profile(env: MutableMapping[str, str] = os.environ) -> Iterator[Path | None]:
    """While a process that starts the cell's nodes creates its own ROS node: the profile
    (``use_profile``) for its participant, taken out of ``env`` again after, so that the
    nodes it starts later choose their own (the camera's sized for frames)."""
    path = use_profile(env)
    try:
        yield path
    finally:
        if path is not None:
            env.pop(PROFILES_ENV, None)


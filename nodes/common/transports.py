"""Fast DDS's built-in transports, sized for the camera's frames.

A 1280x960 rgb8 frame is 3.7 MB, sent as 57 fragments of 64 kB. Between processes on one
computer Fast DDS puts each fragment in the writer's shared-memory segment, 512 kB unless
told otherwise: eight fragments at a time. When the readers have not yet taken the oldest,
the writer takes them back ("Buffer is being invalidated, segment_size may be insufficient"),
those fragments never arrive, and the reliable reader waits for the writer's next heartbeat
to ask for them again (Fast DDS's default period: 3 s). Measured here (one writer, two
readers at nice 19 beside a running cell, 40 frames at 2 Hz): 1133 buffers taken back with
the default segment, 1 with a 16 MB one (docs/benchmarks.md, "The camera's transport").

Fast DDS sizes the segment at twice the socket buffer size of its built-in transports
(``FASTDDS_BUILTIN_TRANSPORTS=DEFAULT?sockets_size=...``); the UDP sockets ask for that size
too, and the kernel grants at most ``net.core.rmem_max`` / ``wmem_max`` (Fast DDS then uses
what it got). A user's own choice of transports is never replaced.
"""

from __future__ import annotations

from collections.abc import MutableMapping

TRANSPORTS_ENV = "FASTDDS_BUILTIN_TRANSPORTS"

#: Socket buffers asked for; the shared-memory segment is twice this (16 MB: four frames).
SOCKETS_SIZE = "8MB"

#: The node that publishes camera frames: shared memory on this computer, UDP beyond it.
FRAME_WRITER_TRANSPORTS = f"DEFAULT?sockets_size={SOCKETS_SIZE}"

#: A node started again after its process died: UDP only (``nodes.cell.respawn``), with
#: socket buffers large enough for a frame's fragments where the kernel allows it.
UDP_AFTER_RESPAWN = f"UDPv4?sockets_size={SOCKETS_SIZE}"


def size_for_frames(env: MutableMapping[str, str]) -> None:
    """Before ``rclpy.init`` in a node that publishes camera frames: transports sized for
    them, unless the environment already names transports (the user's, or a respawn's)."""
    env.setdefault(TRANSPORTS_ENV, FRAME_WRITER_TRANSPORTS)

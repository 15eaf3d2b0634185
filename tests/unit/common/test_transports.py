"""The transports of the node that publishes camera frames."""

from nodes.common.runner import NodeSpec
from nodes.common.transports import TRANSPORTS_ENV, size_for_frames
from nodes.sim.node import SPEC as SIM


def test_the_frame_writer_gets_a_shared_memory_segment_sized_for_frames():
    env: dict[str, str] = {}
    size_for_frames(env)
    mode, _, options = env[TRANSPORTS_ENV].partition("?")
    assert mode == "DEFAULT"  # shared memory on this computer and UDP beyond it, as before
    size = dict(o.split("=") for o in options.split("&"))["sockets_size"]
    # Fast DDS's segment is twice the sockets' size: room for a 3.7 MB frame's fragments
    assert 2 * int(size.removesuffix("MB")) * 1_000_000 >= 2 * 3_686_400


def test_a_transport_the_user_or_a_respawn_chose_is_kept():
    for chosen in ("LARGE_DATA", "UDPv4?sockets_size=8MB"):
        env = {TRANSPORTS_ENV: chosen}
        size_for_frames(env)
        assert env[TRANSPORTS_ENV] == chosen


def test_only_the_sim_publishes_frames():
    assert SIM.publishes_frames
    assert not NodeSpec("x", object, "").publishes_frames

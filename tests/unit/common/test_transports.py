"""The Fast DDS set-up of a node process: transports sized for frames, a short heartbeat."""

import xml.etree.ElementTree as ET

from nodes.common.runner import NodeSpec
from nodes.common.transports import (
    ANNOUNCEMENT_PERIOD_S,
    FRAME_WRITER_TRANSPORTS,
    HEARTBEAT_PERIOD_S,
    PROFILES_ENV,
    TRANSPORTS_ENV,
    UDP_AFTER_RESPAWN,
    Transports,
    own_profile,
    parse_builtin,
    profile_xml,
    size_for_frames,
    use_profile,
)
from nodes.sim.node import SPEC as SIM

NS = {"f": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}


def test_the_frame_writer_gets_a_shared_memory_segment_sized_for_frames():
    env: dict[str, str] = {}
    size_for_frames(env)
    transports = parse_builtin(env[TRANSPORTS_ENV])
    assert transports is not None
    assert transports.shared_memory and transports.udp  # on this computer and beyond, as before
    # Fast DDS's segment is twice the sockets' size: room for a 3.7 MB frame's fragments
    assert 2 * transports.sockets_bytes >= 2 * 3_686_400


def test_a_transport_the_user_or_a_respawn_chose_is_kept():
    for chosen in ("LARGE_DATA", "UDPv4?sockets_size=8MB"):
        env = {TRANSPORTS_ENV: chosen}
        size_for_frames(env)
        assert env[TRANSPORTS_ENV] == chosen


def test_only_the_sim_publishes_frames():
    assert SIM.publishes_frames
    assert not NodeSpec("x", object, "").publishes_frames


def test_the_builtin_transports_a_profile_can_declare():
    assert parse_builtin(None) == Transports()
    assert parse_builtin(FRAME_WRITER_TRANSPORTS) == Transports(True, True, 8_000_000)
    assert parse_builtin(UDP_AFTER_RESPAWN) == Transports(False, True, 8_000_000)
    assert parse_builtin("SHM?sockets_size=512KB") == Transports(True, False, 512_000)
    for foreign in ("LARGE_DATA", "DEFAULT?max_msg_size=1MB", "UDPv4?sockets_size=big",
                    "DEFAULT?sockets_size=8MB&non_blocking=true"):
        assert parse_builtin(foreign) is None, foreign


def _profile(transports: Transports) -> ET.Element:
    return ET.fromstring(profile_xml(transports))


def test_the_profile_declares_the_transports_and_a_short_heartbeat():
    root = _profile(Transports(True, True, 8_000_000))
    used = [e.text for e in root.findall(".//f:participant//f:userTransports/f:transport_id", NS)]
    assert used == ["shm", "udp"]
    assert root.find(".//f:participant//f:useBuiltinTransports", NS).text == "false"
    shm = root.find(".//f:transport_descriptor[f:type='SHM']", NS)
    assert int(shm.find("f:segment_size", NS).text) == 16_000_000
    period = root.find(".//f:data_writer//f:heartbeatPeriod", NS)
    seconds = int(period.find("f:sec", NS).text) + int(period.find("f:nanosec", NS).text) * 1e-9
    assert abs(seconds - HEARTBEAT_PERIOD_S) < 1e-9 and seconds < 3.0  # Fast DDS's own: 3 s
    udp_only = _profile(Transports(False, True, None))
    assert [e.text for e in udp_only.findall(".//f:transport_descriptor/f:type", NS)] == ["UDPv4"]
    assert udp_only.find(".//f:sendBufferSize", NS) is None  # Fast DDS's own size


def test_use_profile_points_fast_dds_at_one_file_per_content(tmp_path):
    first, second, sim = {}, {}, {TRANSPORTS_ENV: FRAME_WRITER_TRANSPORTS}
    path = use_profile(first, tmp_path)
    assert path is not None and first[PROFILES_ENV] == str(path)
    assert use_profile(second, tmp_path) == path  # the same transports: the same file
    assert ET.parse(path).getroot().tag.endswith("dds")
    assert use_profile(sim, tmp_path) != path
    assert sorted(p.suffix for p in tmp_path.iterdir()) == [".xml", ".xml"]  # no scratch left


def test_a_profile_or_transports_the_user_chose_are_left_alone(tmp_path):
    for chosen in ({PROFILES_ENV: "/etc/mine.xml"}, {"FASTDDS_DEFAULT_PROFILES_FILE": "x.xml"},
                   {TRANSPORTS_ENV: "LARGE_DATA"}):
        env = dict(chosen)
        assert use_profile(env, tmp_path) is None
        assert env == chosen
    assert not list(tmp_path.iterdir())


def test_a_launchers_own_profile_is_not_handed_down_to_the_nodes_it_starts(tmp_path,
                                                                          monkeypatch):
    monkeypatch.setattr("nodes.common.transports.profiles_dir", lambda: tmp_path)
    env: dict[str, str] = {}
    with own_profile(env) as path:
        assert path is not None and env[PROFILES_ENV] == str(path)  # its own participant
    assert PROFILES_ENV not in env  # the nodes started after choose theirs
    chosen = {PROFILES_ENV: "/etc/mine.xml"}
    with own_profile(chosen) as path:
        assert path is None
    assert chosen == {PROFILES_ENV: "/etc/mine.xml"}  # the user's file stays


def test_participants_announce_themselves_often():
    period = _profile(Transports()).find(".//f:participant//f:leaseAnnouncement", NS)
    seconds = int(period.find("f:sec", NS).text) + int(period.find("f:nanosec", NS).text) * 1e-9
    assert abs(seconds - ANNOUNCEMENT_PERIOD_S) < 1e-9 and seconds < 3.0  # Fast DDS's own: 3 s


"""A killed node's Fast DDS shared-memory files are removed; a live process's are kept."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from nodes.cell.shared_memory import clean_dead_shared_memory

pytestmark = pytest.mark.ros

SHM = Path("/dev/shm")
SEGMENT = re.compile(r"^fastrtps_[0-9a-f]{16}(_el)?$")
#: A process with one Fast DDS participant that says so, then waits to be killed.
PARTICIPANT = ("import rclpy, time; rclpy.init(); node = rclpy.create_node('shm_probe'); "
               "print('up', flush=True); time.sleep(120)")


def segments() -> set[str]:
    return {p.name for p in SHM.iterdir() if SEGMENT.match(p.name)}


def start_participant() -> tuple[subprocess.Popen, set[str]]:
    """A participant process and the segment files that appeared with it (Fast DDS makes
    them with the participant, before the process says it is up)."""
    before = segments()
    proc = subprocess.Popen([sys.executable, "-c", PARTICIPANT], stdout=subprocess.PIPE,
                            text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "up"
    return proc, segments() - before


@pytest.mark.skipif(not SHM.is_dir(), reason="no /dev/shm")
def test_the_files_of_a_killed_participant_go_and_a_live_ones_stay():
    live, live_files = start_participant()
    victim, victim_files = start_participant()
    try:
        assert victim_files and live_files, "no Fast DDS segment appeared in /dev/shm"
        victim.kill()
        victim.wait()
        assert victim_files <= segments()  # left behind by the SIGKILL
        summary = clean_dead_shared_memory()
        assert summary.startswith("shared memory: ") and "cleaned" in summary, summary
        assert not victim_files & segments()
        assert live_files <= segments()  # its process holds their locks
    finally:
        for proc in (live, victim):
            proc.kill()
            proc.wait()
        clean_dead_shared_memory()


def test_without_the_tool_the_clean_says_so(tmp_path):
    assert clean_dead_shared_memory(tmp_path / "fastdds.py") == (
        f"shared memory not cleaned: {tmp_path / 'fastdds.py'} is not installed")

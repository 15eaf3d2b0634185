"""/proc figures: parsed from captured text, and read from this very process."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from nodes.bench.proc_stats import (
    cpu_s_from_stat,
    descendants,
    parent_pid_from_stat,
    process_parents,
    rss_mb_from_status,
    sample,
)

STATUS = "Name:\tpython\nVmHWM:\t  250000 kB\nVmRSS:\t  204800 kB\nThreads:\t9\n"
# a command name with a space and a parenthesis: fields count from the last ')'
STAT = ("4242 (py (thon) x) S 1 4242 4242 0 -1 4194560 9000 0 0 0 1234 56 0 0 20 0 9 0 "
        "100 900000000 50000 18446744073709551615")
# the same process after reaping children that used 3.00 s user and 0.40 s system
STAT_REAPED = ("4242 (py (thon) x) S 77 4242 4242 0 -1 4194560 9000 0 0 0 1234 56 300 40 20 0 "
               "9 0 100 900000000 50000 18446744073709551615")


def test_rss_is_read_from_vmrss_in_megabytes():
    assert rss_mb_from_status(STATUS) == pytest.approx(204800 * 1024 / 1e6)


def test_a_status_without_vmrss_is_refused():
    with pytest.raises(ValueError, match="VmRSS"):
        rss_mb_from_status("Name:\tzombie\nState:\tZ (zombie)\n")


def test_cpu_time_is_user_plus_system_ticks_counted_after_the_name():
    assert cpu_s_from_stat(STAT, ticks_per_s=100) == pytest.approx(12.90)


def test_cpu_time_counts_the_children_reaped_and_the_parent_is_read():
    assert cpu_s_from_stat(STAT_REAPED, ticks_per_s=100) == pytest.approx(16.30)
    assert parent_pid_from_stat(STAT_REAPED) == 77


def test_descendants_are_found_down_the_tree_and_no_further():
    parents = {10: 1, 11: 10, 12: 11, 13: 10, 20: 1, 21: 20}
    assert sorted(descendants(10, parents)) == [11, 12, 13]
    assert descendants(12, parents) == []


def test_a_process_is_sampled_with_its_children_unless_asked_not_to():
    child = subprocess.Popen(
        [sys.executable, "-c", "import sys; b = b'x' * 80_000_000; print('ready', flush=True); "
         "sys.stdin.read()"], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    try:
        assert child.stdout.readline() == b"ready\n"  # its 80 MB are touched
        alone = sample(os.getpid())
        whole = sample(os.getpid(), parents=process_parents())
        assert alone is not None and whole is not None
        assert whole.rss_mb - alone.rss_mb > 80
    finally:
        child.communicate(b"")

"""/proc figures: parsed from captured text, and read from this very process."""

from __future__ import annotations

import os

import pytest

from nodes.bench.proc_stats import (
    ProcSample,
    cpu_s_from_stat,
    cpu_used,
    rss_mb_from_status,
    sample,
)

STATUS = "Name:\tpython\nVmHWM:\t  250000 kB\nVmRSS:\t  204800 kB\nThreads:\t9\n"
# a command name with a space and a parenthesis: fields count from the last ')'
STAT = ("4242 (py (thon) x) S 1 4242 4242 0 -1 4194560 9000 0 0 0 1234 56 0 0 20 0 9 0 "
        "100 900000000 50000 18446744073709551615")


def test_rss_is_read_from_vmrss_in_megabytes():
    assert rss_mb_from_status(STATUS) == pytest.approx(204800 * 1024 / 1e6)


def test_a_status_without_vmrss_is_refused():
    with pytest.raises(ValueError, match="VmRSS"):
        rss_mb_from_status("Name:\tzombie\nState:\tZ (zombie)\n")


def test_cpu_time_is_user_plus_system_ticks_counted_after_the_name():
    assert cpu_s_from_stat(STAT, ticks_per_s=100) == pytest.approx(12.90)


def test_cpu_used_counts_a_respawned_process_from_its_start():
    before = ProcSample(10, 100.0, 5.0)
    assert cpu_used(before, ProcSample(10, 101.0, 7.5)) == pytest.approx(2.5)
    assert cpu_used(before, ProcSample(11, 90.0, 1.0)) == pytest.approx(1.0)  # another pid
    assert cpu_used(before, None) is None  # gone


def test_this_process_is_sampled_and_a_missing_one_is_none(tmp_path):
    me = sample(os.getpid())
    assert me is not None and me.pid == os.getpid() and me.rss_mb > 1.0 and me.cpu_s > 0.0
    assert sample(os.getpid(), proc=tmp_path) is None

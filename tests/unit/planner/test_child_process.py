"""Plans in a process of their own: values and typed errors come back, a stop reaches the
child, a child that dies is reported, and what the child allocates stays out of the caller."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from msgs_py import MessageError
from nodes.bench.proc_stats import descendants, process_parents, sample
from nodes.planner.child_process import ChildRunner, PlanningProcessDied, exit_description

RUNNER = ChildRunner(preload=("numpy",))


def pid_of_child(should_stop):
    return os.getpid()


def add(a, b, should_stop):
    return a + b


def refuse(field, should_stop):
    raise MessageError(field, 3, "not allowed")


def wait_for_stop(should_stop):
    while not should_stop():  # a plan polls its budget the same way
        time.sleep(0.01)
    return "stopped"


def die(should_stop):
    os.kill(os.getpid(), signal.SIGKILL)


def allocate_mb(mb, should_stop):
    block = np.ones(int(mb * 1e6 // 8))
    return float(block.sum())


def test_the_value_comes_back_from_another_process():
    assert RUNNER.run(add, 2, 3) == 5
    assert RUNNER.run(pid_of_child) != os.getpid()


def test_an_error_comes_back_with_its_type_and_field():
    with pytest.raises(MessageError) as err:
        RUNNER.run(refuse, "goal.poses[1]")
    assert err.value.field == "goal.poses[1]"


def test_the_callers_stop_reaches_the_child():
    asked = []

    def should_stop():
        asked.append(True)
        return len(asked) > 3

    assert RUNNER.run(wait_for_stop, should_stop=should_stop) == "stopped"


def test_a_child_that_dies_is_reported_by_its_signal():
    with pytest.raises(PlanningProcessDied, match="SIGKILL"):
        RUNNER.run(die)
    assert RUNNER.run(add, 1, 1) == 2  # the next plan runs as before


def test_what_the_child_allocates_is_not_the_callers():
    before = sample(os.getpid())
    assert RUNNER.run(allocate_mb, 300) == pytest.approx(300e6 / 8)
    after = sample(os.getpid())
    assert before is not None and after is not None
    assert after.rss_mb - before.rss_mb < 50  # 300 MB were touched, in the child


def test_exit_codes_in_words():
    assert exit_description(3) == "exit code 3"
    assert exit_description(-signal.SIGKILL) == "killed by SIGKILL"
    assert exit_description(None) == "still running"


def test_a_killed_caller_leaves_no_planning_process_behind():
    """The planner node killed mid-plan (SIGKILL, as the chaos benchmark does): its fork
    server exits, and the plan's process, orphaned, gives up as on a stop."""
    script = ("import sys, time; from tests.unit.planner.test_child_process import RUNNER, "
              "wait_for_stop; print('start', flush=True); RUNNER.run(wait_for_stop)")
    caller = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                              cwd=Path(__file__).parents[3])
    assert caller.stdout.readline() == b"start\n"
    planning = []
    for _ in range(600):  # the plan's process is forked by the fork server
        planning = [p for p in descendants(caller.pid, process_parents()) if alive(p)]
        if len(planning) >= 3:  # fork server, resource tracker, the plan's process
            break
        time.sleep(0.05)
    assert len(planning) >= 3, planning
    caller.kill()
    caller.wait()
    for _ in range(600):
        if not any(alive(p) for p in planning):
            break
        time.sleep(0.05)
    assert not any(alive(p) for p in planning)



def alive(pid: int) -> bool:
    """Running: not gone, not a zombie waiting for its parent (``sample`` says None)."""
    return sample(pid) is not None

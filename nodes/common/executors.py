"""The executors a node process spins on: one thread (``single_threaded``), or a
multi-threaded one that lets its workers start what it hands them (``PatientExecutor``).

``single_threaded``: rclpy's ``EventsExecutor`` (``rclpy.experimental``, in the Jazzy wheels):
it waits for events in C++ and queues the ready callbacks, where the ``SingleThreadedExecutor``
rebuilds its wait set in Python on every callback. Measured with a sim-time node (a 50 Hz ROS
timer publishing, four 100 Hz subscriptions, /clock at 100 Hz) over 10 s on the 2-core VM:
1.48 s of CPU on the ``SingleThreadedExecutor``, 0.34 s on the ``EventsExecutor``, the same
callbacks run (taken beside a running cell: CPU time, not wall). ``DENSEPACK_EXECUTOR=single``
in the environment goes back to the ``SingleThreadedExecutor`` (the events executor is
experimental upstream). ``spin`` spins either: the events executor's own ``spin()`` ignores
SIGTERM and SIGINT in the Jazzy wheels (and its ``shutdown()`` from another thread hangs), so
it is spun one callback at a time, which raises ``ExternalShutdownException`` once a signal
has shut the context down, as rclpy's executors do.

``PatientExecutor``:

Jazzy's ``MultiThreadedExecutor`` hands a callback to its thread pool and, on its next
wake-up, hands the same callback out again if no worker has started it yet (it is still
"ready"): the wake-up is immediate, so the spinning thread loops, holding the GIL the workers
need to start it. On 2 cores this fed on itself: the test harness's node timers fell to 4-12 Hz
of 50, and a two-action fake-cell run took 35 s instead of 6. ``PatientExecutor`` waits, after
each hand-out, until the workers have started what they were given (at most ``START_WAIT_S``).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable

from rclpy.context import Context
from rclpy.executors import Executor, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor

#: The environment variable that picks the one-thread executor: ``events`` (the default) or
#: ``single`` (rclpy's SingleThreadedExecutor).
EXECUTOR_ENV = "DENSEPACK_EXECUTOR"


def single_threaded(context: Context | None = None) -> Executor:
    """The executor of a node whose callbacks all run on one thread (see the module), in
    ``context`` (rclpy's default context if None)."""
    choice = os.environ.get(EXECUTOR_ENV, "events")
    if choice == "single":
        return SingleThreadedExecutor(context=context)
    if choice != "events":
        raise ValueError(f"{EXECUTOR_ENV}={choice!r}: expected 'events' or 'single'")
    return EventsExecutor(context=context)


#: The events executor's longest wait for a callback (s): how late a stop may be noticed.
EVENTS_WAKE_S = 0.2


def spin(executor: Executor) -> None:
    """Spin ``executor`` until the context shuts down (raises ``ExternalShutdownException``
    then, as ``Executor.spin`` does)."""
    if isinstance(executor, Executor):  # the events executor is not an rclpy Executor
        executor.spin()
        return
    while True:
        executor.spin_once(timeout_sec=EVENTS_WAKE_S)


#: The longest a spin waits for its workers to start the callbacks handed out (s): a worker
#: busy with a long callback must not stop the others from being handed theirs.
START_WAIT_S = 0.01
_POLL_S = 0.0005


class PatientExecutor(MultiThreadedExecutor):
    def _spin_once_impl(self, timeout_sec=None,
                        wait_condition: Callable[[], bool] = lambda: False) -> None:
        super()._spin_once_impl(timeout_sec, wait_condition)
        deadline = time.monotonic() + START_WAIT_S
        while time.monotonic() < deadline and any(
                not (task.executing() or task.done()) for task in list(self._futures)):
            time.sleep(_POLL_S)

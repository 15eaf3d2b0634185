"""A multi-threaded rclpy executor that lets its workers start what it hands them.

Jazzy's ``MultiThreadedExecutor`` hands a callback to its thread pool and, on its next
wake-up, hands the same callback out again if no worker has started it yet (it is still
"ready"): the wake-up is immediate, so the spinning thread loops, holding the GIL the workers
need to start it. On 2 cores this fed on itself: the test harness's node timers fell to 4-12 Hz
of 50, and a two-action fake-cell run took 35 s instead of 6. ``PatientExecutor`` waits, after
each hand-out, until the workers have started what they were given (at most ``START_WAIT_S``).
"""

from __future__ import annotations

import time
from collections.abc import Callable

from rclpy.executors import MultiThreadedExecutor

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

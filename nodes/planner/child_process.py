"""Each plan in a process of its own, so a planner node that plans goal after goal for days
keeps a flat memory footprint.

A plan allocates tens of MB (numpy arrays, shapely/GEOS geometry, Python objects) and frees
them again, but a long-running process does not give all of it back: the allocator keeps
freed memory, fragmented, in its arenas. Over a 200-goal soak the planner node's resident
memory drifted up 13 % while the Python heap it held between goals stayed flat (tracemalloc).
A plan computed in a process forked for it returns every page when that process exits.

The processes are forked by multiprocessing's fork server, started once with the planner's
modules imported (``PRELOAD``), so a plan starts within milliseconds and the node's own DDS
threads are never forked. A crash in the planning code (a fault in a C extension) ends that
process with a clear error, not the node. The child gives up, as a plan does on its
``should_stop``, when the node asks it to or is gone (killed: the child sees its end of their
connection close); the fork server exits once the node and its last child are gone.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.forkserver
import pickle
import signal
import time
from collections.abc import Callable
from multiprocessing.connection import Connection
from typing import Any

#: Imported once by the fork server: every plan's process starts with them loaded.
PRELOAD = ("nodes.planner.dispatch",)
#: How often the waiting thread looks at the node's stop flag and the child's life (s).
POLL_S = 0.05
#: How often the child looks for a stop from the node, or its death (s of a plan's time).
CHILD_CHECK_S = 0.01
#: After a stop, the child has this long (s) to give up on its own before it is killed.
STOP_GRACE_S = 2.0


class PlanningProcessDied(RuntimeError):
    """The planning process ended without an answer (killed, or crashed in native code)."""


def exit_description(exitcode: int | None) -> str:
    """A process's exit code in words: 'exit code 3', 'killed by SIGKILL'."""
    if exitcode is None:
        return "still running"
    if exitcode < 0:
        try:
            return f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exit code {exitcode}"


def sendable(err: BaseException) -> BaseException:
    """``err`` if it survives pickling (so the node sees its type and fields), else a
    RuntimeError that names it."""
    try:
        pickle.loads(pickle.dumps(err))
        return err
    except Exception:
        return RuntimeError(f"{type(err).__name__}: {err}")


def _child(conn: Connection, fn: Callable[..., Any], args: tuple) -> None:
    """In the forked process: ``fn(*args, should_stop=...)``, its value or exception sent
    back. It stops when the node says so on ``conn``, or closes it (the node is gone)."""
    asked = {"stop": False, "checked": 0.0}

    def should_stop() -> bool:  # polled often by a plan: the connection is read seldom
        now = time.monotonic()
        if not asked["stop"] and now - asked["checked"] >= CHILD_CHECK_S:
            asked["checked"] = now
            asked["stop"] = conn.poll()  # a stop, or the end of the node's side
        return asked["stop"]

    try:
        answer: tuple[str, Any] = ("value", fn(*args, should_stop=should_stop))
    except Exception as err:
        answer = ("raised", sendable(err))
    try:
        conn.send(answer)
    except (OSError, pickle.PicklingError, TypeError, AttributeError) as err:
        if not isinstance(err, OSError):  # the value could not be pickled: say so
            conn.send(("raised", RuntimeError(f"the plan could not be sent back: {err}")))
    finally:
        conn.close()


class ChildRunner:
    """Runs a function in a freshly forked process and waits for its answer."""

    def __init__(self, preload: tuple[str, ...] = PRELOAD) -> None:
        self._ctx = multiprocessing.get_context("forkserver")
        self._ctx.set_forkserver_preload(list(preload))

    def warm_up(self) -> None:
        """Start the fork server now (it imports ``PRELOAD`` in the background), so the first
        plan does not wait for it."""
        multiprocessing.forkserver.ensure_running()

    def run(self, fn: Callable[..., Any], *args: Any,
            should_stop: Callable[[], bool] | None = None) -> Any:
        """``fn(*args, should_stop=...)`` in its own process: its value, or the exception it
        raised. ``fn`` and the arguments must pickle.

        Raises:
            PlanningProcessDied: the process ended without answering, or did not give up
                within STOP_GRACE_S of ``should_stop``.
        """
        ours, theirs = self._ctx.Pipe(duplex=True)
        proc = self._ctx.Process(target=_child, args=(theirs, fn, args), daemon=True,
                                 name="densepack-planning")
        proc.start()
        theirs.close()
        try:
            kind, value = self._answer(proc, ours, should_stop)
        finally:
            ours.close()
            if proc.is_alive():
                proc.kill()
            proc.join()
            proc.close()
        if kind == "raised":
            raise value
        return value

    @staticmethod
    def _answer(proc: multiprocessing.process.BaseProcess, conn: Connection,
                should_stop: Callable[[], bool] | None) -> tuple[str, Any]:
        stop_by: float | None = None
        while True:
            if conn.poll(POLL_S):
                try:
                    return conn.recv()
                except EOFError:
                    proc.join(1.0)
                    raise PlanningProcessDied(
                        "the planning process ended without a plan "
                        f"({exit_description(proc.exitcode)})") from None
            if stop_by is None and should_stop is not None and should_stop():
                conn.send("stop")
                stop_by = time.monotonic() + STOP_GRACE_S
            if stop_by is not None and time.monotonic() > stop_by:
                raise PlanningProcessDied(f"the planning process did not stop within "
                                          f"{STOP_GRACE_S:.0f} s of being asked; killed")

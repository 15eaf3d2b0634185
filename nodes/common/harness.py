"""In-process ROS 2 test harness: a private rclpy Context on its own DDS domain.

``RosHarness`` spins the nodes of one test on a multi-threaded executor in a background
thread and offers ``wait_for_message`` / ``call_service`` to drive them, the way rclpy's
own tests step an executor until a condition holds or a deadline passes. Users writing
integration tests of their own can use it directly::

    with RosHarness() as ros:
        planner = ros.add(PlannerNode(context=ros.context))
        plan = ros.wait_for_message("/plan", PlanMsg, timeout=30, qos=LATCHED)

``allocate_domain_id`` hands every test session its own ``ROS_DOMAIN_ID`` (an flock on a
file under the temp directory) so parallel runs on one machine do not hear each other.
"""

from __future__ import annotations

import fcntl
import os
import random
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile

from nodes.common.executors import PatientExecutor
from nodes.common.qos import RELIABLE

_DOMAIN_LOCKS: list[Any] = []  # keep lock files open for the life of the process


def allocate_domain_id(lo: int = 1, hi: int = 80) -> int:
    """A DDS domain id no other live process on this machine holds (via flock).

    Ids 81-101 stay free for people running a cell by hand next to a test session.
    """
    lock_dir = Path(tempfile.gettempdir()) / "densepack-domains"
    lock_dir.mkdir(exist_ok=True)
    candidates = list(range(lo, hi + 1))
    random.Random(os.getpid() ^ time.time_ns()).shuffle(candidates)
    for domain in candidates:
        handle = open(lock_dir / f"{domain}.lock", "w")  # noqa: SIM115 - held open on purpose
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        _DOMAIN_LOCKS.append(handle)
        return domain
    raise RuntimeError(f"every ROS_DOMAIN_ID in [{lo}, {hi}] is held by another process")


def wait_for_future(future: Any, what: str, timeout: float) -> Any:
    """The result of an rclpy future that another thread spins (a service answer, an action's
    goal response or result).

    Raises:
        TimeoutError: not done within ``timeout`` seconds (``what`` names it).
    """
    deadline = time.monotonic() + timeout
    while not future.done():
        if time.monotonic() > deadline:
            raise TimeoutError(f"{what} did not answer in {timeout} s")
        time.sleep(0.01)
    return future.result()


class RosHarness:
    """A private Context + executor thread; nodes added to it spin until ``shutdown``."""

    def __init__(self, domain_id: int | None = None, threads: int = 6) -> None:
        if domain_id is None:
            domain_id = int(os.environ.get("ROS_DOMAIN_ID", "0"))
        self.domain_id = domain_id
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.executor = PatientExecutor(num_threads=threads, context=self.context)
        self.probe = Node("harness_probe", context=self.context)
        self.executor.add_node(self.probe)
        self._nodes: list[Node] = [self.probe]
        self._errors: list[BaseException] = []
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._subs: dict[tuple, tuple] = {}
        self._clients: dict[tuple, Any] = {}
        self._thread = threading.Thread(target=self._spin, name="ros-harness", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while self.context.ok() and not self._stop.is_set():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except Exception as err:  # surfaced by ``check`` so a test fails loudly
                if not self.context.ok():
                    break
                self._errors.append(err)

    # --- nodes ----------------------------------------------------------------------------------
    def add(self, node: Node) -> Node:
        self._nodes.append(node)
        self.executor.add_node(node)
        return node

    def check(self) -> None:
        """Raise the first exception a node callback threw while spinning."""
        if self._errors:
            raise self._errors[0]

    # --- messages -------------------------------------------------------------------------------
    def _subscription(self, topic: str, msg_type: type, qos: QoSProfile) -> tuple:
        """One long-lived subscription per (topic, type, QoS), shared by every waiter.

        Subscriptions are never destroyed while the executor spins: destroying an entity
        that a wait set is using races with the spinning thread.
        """
        key = (topic, msg_type, qos.reliability, qos.durability, qos.depth)
        with self._lock:
            if key not in self._subs:
                waiters: list[Callable[[Any], None]] = []
                latest: list[Any] = []

                def dispatch(msg: Any, waiters=waiters, latest=latest) -> None:
                    with self._lock:
                        latest[:] = [msg]
                        current = list(waiters)
                    for waiter in current:
                        waiter(msg)

                sub = self.probe.create_subscription(msg_type, topic, dispatch, qos)
                self._subs[key] = (sub, waiters, latest)
            return self._subs[key]

    def wait_for_message(
        self,
        topic: str,
        msg_type: type,
        predicate: Callable[[Any], bool] | None = None,
        timeout: float = 10.0,
        qos: QoSProfile = RELIABLE,
    ) -> Any:
        """The first message on ``topic`` that satisfies ``predicate``.

        With a transient-local (latched) ``qos`` the last message already received counts
        too, so a test sees a latched state even if it arrived before the call.

        Raises:
            TimeoutError: nothing matching arrived within ``timeout`` seconds.
        """
        found: list[Any] = []
        event = threading.Event()

        def on_message(msg: Any) -> None:
            if not event.is_set() and (predicate is None or predicate(msg)):
                found.append(msg)
                event.set()

        _, waiters, latest = self._subscription(topic, msg_type, qos)
        with self._lock:
            waiters.append(on_message)
            replay = list(latest) if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL else []
        try:
            for msg in replay:
                on_message(msg)
            if not event.wait(timeout):
                self.check()
                raise TimeoutError(f"no matching {msg_type.__name__} on {topic} in {timeout} s")
        finally:
            with self._lock:
                waiters.remove(on_message)
        return found[0]

    def publisher(self, topic: str, msg_type: type, qos: QoSProfile = RELIABLE) -> Any:
        return self.probe.create_publisher(msg_type, topic, qos)

    def wait_for_subscribers(self, publisher: Any, count: int = 1, timeout: float = 10.0) -> None:
        deadline = time.monotonic() + timeout
        while publisher.get_subscription_count() < count:
            if time.monotonic() > deadline:
                raise TimeoutError(f"no subscriber on {publisher.topic_name} in {timeout} s")
            time.sleep(0.02)

    def call_service(self, name: str, srv_type: type, request: Any = None, timeout: float = 10.0):
        with self._lock:
            client = self._clients.get((name, srv_type))
            if client is None:  # kept for the harness's life: see _subscription
                client = self._clients[(name, srv_type)] = self.probe.create_client(srv_type, name)
        if not client.wait_for_service(timeout_sec=timeout):
            raise TimeoutError(f"service {name} not available in {timeout} s")
        future = client.call_async(request if request is not None else srv_type.Request())
        return wait_for_future(future, f"service {name}", timeout)

    # --- lifecycle ------------------------------------------------------------------------------
    def shutdown(self) -> None:
        self._stop.set()
        self._thread.join(timeout=10.0)
        self.executor.shutdown()
        self._wait_for_callbacks(timeout=10.0)
        for node in reversed(self._nodes):
            node.destroy_node()
        self._nodes.clear()
        rclpy.try_shutdown(context=self.context)

    def _wait_for_callbacks(self, timeout: float) -> None:
        """Let callbacks still running in the executor's worker threads finish before their
        nodes are destroyed. Jazzy's ``Executor.shutdown`` does not wait for them (its wait
        is skipped once the shutdown flag is set), and a callback that outlives its node
        fails inside rclpy ("cannot use Destroyable because destruction was requested").
        The executor keeps the tasks it submitted in ``_futures``; without it, nothing to
        wait for."""
        deadline = time.monotonic() + timeout
        for task in list(getattr(self.executor, "_futures", ())):
            while not task.done() and time.monotonic() < deadline:
                time.sleep(0.01)

    def __enter__(self) -> RosHarness:
        return self

    def __exit__(self, *exc: object) -> None:
        self.shutdown()

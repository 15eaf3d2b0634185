"""One commander at a time, on ROS: the device node's lease service and command gate
(``LeaseServer``, in the arm and gripper nodes) and the holder's side (``LeaseClient``, in
the executor). The book-keeping is ``nodes.common.lease``; this module only wires it to the
graph, a service, and the public and private command topics.

``/<device>/lease`` (``densepack_interfaces/srv/ControlLease``) grants the lease and names a
private command topic, ``/<device>/lease/<token>/<leaf>``, on which the device node then
subscribes. Once the holder's publisher is seen there (``get_publisher_count``), commands on
the public ``/<device>/<leaf>`` are refused: counted, and the nodes the graph lists as
publishing there (``get_publishers_info_by_topic``) named in a throttled log line and on the
device's status; before that, the public topic still works, so no command is lost while the
holder switches. About once a second (steady time) the node lists the graph's nodes
(``get_node_names_and_namespaces``) and ends the lease of a holder that left.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from densepack_interfaces.srv import ControlLease
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node

from nodes.common.lease import Ask, Lease, LeaseBook, LeaseConfig, LeaseKeeper, LeaseStatus
from nodes.common.qos import RELIABLE

#: The private topics' publisher and subscription come and go with leases: without QoS event
#: handlers, since rclpy Jazzy's multi-threaded executor fails its spin (InvalidHandle) when an
#: entity with event handlers is destroyed on one thread while another builds its wait set.
NO_EVENTS_SUB = SubscriptionEventCallbacks(use_default_callbacks=False)
NO_EVENTS_PUB = PublisherEventCallbacks(use_default_callbacks=False)


def qualified(name: str, namespace: str) -> str:
    """A node's fully qualified name from the graph's name and namespace."""
    return f"{namespace.rstrip('/')}/{name}"


def graph_nodes(node: Node) -> set[str]:
    return {qualified(n, ns) for n, ns in node.get_node_names_and_namespaces()}


def publishers_of(node: Node, topic: str) -> list[str]:
    return sorted({qualified(info.node_name, info.node_namespace)
                   for info in node.get_publishers_info_by_topic(topic)})


def private_topic(device: str, token: str, leaf: str) -> str:
    return f"/{device}/lease/{token}/{leaf}"


class LeaseServer:
    """A device's lease and command gate on ``node``: ``on_command(msg)`` gets the commands
    the lease lets through (the public topic's without a lease, the holder's with one)."""

    def __init__(self, node: Node, device: str, leaf: str, msg_type: type,
                 on_command: Callable[[Any], None], cfg: LeaseConfig,
                 callback_group: Any = None) -> None:
        self.node = node
        self.device, self.leaf, self.msg_type = device, leaf, msg_type
        self.public_topic = f"/{device}/{leaf}"
        self.on_command = on_command
        self.book = LeaseBook(f"the {device}", cfg.absent_checks)
        self._group = callback_group
        self._lock = threading.Lock()
        self._private: tuple[str, Any] | None = None  # (token, subscription)
        public = node.create_subscription(msg_type, self.public_topic, self._on_public,
                                          RELIABLE, callback_group=callback_group)
        self.public_topic = public.topic_name  # as remapped: the graph knows it by that name
        node.create_service(ControlLease, f"/{device}/lease", self._on_request,
                            callback_group=callback_group)
        node.create_timer(cfg.check_period_s, self.check_graph, callback_group=callback_group,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))

    def status(self) -> LeaseStatus:
        with self._lock:
            return self.book.status()

    # --- commands -------------------------------------------------------------------------------
    def _in_force(self) -> Lease | None:
        """The lease, once its holder publishes on its private topic."""
        with self._lock:
            lease, private = self.book.lease, self._private
        if lease is None or private is None or private[1].get_publisher_count() == 0:
            return None
        return lease

    def _on_public(self, msg: Any) -> None:
        lease = self._in_force()
        if lease is None:
            self.on_command(msg)
            return
        publishers = publishers_of(self.node, self.public_topic)
        with self._lock:
            charged = self.book.refuse(publishers)
            refused = self.book.refused
        who = ", ".join(charged) or "nobody but the holder (sent before it switched, or gone)"
        self.node.get_logger().warning(
            f"{self.public_topic} refused ({refused} so far): {lease.holder} holds the "
            f"{self.device}; publishing on {self.public_topic}: {who}",
            throttle_duration_sec=1.0)

    def _private_callback(self, token: str) -> Callable[[Any], None]:
        def on_private(msg: Any) -> None:
            with self._lock:
                current = self._private is not None and self._private[0] == token
            if current:
                self.on_command(msg)
        return on_private

    # --- the service ----------------------------------------------------------------------------
    def _on_request(self, request: Any, response: Any) -> Any:
        now = self.node.get_clock().now().nanoseconds * 1e-9
        holder = str(request.holder)
        with self._lock:
            if request.release:
                answer = self.book.release(holder, str(request.token))
            else:
                answer = self.book.request(holder, now)
            response.holder = self.book.holder
        if answer.ended is not None:
            self._drop(answer.ended)
        response.granted, response.message = answer.granted, answer.message
        if answer.granted and answer.lease is not None:
            token = answer.lease.token
            topic = private_topic(self.device, token, self.leaf)
            self._listen(token, topic)
            response.token, response.command_topic = token, topic
            self.node.get_logger().info(f"{answer.message}: commands on {topic} only")
        elif not request.release:
            self.node.get_logger().warning(f"lease asked by {holder} {answer.message}")
        else:
            self.node.get_logger().info(answer.message)
        return response

    def _listen(self, token: str, topic: str) -> None:
        """Subscribe on the lease's private topic (unless a newer lease came meanwhile)."""
        subscription = self.node.create_subscription(
            self.msg_type, topic, self._private_callback(token), RELIABLE,
            callback_group=self._group, event_callbacks=NO_EVENTS_SUB)
        with self._lock:
            current = self.book.lease is not None and self.book.lease.token == token
            if current:
                self._private = (token, subscription)
        if not current:
            self.node.destroy_subscription(subscription)

    def _drop(self, lease: Lease) -> None:
        """Unsubscribe from the private topic of a lease that ended."""
        with self._lock:
            private = self._private
            if private is None or private[0] != lease.token:
                return
            self._private = None
        self.node.destroy_subscription(private[1])

    # --- the graph ------------------------------------------------------------------------------
    def check_graph(self) -> None:
        """One look at the graph: a holder that left loses its lease; a node other than the
        holder publishing on the private topic is named (and warned of)."""
        nodes = graph_nodes(self.node)
        with self._lock:
            ended = self.book.on_graph(nodes)
            private = self._private
        if ended is not None:
            self._drop(ended)
            self.node.get_logger().warning(
                f"the {self.device}'s lease ended: its holder {ended.holder} left the ROS "
                f"graph; {self.public_topic} commands the {self.device} again")
            return
        if private is None:
            return
        topic = private_topic(self.device, private[0], self.leaf)
        with self._lock:
            intruders = [p for p in publishers_of(self.node, topic) if p != self.book.holder]
            for name in intruders:
                self.book.name(name)
        if intruders:
            self.node.get_logger().warning(
                f"{', '.join(intruders)} publish on {topic}, the private topic of "
                f"{self.book.holder}'s lease (their commands cannot be told apart)",
                throttle_duration_sec=10.0)


class LeaseClient:
    """The holder's side on ``node`` for one device: ``update(want)`` each tick takes or gives
    back the lease; ``publish`` sends on the private topic once connected, else the public.

    The device closes its public topic when it sees the holder's publisher, the holder
    switches when it sees the device's subscriber: a command sent on the public topic in
    between is refused. With ``resend_s`` > 0 the last command, when sent that recently, goes
    again on the private topic at the switch (the gripper's: one command per grip or release,
    which must not be lost; the arm's setpoints stream at 50 Hz and one missed is
    interpolated over)."""

    def __init__(self, node: Node, device: str, leaf: str, msg_type: type,
                 retry_s: float = 1.0, resend_s: float = 0.0) -> None:
        self.node = node
        self.device = device
        self.resend_s = resend_s
        self._last: tuple[Any, float] | None = None  # the last command sent, when (steady s)
        self.public = node.create_publisher(msg_type, f"/{device}/{leaf}", RELIABLE)
        self.client = node.create_client(ControlLease, f"/{device}/lease")
        self.keeper = LeaseKeeper(f"the {device}'s", retry_s)
        self._msg_type = msg_type
        self._private: tuple[str, Any] | None = None  # (topic, publisher)
        self._lock = threading.Lock()
        self.resends = 0  #: how often the last command went again at a switch
        self._was_connected = False  # a lease of this device was ever connected

    def update(self, want: bool) -> list[str]:
        """Take or give back the lease as ``want`` says; returns the lines to log."""
        now = time.monotonic()
        with self._lock:
            subscribers = 0 if self._private is None else self._private[1].get_subscription_count()
            ask = self.keeper.step(want, now, self.client.service_is_ready(), subscribers)
            self._sync_publisher()
            self._was_connected = self._was_connected or self.keeper.connected
            token = self.keeper.token
            lines = self.keeper.take_log()
            if self.keeper.switched:
                self.keeper.switched = False
                last = self._last
                if (last is not None and self._private is not None
                        and now - last[1] <= self.resend_s):
                    self._private[1].publish(last[0])
                    self.resends += 1
        if ask is not None:
            request = ControlLease.Request(holder=self.node.get_fully_qualified_name(),
                                           release=ask is Ask.GIVE_BACK, token=token)
            self.client.call_async(request).add_done_callback(self._answered)
        return lines

    def on_device_status(self, holder: str) -> None:
        """The lease holder the device's status names (``LeaseKeeper.on_device_holder``)."""
        with self._lock:
            self.keeper.on_device_holder(holder, self.node.get_fully_qualified_name(),
                                         time.monotonic())

    def takes_my_commands(self, holder: str) -> bool:
        """The device's status names this node as its holder (``holder``) and the commands go
        on its private topic: what the device reports now answers them. Before this node was
        ever connected to a lease (a device without leases, or the first run), the device is
        taken at its word."""
        with self._lock:
            if not self._was_connected:
                return True
            return holder == self.node.get_fully_qualified_name() and self.keeper.connected

    def inherited(self, holder: str) -> bool:
        """The device names this node's name as its holder (``holder``) though this node never
        connected a lease: a predecessor under the same name took it (an executor respawned
        before the device saw the old one leave the graph). Until this node takes the lease
        again, the device refuses its commands on the closed public topic."""
        with self._lock:
            return not self._was_connected and holder == self.node.get_fully_qualified_name()

    def publish(self, msg: Any) -> None:
        with self._lock:
            private = self._private if self.keeper.connected else None
            self._last = (msg, time.monotonic())
        (self.public if private is None else private[1]).publish(msg)

    def close(self) -> None:
        """Give the lease back on the way out (when the context still lets a request go;
        otherwise the device ends it once this node has left the graph)."""
        with self._lock:
            token = self.keeper.token
        if token and self.client.service_is_ready():
            request = ControlLease.Request(holder=self.node.get_fully_qualified_name(),
                                           release=True, token=token)
            self.client.call_async(request)

    def _answered(self, future: Any) -> None:
        now = time.monotonic()
        try:
            answer = future.result()
        except Exception as err:  # the device node went away while answering
            with self._lock:
                self.keeper.on_failed(f"{type(err).__name__}: {err}", now)
            return
        with self._lock:
            if answer is None:
                self.keeper.on_failed("no answer", now)
            else:
                self.keeper.on_answer(bool(answer.granted), str(answer.token),
                                      str(answer.command_topic), str(answer.message), now)
            self._sync_publisher()

    def _sync_publisher(self) -> None:
        """The private publisher follows the keeper's topic (under the lock)."""
        topic = self.keeper.topic
        if self._private is not None and self._private[0] != topic:
            self.node.destroy_publisher(self._private[1])
            self._private = None
        if topic and self._private is None:
            self._private = (topic, self.node.create_publisher(
                self._msg_type, topic, RELIABLE, event_callbacks=NO_EVENTS_PUB))

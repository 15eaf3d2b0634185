"""Two computers on one machine: two network namespaces joined by a veth pair, each with an
address of its own on one subnet (docs/real_cell.md, "Several computers"). Traffic goes only
between the two namespaces this module makes; they are removed when the ``with`` ends, on
failure too. Needs root (``ip netns``); ``Hosts.make`` raises ``HostsUnavailable`` with the
reason where it cannot."""

from __future__ import annotations

import os
import shutil
import subprocess
from dataclasses import dataclass

SUBNET = "10.29.0"


class HostsUnavailable(RuntimeError):
    pass


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, text=True, timeout=10)


@dataclass
class Host:
    namespace: str
    link: str
    address: str

    def command(self, argv: list[str], env: dict[str, str]) -> list[str]:
        """``argv`` run inside this host with ``env`` (given whole: ``ip netns exec`` keeps
        the caller's environment, ``env -i`` starts from nothing)."""
        return ["ip", "netns", "exec", self.namespace, "env", "-i",
                *(f"{k}={v}" for k, v in env.items()), *argv]

    def link_up(self, up: bool) -> None:
        """Plug in or pull out this host's network cable."""
        _ip("-n", self.namespace, "link", "set", self.link, "up" if up else "down")


class Hosts:
    """Host ``a`` and host ``b``, named after this process (so parallel sessions differ)."""

    def __init__(self) -> None:
        tag = f"dp{os.getpid() % 100000}"
        self.a = Host(f"{tag}a", f"{tag}a", f"{SUBNET}.1")
        self.b = Host(f"{tag}b", f"{tag}b", f"{SUBNET}.2")
        self._made: list[str] = []

    def __enter__(self) -> Hosts:
        if os.geteuid() != 0:
            raise HostsUnavailable("network namespaces need root")
        if shutil.which("ip") is None:
            raise HostsUnavailable("no 'ip' command (iproute2)")
        try:
            for host in (self.a, self.b):
                _ip("netns", "add", host.namespace)
                self._made.append(host.namespace)
            _ip("link", "add", self.a.link, "type", "veth", "peer", "name", self.b.link)
            for host in (self.a, self.b):
                _ip("link", "set", host.link, "netns", host.namespace)
                _ip("-n", host.namespace, "addr", "add", f"{host.address}/24", "dev", host.link)
                _ip("-n", host.namespace, "link", "set", "lo", "up")
                _ip("-n", host.namespace, "link", "set", host.link, "up", "multicast", "on")
        except (subprocess.CalledProcessError, subprocess.TimeoutExpired) as err:
            self.__exit__()
            why = getattr(err, "stderr", "") or str(err)
            raise HostsUnavailable(f"cannot make network namespaces: {why.strip()}") from None
        return self

    def __exit__(self, *exc: object) -> None:
        for namespace in self._made:  # deleting one end's namespace removes the veth pair
            subprocess.run(["ip", "netns", "del", namespace], capture_output=True, timeout=10)
        self._made.clear()

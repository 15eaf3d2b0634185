"""``builtin_interfaces/Time`` <-> integer nanoseconds: every stamp of the cell."""

from __future__ import annotations

from typing import Any

from builtin_interfaces.msg import Time

from msgs_py.errors import MessageError

#: The seconds ``builtin_interfaces/Time`` holds (an int32).
TIME_SEC_MIN, TIME_SEC_MAX = -(2**31), 2**31 - 1


def stamp_to_ns(stamp: Time) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def ns_to_stamp(stamp_ns: Any, where: str = "stamp") -> Time:
    """Nanoseconds -> ``Time``; MessageError (naming ``where``) when Time cannot hold it."""
    if isinstance(stamp_ns, bool) or not isinstance(stamp_ns, int):
        raise MessageError(where, stamp_ns, "expected an integer (ns)")
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    if not TIME_SEC_MIN <= sec <= TIME_SEC_MAX:
        raise MessageError(where, stamp_ns, "outside the range of builtin_interfaces/Time")
    return Time(sec=sec, nanosec=nanosec)

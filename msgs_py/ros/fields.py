"""The field checks every densepack_interfaces codec shares.

Each check takes ``where``, the field's message path (``blocks[2].pose.x``), and raises
``MessageError`` naming it; ``field_paths`` re-raises a dataclass's own error under the message's
path. Vocabularies travel as the messages' constants: ``constants_of`` reads them from the
generated class and fails at import when the vocabulary and the message disagree.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from msgs_py.checks import finite_float
from msgs_py.errors import MessageError
from msgs_py.ros.stamps import ns_to_stamp
from msgs_py.scene import SCHEMA_VERSION

WORLD = "world"
NO_BLOCK = -1
INT32_MAX = 2**31 - 1
UINT32_MAX = 2**32 - 1
INT64_MIN, INT64_MAX = -(2**63), 2**63 - 1
INT64_MIN, INT64_MAX = -(2**63), 2**63 - 1


def constants_of(msg_type: type, prefix: str, names: Sequence[str]) -> dict[str, int]:
    """Vocabulary name -> the message's constant ``PREFIX_NAME`` (all of them must exist)."""
    table = {}
    for name in names:
        constant = f"{prefix}{name.upper()}"
        if not hasattr(msg_type, constant):
            raise ImportError(f"{msg_type.__name__} lacks {constant} for '{name}': rebuild "
                              "densepack_interfaces after changing the vocabulary")
        table[name] = int(getattr(msg_type, constant))
    return table


@contextmanager
def field_paths(prefix: str, renames: Sequence[tuple[str, str]] = ()) -> Iterator[None]:
    """Re-raise a dataclass's MessageError with its field as a message path under ``prefix``.

    ``renames`` maps the dict-schema names the dataclasses use (``goal.poses[2].id``) to the
    message's (``goal.slots[2].block_id``); the longest matching start wins.
    """
    try:
        yield
    except MessageError as err:
        name, reason = err.field, err.reason
        for old, new in sorted(renames, key=lambda r: -len(r[0])):
            if name == old or name.startswith((f"{old}.", f"{old}[")):
                name = new + name[len(old):]
                break
        for old, new in renames:  # "duplicate id (also at goal.poses[0])"
            if "[" not in old:
                reason = reason.replace(f"{old}[", f"{new}[")
        full = f"{prefix}.{name}" if prefix and name else (prefix or name)
        raise MessageError(full, err.value, reason) from None


def join_path(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


def float_at(where: str, value: Any) -> float:
    return finite_float(where, value)


def int_at(where: str, value: Any, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise MessageError(where, value, "expected an integer")
    if not lo <= value <= hi:
        raise MessageError(where, value, f"must lie in [{lo}, {hi}]")
    return int(value)


def text_at(where: str, value: Any) -> str:
    """A ROS string: UTF-8 and a C string on the wire (a NUL would cut it short)."""
    if not isinstance(value, str):
        raise MessageError(where, value, "expected a string")
    if "\x00" in value:
        raise MessageError(where, value, "a ROS string cannot hold a NUL character")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise MessageError(where, value, "a ROS string is UTF-8 (no lone surrogates)") from None
    return value


def block_id_at(where: str, value: Any) -> int:
    return int_at(where, value, 0, INT32_MAX)


def optional_block_to(where: str, block: int | None) -> int:
    return NO_BLOCK if block is None else block_id_at(where, block)


def optional_block_from(where: str, value: int) -> int | None:
    if value == NO_BLOCK:
        return None
    return block_id_at(where, value)


def code_to(where: str, table: dict[str, int], name: str) -> int:
    if name not in table:
        raise MessageError(where, name, f"expected one of {list(table)}")
    return table[name]


def code_from(where: str, table: dict[str, int], code: int) -> str:
    for name, value in table.items():
        if value == code:
            return name
    raise MessageError(where, code, f"unknown constant; expected one of {table}")


def check_unique(where: str, key: str, values: Sequence[Any]) -> None:
    seen: dict[Any, int] = {}
    for k, value in enumerate(values):
        if value in seen:
            raise MessageError(f"{where}[{k}].{key}" if key else f"{where}[{k}]", value,
                               f"duplicate (also at {where}[{seen[value]}])")
        seen[value] = k


def check_version(where: str, version: int) -> None:
    if version != SCHEMA_VERSION:
        raise MessageError(where, version, f"only schema v{SCHEMA_VERSION} has a message form")


# --- frames ---------------------------------------------------------------------------------------
def check_world_frame(where: str, frame_id: str) -> None:
    if frame_id not in (WORLD, ""):
        raise MessageError(where, frame_id, f"scenes and goal layouts are in '{WORLD}'")


def set_world_header(msg: Any, stamp_ns: int) -> None:
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.header.frame_id = WORLD

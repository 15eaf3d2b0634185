"""Generic ROS message introspection: type names to classes, messages to plain dicts."""

from __future__ import annotations

import array
import importlib
from typing import Any

import numpy as np

#: Sequences longer than this print as a summary unless the caller asks for everything.
DEFAULT_ARRAY_LIMIT = 32


def canonical_type_name(type_name: str) -> str:
    """``std_msgs/String`` -> ``std_msgs/msg/String``; full names pass through.

    Raises:
        ValueError: the name is not of the form pkg/Type or pkg/msg/Type.
    """
    parts = type_name.split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    if len(parts) != 3 or not all(parts):
        raise ValueError(f"bad message type name '{type_name}' (expected pkg/msg/Type)")
    return "/".join(parts)


def import_message_type(type_name: str) -> type:
    """``"std_msgs/msg/String"`` (or ``std_msgs/String``) -> the message class.

    Raises:
        ValueError: the name is malformed or its package/class cannot be imported.
    """
    package, kind, name = canonical_type_name(type_name).split("/")
    try:
        module = importlib.import_module(f"{package}.{kind}")
        return getattr(module, name)
    except (ImportError, AttributeError) as err:
        raise ValueError(f"cannot import message type '{type_name}': {err}") from None


def message_to_dict(msg: Any, array_limit: int | None = DEFAULT_ARRAY_LIMIT) -> Any:
    """A ROS message as nested dicts/lists of plain Python values, in field order."""
    if hasattr(msg, "get_fields_and_field_types"):
        return {
            name: message_to_dict(getattr(msg, name), array_limit)
            for name in msg.get_fields_and_field_types()
        }
    if isinstance(msg, bytes | bytearray):
        return _sequence([int(b) for b in msg], array_limit)
    if isinstance(msg, array.array | np.ndarray | list | tuple):
        items = msg.tolist() if not isinstance(msg, list | tuple) else list(msg)
        if array_limit is not None and len(items) > array_limit:
            return f"<sequence of {len(items)} values>"
        return [message_to_dict(v, array_limit) for v in items]
    if isinstance(msg, np.generic):
        return msg.item()
    return msg


def _sequence(items: list[int], array_limit: int | None) -> Any:
    if array_limit is not None and len(items) > array_limit:
        return f"<sequence of {len(items)} values>"
    return items

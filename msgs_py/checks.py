"""Small field checks shared by every decoder: strict keys, finite numbers, integer ids.

Decoders call these on raw dicts (parsed YAML/JSON) before building a dataclass, so that
nothing is half-built when a field is wrong.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from msgs_py.errors import MessageError


def require_mapping(field: str, value: Any) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise MessageError(field, value, "expected a mapping")
    return value


def require_list(field: str, value: Any) -> list[Any]:
    if not isinstance(value, list | tuple):
        raise MessageError(field, value, "expected a list")
    return list(value)


def check_keys(
    field: str,
    data: Mapping[str, Any],
    required: Iterable[str],
    optional: Iterable[str] = (),
) -> None:
    """Reject unknown fields and report the first missing one."""
    required = tuple(required)
    allowed = set(required) | set(optional)
    for key in data:
        if key not in allowed:
            where = f"{field}.{key}" if field else str(key)
            raise MessageError(where, data[key], f"unknown field; allowed: {sorted(allowed)}")
    for key in required:
        if key not in data:
            where = f"{field}.{key}" if field else key
            raise MessageError(where, None, "missing required field")


def finite_float(field: str, value: Any) -> float:
    """A real number that is neither NaN nor infinite (bools are refused)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise MessageError(field, value, "expected a number")
    number = float(value)
    if not math.isfinite(number):
        raise MessageError(field, value, "must be a finite number (NaN and inf are refused)")
    return number


def positive_float(field: str, value: Any) -> float:
    number = finite_float(field, value)
    if number <= 0.0:
        raise MessageError(field, value, "must be > 0")
    return number


def non_negative_float(field: str, value: Any) -> float:
    number = finite_float(field, value)
    if number < 0.0:
        raise MessageError(field, value, "must be >= 0")
    return number


def integer(field: str, value: Any, minimum: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise MessageError(field, value, "expected an integer")
    if minimum is not None and value < minimum:
        raise MessageError(field, value, f"must be >= {minimum}")
    return int(value)


def boolean(field: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise MessageError(field, value, "expected true or false")
    return value


def text(field: str, value: Any) -> str:
    if not isinstance(value, str):
        raise MessageError(field, value, "expected a string")
    return value


def reject_duplicates(field: str, key: str, values: list[int]) -> None:
    """MessageError naming the second of two equal ``key`` values in ``field``."""
    seen: dict[int, int] = {}
    for k, value in enumerate(values):
        if value in seen:
            raise MessageError(
                f"{field}[{k}].{key}", value, f"duplicate {key} (also at {field}[{seen[value]}])"
            )
        seen[value] = k

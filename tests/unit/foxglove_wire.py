"""Foxglove messages read back as the app reads them: the SDK encodes its protobuf messages
but does not decode them, so this decodes the wire format by the field names and types of
the schema (a protobuf ``FileDescriptorSet``) that the SDK ships with each message type. A
test then asserts on what the app receives (frame ids, poses, texts), not on our own inputs.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from typing import Any

VARINT, FIXED64, LENGTH, FIXED32 = 0, 1, 2, 5
REPEATED = 3  # FieldDescriptorProto.label
DOUBLE, FLOAT, BOOL, STRING, MESSAGE, BYTES = 1, 2, 8, 9, 11, 12  # FieldDescriptorProto.type
SCALAR_DEFAULTS = {DOUBLE: 0.0, FLOAT: 0.0, BOOL: False, STRING: "", BYTES: b""}


def _varint(data: bytes, pos: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        byte = data[pos]
        value |= (byte & 0x7F) << shift
        pos, shift = pos + 1, shift + 7
        if byte < 0x80:
            return value, pos


def wire_fields(data: bytes) -> Iterator[tuple[int, int, Any]]:
    """(field number, wire type, raw value) of each field in ``data``, in order."""
    pos = 0
    while pos < len(data):
        key, pos = _varint(data, pos)
        number, wire = key >> 3, key & 7
        if wire == VARINT:
            value, pos = _varint(data, pos)
        elif wire == FIXED64:
            value, pos = data[pos:pos + 8], pos + 8
        elif wire == FIXED32:
            value, pos = data[pos:pos + 4], pos + 4
        elif wire == LENGTH:
            size, pos = _varint(data, pos)
            value, pos = data[pos:pos + size], pos + size
        else:
            raise ValueError(f"wire type {wire} of field {number} is not handled")
        yield number, wire, value


def _first(data: bytes, number: int, default: Any = None) -> Any:
    return next((v for n, _, v in wire_fields(data) if n == number), default)


def message_fields(schema_data: bytes) -> dict[str, dict[int, tuple[str, int, int, str]]]:
    """Full message name (``foxglove.Pose``) -> field number -> (name, label, type,
    type name), from a ``FileDescriptorSet``."""
    found: dict[str, dict[int, tuple[str, int, int, str]]] = {}

    def add(descriptor: bytes, prefix: str) -> None:
        name = f"{prefix}.{_first(descriptor, 1).decode()}"
        fields: dict[int, tuple[str, int, int, str]] = {}
        for number, _, value in wire_fields(descriptor):
            if number == 2:  # DescriptorProto.field
                fields[_first(value, 3, 0)] = (_first(value, 1).decode(), _first(value, 4, 1),
                                              _first(value, 5, 0), _first(value, 6, b"").decode())
            elif number == 3:  # nested_type
                add(value, name)
        found[name] = fields

    for number, _, file in wire_fields(schema_data):
        if number == 1:  # FileDescriptorSet.file
            package = _first(file, 2, b"").decode()
            for field_number, _, message in wire_fields(file):
                if field_number == 4:  # FileDescriptorProto.message_type
                    add(message, package)
    return found


def _scalar(kind: int, wire: int, raw: Any) -> Any:
    if kind == DOUBLE:
        return struct.unpack("<d", raw)[0]
    if kind == FLOAT:
        return struct.unpack("<f", raw)[0]
    if kind == STRING:
        return raw.decode()
    if kind == BOOL:
        return bool(raw)
    return raw


def decode(message_type: Any, data: bytes) -> dict[str, Any]:
    """``data`` (an SDK message's ``encode()``) as nested dicts by field name; fields left out
    on the wire get proto3's defaults (0, "", [], None for a message)."""
    schema = message_type.get_schema()
    return _decode(message_fields(schema.data), schema.name, data)


def _decode(types: dict, name: str, data: bytes) -> dict[str, Any]:
    fields = types[name]
    out: dict[str, Any] = {}
    for fname, label, kind, _ in fields.values():
        out[fname] = [] if label == REPEATED else SCALAR_DEFAULTS.get(kind, 0 if kind != MESSAGE
                                                                       else None)
    for number, wire, raw in wire_fields(data):
        if number not in fields:
            continue
        fname, label, kind, type_name = fields[number]
        if kind == MESSAGE:
            value = _decode(types, type_name.lstrip("."), raw)
        elif wire == LENGTH and kind in (DOUBLE, FLOAT):  # a packed repeated number
            size = 8 if kind == DOUBLE else 4
            out[fname] += [_scalar(kind, FIXED64, raw[k:k + size])
                           for k in range(0, len(raw), size)]
            continue
        else:
            value = _scalar(kind, wire, raw)
        if label == REPEATED:
            out[fname].append(value)
        else:
            out[fname] = value
    return out

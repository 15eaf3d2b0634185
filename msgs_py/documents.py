"""Reading and writing versioned YAML/JSON documents (scene files, goal layouts, plans).

Text is parsed as JSON when it looks like JSON and as YAML otherwise (YAML is a superset
of JSON, but JSON's parser gives better messages for JSON). Output is deterministic.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml

from msgs_py.actions import Plan
from msgs_py.errors import MessageError
from msgs_py.scene import Scene


def parse_text(text: str, source: str = "document") -> Any:
    """Parse YAML or JSON text; a syntax error becomes a ``MessageError`` naming ``source``."""
    stripped = text.lstrip()
    if not stripped:
        raise MessageError(source, text, "empty document")
    try:
        if stripped[0] in "{[":
            return json.loads(text)
        return yaml.safe_load(text)
    except (json.JSONDecodeError, yaml.YAMLError) as err:
        raise MessageError(source, text[:80], f"not valid YAML/JSON: {err}") from None


def dump_json(data: Any, indent: int | None = None) -> str:
    """JSON that refuses NaN/inf rather than writing non-standard tokens."""
    try:
        return json.dumps(data, indent=indent, allow_nan=False, sort_keys=False)
    except ValueError as err:
        raise MessageError("document", "NaN/inf", f"cannot be written as JSON: {err}") from None


def dump_yaml(data: Any) -> str:
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=None)


def _read(path: str | Path) -> Any:
    path = Path(path)
    try:
        content = path.read_text(encoding="utf-8")
    except OSError as err:
        raise MessageError(str(path), None, f"cannot read file: {err.strerror}") from None
    return parse_text(content, str(path))


def _write(data: dict[str, Any], path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".json":
        path.write_text(dump_json(data, indent=2) + "\n", encoding="utf-8")
    else:
        path.write_text(dump_yaml(data), encoding="utf-8")
    return path


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene (or goal layout) file, YAML or JSON."""
    return Scene.from_dict(_read(path))


def save_scene(scene: Scene, path: str | Path) -> Path:
    return _write(scene.to_dict(), path)


def load_plan(path: str | Path) -> Plan:
    return Plan.from_dict(_read(path))


def save_plan(plan: Plan, path: str | Path) -> Path:
    return _write(plan.to_dict(), path)

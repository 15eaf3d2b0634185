"""Node parameters declared from frozen dataclasses: YAML -> declared parameters -> config.

A config dataclass lists each parameter once, with its default, unit and description::

    @dataclass(frozen=True)
    class PlannerConfig:
        a1: float = param(1.0, "cost of a pick-and-place action")
        budget_s: float = param(30.0, "planning time budget", unit="s")

``declare_config(node, PlannerConfig)`` declares every field on the node (so
``--ros-args -p a1:=2.0`` and ``--params-file`` work and ``ros2 param describe`` shows the
description), reads the values back, coerces them to the field's type and builds the
dataclass, whose ``__post_init__`` runs the cross-field checks. ``describe_config`` renders
the same information for ``--help`` and the README.

Outside a node (the offline CLIs, benchmarks, tests) ``read_params_file`` reads the same
``--params-file`` YAML and ``configs_from_parameters`` builds the same dataclasses from it,
refusing names that no config declares, so a typo in a parameter file is an error there too.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import MISSING, dataclass, fields
from pathlib import Path
from typing import Any, TypeVar

import yaml
from rcl_interfaces.msg import ParameterDescriptor

C = TypeVar("C")

#: Parameters every ROS node has: a parameter file may give them to any node.
ROS_NODE_PARAMETERS = ("use_sim_time",)


@dataclass(frozen=True, slots=True)
class ParamMeta:
    description: str
    unit: str = ""
    name: str | None = None
    read_only: bool = False


def param(
    default: Any,
    description: str,
    *,
    unit: str = "",
    name: str | None = None,
    read_only: bool = False,
) -> Any:
    """A dataclass field that is also a ROS parameter (``name`` defaults to the field name).

    Sequence defaults are stored as tuples so the config stays immutable.
    """
    if isinstance(default, list):
        default = tuple(default)
    return dataclasses.field(
        default=default, metadata={"ros": ParamMeta(description, unit, name, read_only)}
    )


def _param_fields(cls: type) -> list[tuple[dataclasses.Field, ParamMeta]]:
    out = []
    for f in fields(cls):
        meta = f.metadata.get("ros")
        if meta is not None:
            out.append((f, meta))
    return out


def parameter_name(f: dataclasses.Field, meta: ParamMeta, prefix: str = "") -> str:
    return prefix + (meta.name or f.name)


def _to_ros(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


def _coerce(name: str, value: Any, default: Any) -> Any:
    """Convert a parameter value to the type of its default, or explain why not."""
    if isinstance(default, bool):
        if isinstance(value, bool):
            return value
    elif isinstance(default, int):
        if isinstance(value, int) and not isinstance(value, bool):
            return value
    elif isinstance(default, float):
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
    elif isinstance(default, str):
        if isinstance(value, str):
            return value
    elif isinstance(default, tuple):
        if isinstance(value, list | tuple):
            items = tuple(value)
            if default and isinstance(default[0], float):
                if all(isinstance(v, int | float) and not isinstance(v, bool) for v in items):
                    return tuple(float(v) for v in items)
            else:
                return items
    else:
        return value
    raise ValueError(
        f"parameter '{name}': expected {type(default).__name__} like {default!r}, got {value!r}"
    )


def declare_config(node: Any, cls: type[C], prefix: str = "") -> C:
    """Declare ``cls``'s fields as parameters of ``node`` and return the filled config.

    Raises:
        ValueError: a value of the wrong type or one the config's own checks refuse; the
            message names the parameter.
    """

    values: dict[str, Any] = {}
    for f, meta, name, default in _named_fields(cls, prefix):
        description = meta.description + (f" [{meta.unit}]" if meta.unit else "")
        descriptor = ParameterDescriptor(
            description=description, read_only=meta.read_only, dynamic_typing=True
        )
        node.declare_parameter(name, _to_ros(default), descriptor)
        values[f.name] = _coerce(name, node.get_parameter(name).value, default)
    return cls(**values)


def current_config(node: Any, cls: type[C], prefix: str = "") -> C:
    """``cls`` built from the current values of ``node``'s parameters, as ``declare_config``
    declared them (a parameter set since, e.g. through the node's ``set_parameters``
    service, counts with its new value).

    Raises:
        ValueError: a value of the wrong type or one the config's own checks refuse; the
            message names the parameter.
    """
    return cls(**{f.name: _coerce(name, node.get_parameter(name).value, default)
                  for f, _, name, default in _named_fields(cls, prefix)})


def _named_fields(cls: type, prefix: str):
    """(field, its param metadata, parameter name, default) of each of ``cls``'s fields."""
    for f, meta in _param_fields(cls):
        default = f.default if f.default is not MISSING else f.default_factory()  # type: ignore[misc]
        yield f, meta, parameter_name(f, meta, prefix), default


def describe_config(cls: type, prefix: str = "") -> list[dict[str, str]]:
    """Rows of (name, type, default, unit, description) for help texts and docs."""
    rows = []
    for f, meta in _param_fields(cls):
        default = f.default if f.default is not MISSING else f.default_factory()  # type: ignore[misc]
        rows.append(
            {
                "name": parameter_name(f, meta, prefix),
                "type": type(default).__name__ if not isinstance(default, tuple) else "list",
                "default": repr(_to_ros(default)),
                "unit": meta.unit,
                "description": meta.description,
            }
        )
    return rows


def config_overrides(config: Any, prefix: str = "") -> dict[str, Any]:
    """The parameter values of a config instance, by parameter name (for launching nodes)."""
    return {
        parameter_name(f, meta, prefix): _to_ros(getattr(config, f.name))
        for f, meta in _param_fields(type(config))
    }


def read_params_file(path: str | Path, node_name: str | None = None) -> dict[str, Any]:
    """The parameters a ROS ``--params-file`` YAML gives a node, nested keys joined by dots.

    ``camera: {fx: ...}`` and ``camera.fx: ...`` mean the same to ROS; both come back as
    ``{"camera.fx": ...}``. The ``/**`` section applies to every node, a section named after
    the node (``sim`` or ``/sim``) to that node only; ``node_name=None`` merges every section.

    Raises:
        OSError: the file cannot be read.
        ValueError: the file is not a parameter file (names the file and what is wrong).
    """

    data = yaml.safe_load(Path(path).read_text())
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ValueError(f"{path}: not a ROS parameter file (expected '/**: ros__parameters:')")
    values: dict[str, Any] = {}
    for section, body in data.items():
        if node_name is not None and str(section).lstrip("/") not in ("**", node_name):
            continue
        params = body.get("ros__parameters") if isinstance(body, dict) else None
        if not isinstance(params, dict):
            raise ValueError(f"{path}: section '{section}' has no 'ros__parameters' mapping")
        values.update(_flatten(params))
    return values


def _flatten(tree: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(_flatten(value, name + "."))
        else:
            out[name] = value
    return out


def configs_from_parameters(
    configs: Sequence[tuple[str, type]], values: Mapping[str, Any], source: str = "parameters"
) -> list[Any]:
    """One config per ``(prefix, cls)`` from parameter ``values`` (names as in a params file),
    coerced like ``declare_config``; a field not in ``values`` keeps its default.

    Raises:
        ValueError: a name no config declares (a typo, a parameter of another node), a value
            of the wrong type, or one the config's own checks refuse; ``source`` and the
            parameter are named.
    """
    claimed: set[str] = set(ROS_NODE_PARAMETERS)
    built = []
    for prefix, cls in configs:
        kwargs: dict[str, Any] = {}
        for f, meta in _param_fields(cls):
            name = parameter_name(f, meta, prefix)
            claimed.add(name)
            if name in values:
                default = f.default if f.default is not MISSING else f.default_factory()  # type: ignore[misc]
                kwargs[f.name] = _coerce(name, values[name], default)
        built.append(kwargs)
    unknown = sorted(set(values) - claimed)
    if unknown:
        raise ValueError(f"{source}: unknown parameter(s) {unknown}")
    out = []
    for (_, cls), kwargs in zip(configs, built, strict=True):
        try:
            out.append(cls(**kwargs))
        except ValueError as err:
            raise ValueError(f"{source}: {err}") from None
    return out

"""The two long requests of the cell: plan a scene, and rearrange the blocks into a layout.

Dataclass halves of ``densepack_interfaces/srv/PlanScene`` (``PlanRequest``, ``PlanReply``)
and ``densepack_interfaces/action/Rearrange`` (goal: a goal layout, i.e. a ``Scene`` without
blocks; ``RearrangeFeedback``; ``RearrangeResult`` with one ``BlockError`` per block). Like the
rest of msgs_py they validate themselves on construction and import no ROS package; the
codecs are in ``msgs_py.ros``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from msgs_py.actions import Plan
from msgs_py.checks import finite_float
from msgs_py.errors import MessageError
from msgs_py.scene import Scene
from msgs_py.status import EXECUTOR_STATES

#: Why a PlanScene request failed (``none`` when it succeeded).
PLAN_ERRORS = (
    "none",
    "invalid_scene",  # the scene breaks a rule: overlap, outside the workspace, unknown id, ...
    "invalid_parameter",  # an override is unknown, mistyped or out of range
    "no_plan",  # a well-formed scene the planner found no plan for
    "busy",  # the planner is planning and refuses a second request
)

#: How a Rearrange goal ended.
REARRANGE_OUTCOMES = (
    "succeeded",  # every block verified at its goal
    "failed",  # gave up: detail says why
    "canceled",  # stopped safely on a cancel request
    "preempted",  # stopped safely because a newer goal replaced this one
)


def check_params(where: str, params: dict[str, Any]) -> None:
    """Parameter values as a ROS parameter holds them: a scalar or a flat list of one type."""
    for name, value in params.items():
        if not isinstance(name, str) or not name:
            raise MessageError(where, name, "parameter names are non-empty strings")
        _check_param_value(f"{where}.{name}", value)


def _check_param_value(where: str, value: Any) -> None:
    if value is None or isinstance(value, bool | str):
        return
    if isinstance(value, int | float):
        finite_float(where, value)
        return
    if not isinstance(value, list | tuple):
        raise MessageError(where, value, "expected a bool, int, float, str or a list of one")
    kinds = {_scalar_kind(f"{where}[{k}]", item) for k, item in enumerate(value)}
    if len(kinds) > 1:
        raise MessageError(where, list(value), "a list parameter holds items of one type")


def _scalar_kind(where: str, value: Any) -> type:
    if isinstance(value, bool | str):
        return type(value)
    if isinstance(value, int | float):
        finite_float(where, value)
        return type(value)
    raise MessageError(where, value, "list items are bools, ints, floats or strs")


def _optional_block(where: str, block: int | None) -> None:
    if block is not None and (isinstance(block, bool) or not isinstance(block, int) or block < 0):
        raise MessageError(where, block, "a block id is an integer >= 0 (or None)")


def _count(where: str, value: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise MessageError(where, value, "expected an integer >= 0")


@dataclass(frozen=True, slots=True)
class PlanRequest:
    """Plan ``scene`` (it must have a goal); ``overrides`` replace planner parameters once."""

    scene: Scene
    overrides: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.scene.goal is None:
            raise MessageError("scene.has_goal", False, "a scene to plan needs a goal")
        check_params("overrides", self.overrides)


@dataclass(frozen=True, slots=True)
class PlanReply:
    """A validated ``plan``, or a failure: ``error`` (PLAN_ERRORS), block, field and reason."""

    success: bool
    plan: Plan | None = None
    error: str = "none"
    failed_block: int | None = None
    failed_field: str = ""
    message: str = ""

    def __post_init__(self) -> None:
        if self.error not in PLAN_ERRORS:
            raise MessageError("error", self.error, f"expected one of {list(PLAN_ERRORS)}")
        if self.success and (self.plan is None or self.error != "none"):
            raise MessageError("success", True, "a success carries a plan and error 'none'")
        if not self.success and (self.plan is not None or self.error == "none"):
            raise MessageError("success", False, "a failure carries no plan and names an error")
        _optional_block("failed_block", self.failed_block)

    @classmethod
    def planned(cls, plan: Plan, message: str = "") -> PlanReply:
        return cls(True, plan, message=message)

    @classmethod
    def refused(cls, error: str, message: str, failed_block: int | None = None,
                failed_field: str = "") -> PlanReply:
        return cls(False, None, error, failed_block, failed_field, message)


@dataclass(frozen=True, slots=True)
class RearrangeFeedback:
    """Progress of a Rearrange goal: executor ``state``, action k of n, corrections so far."""

    state: str
    action_index: int = 0
    action_total: int = 0
    block: int | None = None
    corrections: int = 0
    detail: str = ""

    def __post_init__(self) -> None:
        if self.state not in EXECUTOR_STATES:
            raise MessageError("state", self.state, f"expected one of {list(EXECUTOR_STATES)}")
        _count("action_index", self.action_index)
        _count("action_total", self.action_total)
        _count("corrections", self.corrections)
        _optional_block("block", self.block)


@dataclass(frozen=True, slots=True)
class BlockError:
    """How far block ``block_id`` ended from its goal slot: metres and radians (not degrees).

    The yaw error is taken modulo 90 degrees unless the goal is ``yaw_exact``. ``found`` is
    False for a block missing from the final detection; both errors are then 0.
    """

    block_id: int
    position_error_m: float
    yaw_error_rad: float
    found: bool = True

    def __post_init__(self) -> None:
        _optional_block("block_id", self.block_id)
        for name in ("position_error_m", "yaw_error_rad"):
            value = finite_float(name, getattr(self, name))
            if value < 0.0:
                raise MessageError(name, value, "must be >= 0")
            if not self.found and value != 0.0:
                raise MessageError(name, value, "a block not found has no error (0)")
        if self.yaw_error_rad > math.pi:
            raise MessageError("yaw_error_rad", self.yaw_error_rad, "an absolute yaw error <= pi")


@dataclass(frozen=True, slots=True)
class RearrangeResult:
    """How a Rearrange goal ended, with the final error of every block the goal constrains."""

    outcome: str
    detail: str = ""
    block_errors: tuple[BlockError, ...] = ()
    metrics: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "block_errors", tuple(self.block_errors))
        if self.outcome not in REARRANGE_OUTCOMES:
            raise MessageError("outcome", self.outcome,
                               f"expected one of {list(REARRANGE_OUTCOMES)}")
        seen: dict[int, int] = {}
        for k, err in enumerate(self.block_errors):
            if err.block_id in seen:
                raise MessageError(f"block_errors[{k}].block_id", err.block_id,
                                   f"duplicate (also at block_errors[{seen[err.block_id]}])")
            seen[err.block_id] = k
        for name, value in self.metrics.items():
            finite_float(f"metrics.{name}", value)

"""Progress reports: the planner's, the executor's and the gripper's.

The planner's and the executor's are flat records: a ``state`` from a fixed vocabulary,
counters, the last error in words and a ``metrics`` dict of figures (seconds, counts) for
dashboards and reports. The gripper's is what a 2F-85 driver reports; it and the arm's also
say who holds the device's lease and which commanders it refused (``nodes.common.lease``).
The codecs to ``densepack_interfaces`` are in ``msgs_py.ros.status``.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from msgs_py.checks import finite_float
from msgs_py.errors import MessageError
from msgs_py.scene import SCHEMA_VERSION


class ExecutorState(enum.StrEnum):
    """What the executor is doing: the one list of its states. The executor's core switches
    on it, its goal handling and the codecs use it, and the README's state table is printed
    from the executor's table of the changes between them. A ``str`` enum: the value is the
    word ``/executor/status`` carries, and a member equals its word."""

    IDLE = "idle"  #: no plan yet, or parked until one and a start
    RUNNING = "running"  #: streaming an action
    OBSERVING = "observing"  #: arm out of the camera's view, waiting for a fresh detection
    RECOVERING = "recovering"  #: handling a fault: setting a block down, bringing one back
    REPLANNING = "replanning"  #: asked the planner for a new plan from the perceived state
    STOPPING = "stopping"  #: lifting and parking after a stop request or an error
    STOPPED = "stopped"  #: parked after /executor/stop; /executor/start resumes
    DONE = "done"  #: plan finished and every block verified at its goal
    FAILED = "failed"  #: gave up; last_error says why


#: The executor states' words, in ``ExecutorState``'s order.
EXECUTOR_STATES = tuple(state.value for state in ExecutorState)

#: The gripper's object detection (the 2F-85's gOBJ), in the order of its codes 0-3.
GRIPPER_OBJECT_STATES = (
    "moving",  # fingers moving towards the requested gap, nothing detected
    "stopped_opening",  # stopped on an object while opening
    "stopped_closing",  # stopped on an object while closing: something is held
    "at_position",  # reached the requested gap: no object
)

#: The executor's view of the arm: it moves, or it stopped (and why). The executor node makes
#: it from the arm node's ``ArmStatus``.
SAFETY_MODES = (
    "normal",
    "protective_stop",  # the arm holds where it stopped until it can move again
)

#: What the arm node says of the arm (``nodes.arm.readiness`` says when each holds).
ARM_STATES = (
    "ready",  # setpoints are followed
    "paused",  # the speed slider is at 0: setpoints are taken, the arm waits on its path
    "protective_stop",  # stopped by the robot's safety system until unlocked
    "stopped",  # cannot move until someone acts (program, safeguard, e-stop, power)
    "no_joint_states",  # joint states missing, incomplete or stale
)

PLANNER_STATES = (
    "waiting",  # missing a goal or a detection
    "planning",
    "planned",  # a validated plan was published
    "failed",  # no plan: last_error names the block and the reason
)


@dataclass(frozen=True, slots=True)
class ExecutorStatus:
    """What the executor is doing: action ``action_index`` (1-based) of ``action_total``.
    ``state`` may be given as its word; it is kept as the ``ExecutorState``."""

    state: ExecutorState
    plan_id: str = ""
    action_index: int = 0
    action_total: int = 0
    block: int | None = None
    last_error: str = ""
    detail: str = ""
    metrics: dict[str, float] = field(default_factory=dict)
    version: int = SCHEMA_VERSION

    def __post_init__(self) -> None:
        if not isinstance(self.state, ExecutorState):
            if self.state not in EXECUTOR_STATES:
                raise MessageError("state", self.state,
                                   f"expected one of {list(EXECUTOR_STATES)}")
            object.__setattr__(self, "state", ExecutorState(self.state))


@dataclass(frozen=True, slots=True)
class PlannerStatus:
    """What the planner did last: ``failed`` carries the block and reason in ``last_error``."""

    state: str
    plan_id: str = ""
    n_actions: int = 0
    planning_time_s: float = 0.0
    last_error: str = ""
    failed_block: int | None = None
    metrics: dict[str, float] = field(default_factory=dict)
    version: int = SCHEMA_VERSION

    def __post_init__(self) -> None:
        if self.state not in PLANNER_STATES:
            raise MessageError("state", self.state, f"expected one of {list(PLANNER_STATES)}")

    @property
    def wants_detection(self) -> bool:
        """The planner waits for a (new) detection: none yet, or one that shows every block
        (its reasons name the detection; a fresh camera frame is what it needs)."""
        return self.state == "waiting" and "detection" in self.last_error


def check_lease_fields(refused: int, commanders: tuple[str, ...]) -> None:
    """The lease part of the arm's and the gripper's status (``nodes.common.lease``)."""
    if isinstance(refused, bool) or not isinstance(refused, int) or refused < 0:
        raise MessageError("refused_commands", refused, "expected a count (an integer >= 0)")
    if not isinstance(commanders, tuple) or not all(isinstance(c, str) for c in commanders):
        raise MessageError("refused_commanders", commanders, "expected a tuple of node names")


@dataclass(frozen=True, slots=True)
class GripperStatus:
    """What the gripper reports at ``stamp_ns``: measured and requested gap between the pads
    (m) and the object detection (``GRIPPER_OBJECT_STATES``)."""

    gap: float
    requested_gap: float
    object: str
    stamp_ns: int = 0
    lease_holder: str = ""  #: the node that holds the fingers ("": /gripper/command does)
    refused_commands: int = 0  #: /gripper/command messages refused while another held them
    refused_commanders: tuple[str, ...] = ()  #: the nodes named for them, most recent first

    def __post_init__(self) -> None:
        finite_float("gap", self.gap)
        finite_float("requested_gap", self.requested_gap)
        if self.object not in GRIPPER_OBJECT_STATES:
            raise MessageError("object", self.object,
                               f"expected one of {list(GRIPPER_OBJECT_STATES)}")
        check_lease_fields(self.refused_commands, self.refused_commanders)

    @property
    def holds_object(self) -> bool:
        return self.object == "stopped_closing"


@dataclass(frozen=True, slots=True)
class ArmStatus:
    """What the arm node says of the arm at ``stamp_ns`` (``ARM_STATES``), and why."""

    state: str
    reason: str = ""
    speed_scaling: float = 1.0  #: the speed slider (fraction)
    program_running: bool = False
    safety_mode: int = 0  #: ur_dashboard_msgs/SafetyMode code, 0: none yet
    robot_mode: int = -128  #: ur_dashboard_msgs/RobotMode code, -128: none yet
    stream_time: float | None = None  #: stamp (s) of the stream the arm is commanded at
    rejected_setpoints: int = 0
    stamp_ns: int = 0
    lease_holder: str = ""  #: the node that holds the arm ("": /arm/cartesian_setpoint does)
    refused_commands: int = 0  #: setpoints refused on the public topic while another held it
    refused_commanders: tuple[str, ...] = ()  #: the nodes named for them, most recent first

    def __post_init__(self) -> None:
        if self.state not in ARM_STATES:
            raise MessageError("state", self.state, f"expected one of {list(ARM_STATES)}")
        finite_float("speed_scaling", self.speed_scaling)
        check_lease_fields(self.refused_commands, self.refused_commanders)

    @property
    def ready(self) -> bool:
        return self.state == "ready"

    @property
    def protective_stop(self) -> bool:
        return self.state == "protective_stop"


@dataclass(frozen=True, slots=True)
class SafetyMode:
    """The arm's safety mode (``SAFETY_MODES``) since ``stamp_ns``, and why it stopped."""

    mode: str
    reason: str = ""
    stamp_ns: int = 0

    def __post_init__(self) -> None:
        if self.mode not in SAFETY_MODES:
            raise MessageError("mode", self.mode, f"expected one of {list(SAFETY_MODES)}")

    @property
    def stopped(self) -> bool:
        return self.mode == "protective_stop"

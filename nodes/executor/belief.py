"""What the executor believes: the plan and where it stands in it, the blocks as expected and
as last perceived, and what the fingers hold.

The handlers read and update it; nothing here moves the arm or talks to the node.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from msgs_py import Plan, Pose2D, Scene, Workspace
from msgs_py.actions import Action, Push
from msgs_py.cell import GripperGeometry, table_margin_of
from nodes.executor.primitives import GRASP_SYMMETRY
from nodes.executor.states import Held
from nodes.executor.verify import Deviation, goal_errors


@dataclass
class Belief:
    """The plan (with the camera check's entries in front once added), the next action's
    ``index``, the blocks where they should be (``expected``) and where the camera last saw
    them (``perceived``), the block in the fingers and where the current action picked its
    block up."""

    plan: Plan | None = None
    geo: GripperGeometry = field(default_factory=GripperGeometry)
    index: int = 0  #: the next action to run (0-based)
    probes: int = 0  #: the plan's first actions that are the camera check's re-grips
    expected: dict[int, Pose2D] = field(default_factory=dict)
    perceived: dict[int, Pose2D] = field(default_factory=dict)
    held: Held | None = None
    picked_from: Pose2D | None = None  #: where the current action's block stood
    #: the block a recovery's script picks up (brought in, set apart): the status names it
    #: from the script's start, before the fingers close on it (a set-down names ``held``)
    handling: int | None = None
    camera_checked: bool = False  #: the start-of-run camera check was made (once a lifetime)
    #: blocks near where an action acted since the camera last saw them uncovered: what the
    #: camera says of them now may be out of date
    unverified: set[int] = field(default_factory=set)
    #: blocks a recovery picked up and set down elsewhere (set apart, brought in, set down
    #: from the fingers) since the plan was adopted
    moved_aside: set[int] = field(default_factory=set)

    def adopt(self, plan: Plan) -> None:
        """Take ``plan``, from its first action; its params give the gripper's geometry."""
        self.plan = plan
        self.geo = GripperGeometry.from_params(plan.params)
        self.index = 0
        self.probes = 0
        self.moved_aside = set()

    def stranded(self) -> dict[int, str]:
        """Blocks a recovery moved that the plan cannot take on from where they stand, and
        why: the plan moves them no more (it would leave them where the recovery put them,
        off their goal and maybe on a slot still to fill: the nudge fault, seed 7), or their
        next action is a push (it runs along the plan's line, so a block set apart beside
        its start ends beside its goal: the 200-goal soak's goal 116, 13 mm off and walled
        in by its neighbours). A next pick takes the block where it is seen."""
        if self.plan is None:
            return {}
        nxt: dict[int, Action] = {}
        for action in self.plan.actions[self.index:]:
            nxt.setdefault(action.block, action)
        why = {}
        for block in sorted(self.moved_aside):
            action = nxt.get(block)
            if action is None:
                why[block] = "after its last action in the plan"
            elif isinstance(action, Push):
                why[block] = "off the start of its next push"
        return why

    @property
    def scene(self) -> Scene | None:
        return self.plan.scene if self.plan is not None else None

    @property
    def current(self) -> Action | None:
        """The action to run next (or running), None past the plan's end."""
        if self.plan is None or self.index >= len(self.plan.actions):
            return None
        return self.plan.actions[self.index]

    @property
    def checking_camera(self) -> bool:
        """The current action is one of the camera check's re-grips."""
        return self.index < self.probes

    def table(self) -> Workspace:
        """The table the fingers may stand on: the workspace and the plan's margin."""
        assert self.plan is not None and self.plan.scene is not None
        return self.plan.scene.workspace.grown(table_margin_of(self.plan.params))

    @property
    def turn_period(self) -> float:
        """Placed this turn off its goal yaw, a block is as good as at it, its fingers where
        the planner checked them: a half turn for a cube, a full one when ``yaw_exact``."""
        scene = self.scene
        exact = scene is not None and scene.goal is not None and scene.goal.yaw_exact
        return 2 * math.pi if exact else GRASP_SYMMETRY

    def goal_errors(self) -> list[Deviation]:
        """Every goal slot's perceived error."""
        assert self.plan is not None and self.plan.scene is not None
        return goal_errors(self.perceived, self.plan.scene)

"""Planner parameters: gripper geometry, costs, sampling, search bounds and the options.

One frozen dataclass, ``PlannerConfig``, is both the ROS parameter set of the planner node
(``declare_config``) and the argument of the pure planner. ``config/planner.yaml`` carries the
same defaults (a unit test checks they agree). The physical reason of each geometric value is
in its description; the figures follow a Robotiq 2F-85-class gripper as the sim models it
(docs/contracts.md "Gripper": 85 mm stroke, fingers 14 mm thick along the closing axis and
22 mm wide across it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

from msgs_py import cell
from msgs_py.cell import GRIPPER_STROKE, GripperGeometry
from nodes.common.params import param

#: Longest time any planning budget may be given (s). A budget is a promise to answer; the
#: largest benchmark scenes (100 blocks) plan in seconds, and an hour bounds every search.
MAX_BUDGET_S = 3600.0
#: Most poses sampled per single-block roadmap: the roadmap holds M x M edge matrices (per
#: grasp, with a movable-block mask per edge), so this bounds its memory before it is built.
MAX_SAMPLES = 2000
#: The time parameters bounded by ``MAX_BUDGET_S``.
SECONDS = ("budget_s", "frozen_budget_s", "improve_min_s", "improve_max_s",
           "near_goal_budget_s", "exact_budget_s", "exact_pirs_s", "exact_after_s")
#: Most blocks ``exact_max_blocks`` and ``exact_after_max_blocks`` may name: the exact
#: search's states grow with the pose set to the power of the block count (cramped 9-block
#: scenes close in 2-40 s, docs/benchmarks.md; 12 is the reference command's limit).
MAX_EXACT_BLOCKS = 12


@dataclass(frozen=True)
class PlannerConfig:
    # --- gripper geometry (docs/contracts.md "Plans and how the executor reads them") -------
    finger_thickness: float = param(
        cell.FINGER_THICKNESS,
        "finger size along the closing axis (2F-85 phalanx + pad; docs/contracts.md)",
        unit="m")
    finger_width: float = param(
        cell.FINGER_WIDTH,
        "finger pad size across the closing axis (2F-85 pad is ~22 mm wide)", unit="m")
    finger_clearance: float = param(
        0.001,
        "room kept beside each finger pad's sides in the planner's footprints (a pad placed "
        "flush with a neighbour grazes it when either stands a tenth of a millimetre off)",
        unit="m")
    approach_clearance: float = param(
        cell.APPROACH_CLEARANCE,
        "gap between each finger and the block face as the open gripper descends: "
        "covers perception error (a few mm) and finger flex; opening = s + 2*clearance",
        unit="m")
    push_opening: float = param(
        cell.PUSH_OPENING,
        "finger gap during a push: both tips on the rear face (needs "
        "push_opening/2 + finger_thickness <= s/2) and far enough apart to stop the block "
        "from turning", unit="m")
    push_contact_depth: float = param(
        cell.PUSH_CONTACT_DEPTH,
        "gap between fingertips and the rear face when the fingers descend behind a "
        "block before a push, so they never land on it", unit="m")
    table_margin: float = param(
        cell.TABLE_MARGIN,
        "how far the table extends past the block workspace on every side: fingers "
        "may stand there, blocks may not", unit="m")
    # --- cost (the edge cost) -----------------------------------------------------------------
    a1: float = param(1.0, "cost of one pick-and-place action")
    a2: float = param(1.5, "cost of one push (> a1: pushes are less precise)")
    a3: float = param(1.5, "cost per movable block an action collides with (Nc)")
    distance_cost: bool = param(
        True, "option: add a_dist * distance moved and a_push_len * push length to each edge")
    a_dist: float = param(1.0, "cost per metre the block moves (with distance_cost)", unit="1/m")
    a_push_len: float = param(
        2.0, "extra cost per metre pushed (with distance_cost): long pushes drift", unit="1/m")
    # --- roadmap sampling ---------------------------------------------------------------------
    n_samples: int = param(80, "N: poses sampled per single-block roadmap")
    eps: float = param(0.3, "probability that a sample lies on a push line through the goal")
    eps_start: float = param(
        0.05, "probability that a sample lies on a push line through the start (lets an "
        "enclosed block be pushed out)")
    push_max_distance: float = param(
        0.18, "longest push sampled on a push line", unit="m")
    # --- search --------------------------------------------------------------------------------
    budget_s: float = param(30.0, "planning time budget", unit="s")
    seed: int = param(0, "seed of the planner's random generator (same seed, same first plan; "
                      "the anytime restarts that may shorten it are bounded by time, so on a "
                      "loaded machine fewer run: improve_max_s 0 makes the plan depend on the "
                      "seed alone)")
    max_depth: int = param(8, "bound on nested CLEAR / re-plan recursion per block")
    max_backtracks: int = param(
        40, "above exact_max_blocks, CLEAR routes round a blocker it failed to clear; a "
        "search that backtracks more often than this starts again with the paper's CLEAR")
    clear_attempts: int = param(4, "clearing poses tried for one blocking block")
    clear_outside_path: bool = param(
        True, "option: sample clearing poses outside the blocked path (paper: uniform)")
    clear_off_goals: bool = param(
        True, "option: keep clearing poses off the goal slots of blocks not yet placed")
    clear_goal_margin: float = param(
        0.07, "with clear_off_goals, first try to keep cleared blocks this far from pending "
        "goal slots, so fingers and push lanes around the goal stay free", unit="m")
    probe: int = param(
        5, "candidates whose route is planned before choosing the next block to place: one "
        "that needs no clearing goes first")
    clear_goal_first: bool = param(
        True, "option: try to clear a blocking block straight to its own goal first")
    assembly_order: bool = param(
        True, "option: try blocks in an assembly order of the goal layout (paper: by id)")
    shortcut: bool = param(
        True, "option: merge two moves of the same block into one where the plan allows it")
    rebuffer: bool = param(
        True, "option: after the shortcut pass, replace two moves of a block (out of the way, "
        "then on) by one to a better buffer, with hindsight: its next end itself, or a pose on "
        "a push line into it, at any moment between the two moves")
    reinsert: bool = param(
        True, "option: after the rebuffer pass, take out every move of a block moved more "
        "than once and put back the fewest that fit between the other blocks' actions")
    frozen_budget_s: float = param(
        2.0, "planning time when the start leaves a block off its goal that no grasp and no "
        "push of 5 mm or more can free, even with every block that can move gone "
        "(nodes/planner/bounds/frozen.py; a permuted grid whose hole is not its centre): such a "
        "scene has no plan short of slides within the gaps, so the planner fails soon, "
        "naming the blocks", unit="s")
    improve_factor: float = param(
        4.0, "anytime improvement: after the first plan, pIRS restarts (other samples, "
        "near ties in the order broken at random) for improve_factor x the first solve's time "
        "and the shortest validated plan is kept (pIRS is greedy per block; a restart is "
        "often an action or two shorter)")
    improve_min_s: float = param(
        1.0, "least time given to the anytime improvement (when the first solve was quick)",
        unit="s")
    improve_max_s: float = param(
        2.5, "most time given to the anytime improvement (the executor replans in its loop, "
        "so planning time counts); 0 switches it off", unit="s")
    exact_max_blocks: int = param(
        6, "scenes with at most this many blocks are first solved by the exact search over a "
        "fixed pose set (nodes/planner/bounds/exact.py: the fewest actions over that set; "
        "cramped small scenes, where pIRS finds no clearing pose, close in about a second); "
        "pIRS then tries to beat its plan; 0 switches it off")
    exact_budget_s: float = param(
        10.0, "most time given to the exact search; if it does not close, pIRS plans alone "
        "with what is left of budget_s", unit="s")
    exact_pirs_s: float = param(
        5.0, "with the exact search's plan in hand (above the lower bound), the time pIRS and "
        "its restarts get to find a shorter one (off the pose set)", unit="s")
    exact_after_max_blocks: int = param(
        9, "scenes with more blocks than exact_max_blocks and at most this many: once pIRS "
        "and its restarts have a plan above the lower bound, the exact search over the pose "
        "set looks for a shorter one (nodes/planner/bounds/pose_search.py, pruned at the "
        "plan's length) within exact_after_s; 0 switches it off")
    exact_after_s: float = param(
        12.0, "most time given to the exact search after pIRS (exact_after_max_blocks); the "
        "plan in hand is kept if it does not close", unit="s")
    goal_tolerance_xy: float = param(
        cell.PLACED_TOLERANCE_XY,
        "a block this close to its goal counts as placed (no action)", unit="m")
    goal_tolerance_yaw: float = param(
        round(math.radians(cell.PLACED_TOLERANCE_YAW_DEG), 4),
        "yaw tolerance (modulo 90 deg unless yaw_exact) for 'already placed'; "
        "1.5 deg, the executor's yaw_tolerance_deg, so a block the executor finds off its "
        "goal is one the planner moves again", unit="rad")
    near_goal_tolerance_xy: float = param(
        cell.ACCEPT_TOLERANCE_XY,
        "a block off its goal by more than goal_tolerance_xy but less than this is "
        "near its goal: if no plan that also corrects it is found within near_goal_budget_s, "
        "the planner plans again leaving it where it stands (a block a degree off in the "
        "middle of a dense grid can be neither grasped nor pushed); the executor's "
        "accept_pos_tolerance", unit="m")
    near_goal_tolerance_yaw: float = param(
        round(math.radians(cell.ACCEPT_TOLERANCE_YAW_DEG), 4),
        "... and this in yaw (2 deg, the executor's accept_yaw_tolerance_deg)",
        unit="rad")
    near_goal_budget_s: float = param(
        5.0, "time given to a plan that also corrects near-goal blocks before they are left "
        "as they stand", unit="s")

    def __post_init__(self) -> None:
        for name in ("finger_thickness", "finger_width", "push_opening", "push_max_distance",
                     "budget_s", "a1", "a2", "frozen_budget_s"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"parameter '{name}' must be > 0, got {getattr(self, name)}")
        for name in ("approach_clearance", "finger_clearance", "push_contact_depth",
                     "table_margin", "a3", "a_dist", "a_push_len", "goal_tolerance_xy",
                     "goal_tolerance_yaw", "improve_factor", "improve_min_s", "improve_max_s",
                     "exact_budget_s", "exact_pirs_s"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"parameter '{name}' must be >= 0, got {getattr(self, name)}")
        if not 0.0 <= self.eps <= 1.0 or not 0.0 <= self.eps_start <= 1.0 - self.eps:
            raise ValueError(f"need 0 <= eps ({self.eps}) and eps + eps_start "
                             f"({self.eps_start}) <= 1")
        if (self.n_samples < 0 or self.max_depth < 1 or self.clear_attempts < 1
                or self.max_backtracks < 0):
            raise ValueError("n_samples and max_backtracks must be >= 0, max_depth and "
                             "clear_attempts >= 1")
        for name in SECONDS:
            if getattr(self, name) > MAX_BUDGET_S:
                raise ValueError(f"parameter '{name}' must be at most {MAX_BUDGET_S:g} s, got "
                                 f"{getattr(self, name)}")
        for name in ("exact_max_blocks", "exact_after_max_blocks"):
            if not 0 <= getattr(self, name) <= MAX_EXACT_BLOCKS:
                raise ValueError(f"parameter '{name}' must be in [0, {MAX_EXACT_BLOCKS}], got "
                                 f"{getattr(self, name)}")
        if self.n_samples > MAX_SAMPLES:
            raise ValueError(f"parameter 'n_samples' must be at most {MAX_SAMPLES}, got "
                             f"{self.n_samples}")

    def check_block(self, block_size: float) -> None:
        """Cross-checks that need the block size (from the scene).

        Raises:
            ValueError: the open gripper would not fit around the block, or the pushing
                fingertips would not both stand on the block's rear face.
        """
        opening = block_size + 2.0 * self.approach_clearance
        if opening > GRIPPER_STROKE:
            raise ValueError(f"opening block_size + 2*approach_clearance = {opening:.4f} m "
                             f"exceeds the gripper stroke {GRIPPER_STROKE} m")
        if self.push_opening / 2.0 + self.finger_thickness > block_size / 2.0:
            raise ValueError("push_opening/2 + finger_thickness exceeds block_size/2: the "
                             "fingertips would miss the block's rear face")

    def gripper(self, block_size: float) -> GripperGeometry:
        """The footprint geometry the planner checks, for blocks of ``block_size``: the finger
        pads ``finger_clearance`` wider on each side than ``finger_width``. A plan's params
        keep the pads' own width (the executor and the validator use it)."""
        return GripperGeometry(block_size, self.finger_thickness,
                               self.finger_width + 2.0 * self.finger_clearance,
                               self.approach_clearance, self.push_opening,
                               self.push_contact_depth)

    def to_params(self, block_size: float) -> dict[str, Any]:
        """Everything a plan's ``params`` must carry to be replayed on its own."""
        out: dict[str, Any] = {"block_size": block_size, "stroke": GRIPPER_STROKE}
        out.update({f.name: getattr(self, f.name) for f in fields(self)})
        return out

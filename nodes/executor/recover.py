"""Recovering what the camera shows is wrong before the run can go on.

A block in the fingers (found at start-up, say) is set down at a free spot; a block outside
the workspace (dropped, knocked) is brought back in; two blocks seen overlapping (one
knocked against or onto the other) are set apart. Each recovery ends with a fresh look,
judged for what the look before it was judged for (``Recovered``). Geometry and scripts
are ``nodes.executor.recovery``'s.
"""

from __future__ import annotations

import math

from msgs_py import Pose2D, Workspace
from msgs_py.cell import table_margin_of
from msgs_py.status import ExecutorState as State
from nodes.executor.belief import Belief
from nodes.executor.config import ExecutorConfig
from nodes.executor.decisions import Decision, Enter, Observe, Recovered, Script, Stop
from nodes.executor.motion import ToolPose
from nodes.executor.recovery import (
    bring_in_steps,
    free_grasp,
    free_spot,
    let_go_steps,
    outside,
    overlapping_ids,
    set_down_steps,
    wide_opening,
)
from nodes.executor.report import Report
from nodes.executor.states import Held, Purpose, Tries

#: A block brought back in is set down this far inside the workspace's edge (m): a camera
#: a centimetre off (before its check) then still sees it inside.
BRING_IN_INSET = 0.015
#: Tries to bring the same block in before giving up.
MAX_BRING_INS = 3
#: A footprint that leaves the workspace by less than this is inside: the sim's scenes put
#: blocks up to the edge, and the camera's noise (0.3 mm at most) must not send the arm to
#: bring one in (seed 78 of the cell benchmark: a footprint 0.5 um inside, seen just out)
EDGE_TOLERANCE = 0.001
#: Tries to set overlapping blocks apart before giving up (each is a pick-and-place and a look).
MAX_SEPARATIONS = 3


def held_block(belief: Belief, look_for: Purpose, cfg: ExecutorConfig, report: Report,
               tool: ToolPose | None) -> Decision:
    """The fingers hold a block: find which (the one block unseen), set it down near where
    it was picked up (or near the tool) at a free spot; then judge the next frame for
    ``look_for``. Holding something no unseen block explains: let go here and look."""
    plan, held = belief.plan, belief.held
    assert plan is not None and held is not None
    block = held.block
    if block is None:
        known = ({b.id for b in plan.scene.blocks} if plan.scene else set()) | set(
            belief.expected)
        unseen = sorted(known - set(belief.perceived))
        if len(unseen) != 1:
            report.log(f"the fingers hold something, but {len(unseen)} blocks are unseen; "
                       "letting go here, out of the workspace, and looking again")
            belief.held = None
            return Enter(State.RECOVERING, Script(let_go_steps(belief.geo, cfg, "recover"),
                                                  Recovered(look_for)))
        block = unseen[0]
    assert tool is not None
    near = held.picked_from or (plan.scene is not None and plan.scene.blocks and next(
        (b.pose for b in plan.scene.blocks if b.id == block), None))
    target = near or Pose2D(tool.x, tool.y, 0.0)
    spot = None if plan.scene is None else free_spot(
        belief.perceived, plan.scene.workspace, belief.geo, tool.yaw, (target.x, target.y),
        table_margin_of(plan.params))
    if spot is None:
        return Stop(f"holding block {block} and no free spot to set it down", failed=True)
    report.say(f"setting block {block} down at ({spot.x:.3f}, {spot.y:.3f})")
    belief.held = Held(block)
    belief.expected[block] = spot
    belief.moved_aside.add(block)
    return Enter(State.RECOVERING, Script(set_down_steps(block, spot, tool.yaw, belief.geo, cfg),
                                          Recovered(look_for)))


def bring_in(belief: Belief, tries: Tries, cfg: ExecutorConfig, report: Report,
             look_for: Purpose) -> Decision | None:
    """A perceived block outside the workspace or the arm's working reach (dropped,
    knocked): pick it up and set it down at the nearest free spot inside both. None when
    every block is inside."""
    plan = belief.plan
    assert plan is not None and plan.scene is not None
    away = outside(belief.perceived, plan.scene.workspace.grown(EDGE_TOLERANCE),
                   belief.geo.block_size)
    if not away:
        tries.bring_ins.reset()
        return None
    block = away[0]
    at = belief.perceived[block]
    if tries.bring_ins.again(block) > MAX_BRING_INS:
        return Stop(f"block {block} is still seen outside the workspace or reach at "
                    f"({at.x:.3f}, {at.y:.3f}) after {MAX_BRING_INS} tries to bring it in",
                    failed=True)
    margin = table_margin_of(plan.params)
    table = plan.scene.workspace
    reach = table.grown(3 * margin)
    grasp = free_grasp(belief.perceived, block, belief.geo, reach)
    spot = free_spot({b: p for b, p in belief.perceived.items() if b != block},
                     table.grown(-BRING_IN_INSET), belief.geo, at.theta, (at.x, at.y),
                     margin + BRING_IN_INSET)
    if grasp is None or spot is None:
        return Stop(f"block {block} lies outside the workspace or reach at ({at.x:.3f}, {at.y:.3f})"
                    " and cannot be " + ("grasped there" if grasp is None else
                                         "set down anywhere free inside"), failed=True)
    return move_aside(belief, cfg, report, look_for, block, spot, grasp, belief.perceived, reach,
                      f"bringing block {block} back into the workspace")


def set_apart(belief: Belief, tries: Tries, cfg: ExecutorConfig, report: Report,
              look_for: Purpose) -> Decision | None:
    """Two perceived blocks overlap (one knocked against or onto another, leaning on it):
    no plan starts from that, so one of them is picked up and set down at the nearest free
    spot: the one that moved furthest from where it was expected first (the knocked one,
    which lies on the other if either does). None when no two blocks overlap."""
    plan = belief.plan
    assert plan is not None and plan.scene is not None
    pairs = overlapping_ids(belief.perceived, belief.geo.block_size)
    if not pairs:
        tries.separations = 0
        tries.apart_blocked = set()
        return None
    if tries.separations >= MAX_SEPARATIONS:
        return Stop(f"blocks {list(pairs[0])} still overlap after {tries.separations} tries "
                    "to set one of them apart", failed=True)
    block, partner, grasp, rest = _apart_grasp(belief, *_which_first(belief, tries, pairs))
    at = belief.perceived[block]
    spot = free_spot({k: p for k, p in belief.perceived.items() if k != block},
                     plan.scene.workspace, belief.geo, at.theta, (at.x, at.y),
                     table_margin_of(plan.params))
    if grasp is None or spot is None:
        return Stop(f"blocks {block} and {partner} overlap and neither can be " + (
            "grasped" if grasp is None else "set down anywhere free"), failed=True)
    tries.separations += 1
    tries.setting_apart = block
    return move_aside(belief, cfg, report, look_for, block, spot, grasp, rest, belief.table(),
                      f"blocks {block} and {partner} overlap: setting block {block} apart")


def _apart_grasp(belief: Belief, first: int, second: int
                 ) -> tuple[int, int, int | None, dict[int, Pose2D]]:
    """Which of an overlapping pair to pick up, how, and around which blocks: fingers that
    clear the partner too first (a block leaning on its neighbour along x is gripped along
    y, beside the neighbour, not with a finger coming down on it), for either block; then,
    ignoring the partner (the overlap may leave no grasp beside it), the first, then the
    other. The grasp is None when neither block has one."""
    table = belief.table()
    around = belief.perceived
    for beside_partner in (True, False):
        for block, partner in ((first, second), (second, first)):
            around = belief.perceived if beside_partner else {
                k: p for k, p in belief.perceived.items() if k != partner}
            grasp = free_grasp(around, block, belief.geo, table)
            if grasp is not None:
                return block, partner, grasp, around
    return second, first, None, around


def _which_first(belief: Belief, tries: Tries, pairs: list[tuple[int, int]]
                 ) -> tuple[int, int]:
    """Of the overlapping pair whose block moved furthest, that block first, unless a
    descent to it already stopped on its partner (which then lies on top)."""
    a, b = max(pairs, key=lambda pair: max(_moved(belief, pair[0]), _moved(belief, pair[1])))
    first, second = (a, b) if _moved(belief, a) >= _moved(belief, b) else (b, a)
    if first in tries.apart_blocked and second not in tries.apart_blocked:
        first, second = second, first  # the tool stopped on the other: it is on top
    return first, second


def _moved(belief: Belief, block: int) -> float:
    """How far (m) ``block`` is seen from where it was expected (inf: not expected
    anywhere, as a block let go of after a grasp fault)."""
    was = belief.expected.get(block)
    return math.inf if was is None else belief.perceived[block].distance_to(was)


def move_aside(belief: Belief, cfg: ExecutorConfig, report: Report, look_for: Purpose,
               block: int, spot: Pose2D, grasp: int, around: dict[int, Pose2D],
               table: Workspace, why: str) -> Enter:
    """Pick ``block`` where it is seen and set it down at ``spot``, the fingers wide open
    where they clear ``around`` on ``table``; then look again."""
    at = belief.perceived[block]
    report.say(f"{why}, from ({at.x:.3f}, {at.y:.3f}) to ({spot.x:.3f}, {spot.y:.3f})")
    belief.picked_from = at
    belief.expected[block] = spot
    belief.moved_aside.add(block)
    belief.handling = block
    opening = wide_opening(dict(around), block, grasp, table, belief.geo, cfg.pick_clearance)
    steps = bring_in_steps(block, at, spot, grasp, belief.geo, cfg, opening, belief.turn_period)
    return Enter(State.RECOVERING, Script(steps, Recovered(look_for)))


def recovered(then: Recovered, belief: Belief, tries: Tries, stop_requested: bool
              ) -> Decision:
    """A recovery ran to its end: the fingers are empty; look (near, after a fault), or
    stop if asked to."""
    belief.held = None
    belief.handling = None
    tries.setting_apart = None
    if stop_requested:
        return Stop("stop requested", failed=False)
    return Observe(then.look_for, near=then.look_for is Purpose.RECOVERY)

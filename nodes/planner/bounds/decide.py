"""Proven optima over a stated pose set: "is there a plan of at most K actions?" (CP-SAT).

**The pose set** is ``exact.pose_set``: every block's start, every goal slot, poses on the
push lines into each slot and out of each start (0.5, 1 and 2 block sizes), and a lattice of
buffers 1.5 block sizes apart at the goal's yaw, clear of the slots; poses are footprints (the
cube's 90-degree symmetry). **A plan over the pose set** is a sequence of single actions, each
taking one block from the pose it stands on to another pose of the set with every other block
where it stands: a pick-and-place whose fingers (either grasp axis at each end) stand on the
table, in reach and off every other block, whose block lands off every other block, and whose
carry the arm can follow; or a straight push along a face normal whose swept block and
fingertips miss every other block (``exact.PoseSet``: the same moves as the A* of ``exact``,
with the planner's footprints). **Optimal** here means: no plan over the pose set has fewer
actions. Plans found elsewhere (pIRS samples any pose) may be shorter than that optimum; a
certified lower bound (``bound``) holds for every plan.

``decide(K)`` is a bounded-horizon model over K steps: per step and pose whether a block
stands there (per block for a labeled goal), per step which block moves (at most one; idle
steps only at the end, so "at most K"), the pose it leaves and the pose it reaches (where the
occupancy changes), the kind of action and the grasp axis at each end; a clause per pose,
grasp and finger-hit pose forbids a move whose fingers meet a block, one per push and swept
pose likewise, and footprints of blocks never overlap. ``prove_optimum`` asks K = the
certified bound, then K + 1, ...: each "no" proves the optimum above K; the first "yes" is the
optimum over the pose set, with its plan; a level that runs out of time ends the run with the
bound proven so far.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from ortools.sat.python import cp_model

from msgs_py import Pose2D
from msgs_py.actions import Action
from nodes.planner.bounds.exact import PoseProblem, pose_problem

#: CP-SAT workers per level (the machine has two cores, shared).
WORKERS = 1


@dataclass(frozen=True)
class Level:
    """One decision: is there a plan of at most ``k`` actions over the pose set?"""

    k: int
    status: str  # "feasible", "infeasible" or "unknown" (out of time)
    seconds: float


@dataclass
class Decision:
    """What ``prove_optimum`` proved: ``bound`` (no plan over the pose set has fewer
    actions), and ``optimum`` with its ``plan`` when a level said yes."""

    bound: int
    optimum: int | None = None
    plan: list[Action] | None = None
    levels: list[Level] = field(default_factory=list)
    poses: int = 0

    @property
    def proven(self) -> bool:
        return self.optimum is not None


class HorizonModel:
    """The CP-SAT model of plans of at most ``k`` actions over ``problem``'s pose set."""

    def __init__(self, problem: PoseProblem, k: int) -> None:
        self.pp, self.k = problem, k
        ps = problem.poses
        self.p = len(ps.poses)
        self.n = len(problem.ids)
        m = cp_model.CpModel()
        self.m = m
        steps = range(k + 1)
        self.at = [[[m.NewBoolVar("") for _ in range(self.p)] for _ in steps]
                   for _ in range(self.n)] if problem.labeled else None
        self.occ = [[m.NewBoolVar("") for _ in range(self.p)] for _ in steps]
        self.active: list = []  # per step: an action happens
        self.steps: list[tuple] = []  # per step: (src, dst, pick, axis at src, axis at dst)
        self.movers: list[list] = []  # labeled: per step, which block moves
        self._states()
        for t in range(k):
            self._step(t)
        self._ends()

    # --- states ---------------------------------------------------------------------------
    def _states(self) -> None:
        m, ps = self.m, self.pp.poses
        conflict = np.triu(ps.conflict, 1)
        pairs = np.argwhere(conflict)
        for t in range(self.k + 1):
            occ = self.occ[t]
            if self.at is not None:
                for b in range(self.n):
                    m.AddExactlyOne(self.at[b][t])
                for q in range(self.p):
                    m.Add(occ[q] == sum(self.at[b][t][q] for b in range(self.n)))
            else:
                m.Add(sum(occ) == self.n)
            for a, b in pairs:
                m.AddBoolOr([occ[a].Not(), occ[b].Not()])

    def _ends(self) -> None:
        m, pp = self.m, self.pp
        for q in range(self.p):
            m.Add(self.occ[0][q] == int(q in pp.state))
        if self.at is not None:
            for b, q in enumerate(pp.state):
                m.Add(self.at[b][0][q] == 1)
            for b, slot in enumerate(pp.slots):
                m.Add(self.at[b][self.k][slot] == 1)
        else:
            for slot in pp.slots:
                m.Add(self.occ[self.k][slot] == 1)
        self._counting_cuts()

    def _counting_cuts(self) -> None:
        """Redundant cuts that prune hopeless prefixes: every goal block off its goal (every
        empty slot, unlabeled) at step t needs one of the k - t actions left."""
        m, pp = self.m, self.pp
        for t in range(self.k + 1):
            if self.at is not None:
                on_goal = [self.at[b][t][slot] for b, slot in enumerate(pp.slots)]
            else:
                on_goal = [self.occ[t][slot] for slot in pp.slots]
            m.Add(len(on_goal) - sum(on_goal) <= self.k - t)

    # --- one action ------------------------------------------------------------------------
    def _step(self, t: int) -> None:
        m, ps = self.m, self.pp.poses
        now, nxt = self.occ[t], self.occ[t + 1]
        active = m.NewBoolVar("")
        self.active.append(active)
        if t:
            m.AddImplication(active, self.active[t - 1])
        src = [m.NewBoolVar("") for _ in range(self.p)]
        dst = [m.NewBoolVar("") for _ in range(self.p)]
        for q in range(self.p):
            # src: occupied now, empty after; dst: empty now, occupied after
            m.AddBoolAnd([now[q], nxt[q].Not()]).OnlyEnforceIf(src[q])
            m.AddBoolOr([now[q].Not(), nxt[q], src[q]])
            m.AddBoolAnd([now[q].Not(), nxt[q]]).OnlyEnforceIf(dst[q])
            m.AddBoolOr([now[q], nxt[q].Not(), dst[q]])
            if not ps.stand_ok[q]:
                m.Add(dst[q] == 0)
        m.Add(sum(src) == active)
        m.Add(sum(dst) == active)
        if self.at is not None:
            self._labeled_frame(t, active)
        pick, push = m.NewBoolVar(""), m.NewBoolVar("")
        m.Add(pick + push == active)
        axis_u, axis_v = m.NewBoolVar(""), m.NewBoolVar("")  # grasp axis 1 at each end
        self._fingers(pick, axis_u, src, now)
        self._fingers(pick, axis_v, dst, nxt)
        for u, v in np.argwhere(~ps.carry_ok):
            m.AddBoolOr([pick.Not(), src[u].Not(), dst[v].Not()])
        self._pushes(push, src, dst, now)
        self.steps.append((src, dst, pick, axis_u, axis_v))

    def _labeled_frame(self, t: int, active) -> None:
        """Exactly the block that moves changes pose (at most one per step)."""
        m = self.m
        moves = [m.NewBoolVar("") for _ in range(self.n)]
        m.Add(sum(moves) == active)
        for b in range(self.n):
            here, there = self.at[b][t], self.at[b][t + 1]
            for q in range(self.p):
                m.Add(there[q] == here[q]).OnlyEnforceIf(moves[b].Not())
                m.AddBoolOr([moves[b].Not(), here[q].Not(), there[q].Not()])
        self.movers.append(moves)

    def _fingers(self, pick, axis, end: list, occ: list) -> None:
        """A pick-and-place's fingers at the pose ``end`` marks (the pose left, or the pose
        reached), along ``axis``: usable there and off every block of ``occ`` (the others:
        no block overlaps the moving one)."""
        m, ps = self.m, self.pp.poses
        for q in range(self.p):
            for g, lit in ((0, axis), (1, axis.Not())):  # lit false <=> this axis is used
                if not ps.fingers_ok[q, g]:
                    m.AddBoolOr([pick.Not(), end[q].Not(), lit])
                    continue
                for r in np.flatnonzero(ps.fingers[q, g] & ~ps.conflict[q]):
                    m.AddBoolOr([pick.Not(), end[q].Not(), lit, occ[r].Not()])

    def _pushes(self, push, src: list, dst: list, occ: list) -> None:
        m, ps = self.m, self.pp.poses
        for u in range(self.p):
            lines = ps.pushes.get(u, [])
            m.AddBoolOr([push.Not(), src[u].Not(), *(dst[v] for v, _ in lines)])
            for v, blocked in lines:
                for r in np.flatnonzero(blocked & ~ps.conflict[u]):
                    m.AddBoolOr([push.Not(), src[u].Not(), dst[v].Not(), occ[r].Not()])

    # --- solve -------------------------------------------------------------------------------
    def solve(self, seconds: float) -> tuple[str, list[Action] | None]:
        solver = cp_model.CpSolver()
        solver.parameters.max_time_in_seconds = max(seconds, 0.01)
        solver.parameters.num_workers = WORKERS
        status = solver.Solve(self.m)
        if status in (cp_model.OPTIMAL, cp_model.FEASIBLE):
            return "feasible", self._plan(solver)
        if status == cp_model.INFEASIBLE:
            return "infeasible", None
        return "unknown", None

    def _plan(self, solver: cp_model.CpSolver) -> list[Action]:
        moves: list[tuple[int, int, str]] = []
        at = list(self.pp.state)
        for t, (src, dst, pick, _, _) in enumerate(self.steps):
            if not solver.Value(self.active[t]):
                break
            u = next(q for q in range(self.p) if solver.Value(src[q]))
            v = next(q for q in range(self.p) if solver.Value(dst[q]))
            block = at.index(u)
            moves.append((block, v, "pick_place" if solver.Value(pick) else "push"))
            at[block] = v
        return self.pp.realize(moves)


def prove_optimum(ctx, start: Mapping[int, Pose2D], goal_slots: list[Pose2D],
                  assignment: Mapping[int, int] | None, lower_bound: int, seconds: float,
                  upper: int | None = None) -> Decision:
    """Levels K = ``lower_bound``, ``lower_bound`` + 1, ... (at most ``upper`` when given)
    within ``seconds`` in all; see the module docstring. ``assignment`` as ``exact``'s."""
    deadline = time.monotonic() + seconds
    problem = pose_problem(ctx, start, goal_slots, assignment)
    out = Decision(bound=lower_bound, poses=len(problem.poses.poses))
    k = lower_bound
    while upper is None or k <= upper:
        left = deadline - time.monotonic()
        if left <= 0.0:
            break
        began = time.monotonic()
        status, plan = HorizonModel(problem, k).solve(left)
        out.levels.append(Level(k, status, time.monotonic() - began))
        if status == "feasible":
            out.optimum, out.plan = k, plan
            return out
        if status == "unknown":
            return out
        k += 1
        out.bound = k
    return out

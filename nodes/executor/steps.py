"""Step scripts: what the executor streams, one step after the other.

A primitive (pick-and-place, push, park) is a list of steps: ``Move`` (a straight,
time-optimal move to a tool pose), ``Rise`` (straight up to a height from wherever the tool
is), ``Grip`` (set the finger opening and wait until the gripper has done it), each with the
activity it serves and the block it handles. ``StepRunner`` plays a script: fed the time, the
measured TCP and the measured finger gap at every tick, it returns the setpoint (and gripper
command) to publish, so the node stays a thin timer callback and tests run it without ROS.

A move starts from where the script last commanded the tool, so streamed setpoints are
continuous even when tracking lags. A move with a ``blend`` radius hands over to the next
move that far before its end, the way a UR blends ``movel`` segments: the two profiles
overlap (one slowing down while the other speeds up, so the speed never exceeds either's
limit) and the tool rounds the corner within the radius instead of stopping in it. A move
without a blend ends only when the measured TCP has converged on its end point. A script
that cannot go on says why as a ``StepFault``.
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from nodes.executor.grip import (
    GRIP_MIN_S,
    GRIP_STALL_S,
    GRIP_TIMEOUT_S,
    GRIPPER_SILENT_S,
    gripper_done,
    opening_stalled,
    since_pause,
)
from nodes.executor.motion import (
    Blending,
    Limits,
    LinearMove,
    ToolPose,
    blend_overlap,
    braking_move,
    stopped_on_the_way_down,
)


class Activity(enum.Enum):
    """What a step is for, as the run's time is charged (``ledger.activity_of``)."""

    BLOCK = "block"  #: handling the block ``Step.block``: charged to the plan action moving it
    LOOK = "look"  #: getting out of the camera's view (the look and park poses)
    OTHER = "other"  #: anything else (a stop's lift, letting go, ...)


@dataclass(frozen=True, slots=True)
class Move:
    target: ToolPose
    limits: Limits
    label: str = ""
    converge: bool = True
    blend: float = 0.0  #: m: start the next move this far before the end (no convergence)
    #: the last part of a descent from this height (m) onto the table or a block: stopped
    #: above its end after coming down, the tool stands on something
    onto: float | None = None
    activity: Activity = Activity.OTHER
    block: int | None = None  #: the block the step handles (``Activity.BLOCK``)
    pushes: bool = False  #: a push's stroke: once it ends, ``block`` stands at its goal


@dataclass(frozen=True, slots=True)
class Rise:
    """Straight up (never down) to ``z`` at the current x, y, yaw."""

    z: float
    limits: Limits
    label: str = "rise"
    blend: float = 0.0
    activity: Activity = Activity.OTHER
    block: int | None = None


@dataclass(frozen=True, slots=True)
class Grip:
    """Set the finger opening (m) and wait until the fingers are there or stopped on a block.

    ``holds`` says which block is in the fingers afterwards; ``squares`` that they closed on
    it along its other axis just before, at the same TCP (it then stands on the TCP on both
    axes). ``settle_s`` is how long to wait when no finger measurement comes (a gripper that
    reports nothing). ``wait=False`` only sends the command: the fingers move while the script
    goes on. ``off_at``: a release is done once the gap is this wide (the pads off the block).
    """

    opening: float
    settle_s: float
    label: str = ""
    holds: int | None = None
    wait: bool = True
    squares: bool = False
    off_at: float = float("inf")
    activity: Activity = Activity.OTHER
    block: int | None = None


@dataclass(frozen=True, slots=True)
class Brake:
    """Come to rest from ``velocity`` (m/s, x y z) along a straight line, decelerating at
    ``decel`` (m/s^2): how the arm stops safely in the middle of a move."""

    velocity: tuple[float, float, float]
    decel: float
    label: str = "brake"
    activity: Activity = Activity.OTHER
    block: int | None = None


Step = Move | Rise | Grip | Brake


def of_block(block: int) -> dict[str, Any]:
    """The fields (``activity``, ``block``) of a step that handles ``block``."""
    return {"activity": Activity.BLOCK, "block": block}


class StepFaultKind(enum.Enum):
    """Why a script could not go on."""

    REFUSED = "refused"  #: the next move would leave the safe box
    NOT_CONVERGED = "not converged"  #: the measured TCP did not reach a move's end in time
    BLOCKED = "blocked"  #: a descent stopped above its end: something stands below
    STALLED = "stalled"  #: an opening stopped short: the fingers did not let go
    GRIPPER_TIMEOUT = "gripper timeout"  #: the fingers neither reached the opening nor stopped


@dataclass(frozen=True, slots=True)
class StepFault:
    """A script's fault, in words for the log and the status."""

    kind: StepFaultKind
    message: str


@dataclass(frozen=True, slots=True)
class Tick:
    """What to publish this tick, and where the script stands (``fault``: why it stops)."""

    setpoint: ToolPose
    gripper: float | None
    done: bool
    fault: StepFault | None = None
    label: str = ""
    missed: tuple[tuple[float, ToolPose], ...] = ()  #: late ticks' (time, setpoint), in order

    @property
    def error(self) -> str:
        """The fault in words ("" without one), for players that only report it."""
        return "" if self.fault is None else self.fault.message


#: With no fresh measurement at all, give up after this many convergence timeouts.
STALE_FACTOR = 5.0


class StepRunner:
    """Plays a step script from ``start`` (the last commanded tool pose)."""

    def __init__(self, steps: Sequence[Step], start: ToolPose, convergence_tol: float,
                 convergence_timeout_s: float, in_safe_box=lambda pose: True) -> None:
        self.steps = list(steps)
        self.commanded = start  #: the end point of the last move begun (the nominal pose)
        self.tol = convergence_tol
        self.timeout = convergence_timeout_s
        self.in_safe_box = in_safe_box
        self.index = 0
        self._measured_at = 0.0
        self._t0: float | None = None
        self._move: LinearMove | None = None
        self._blending: list[Blending] = []
        self.gripper: float | None = None
        self.gripper_reports = False  #: see ``update``
        self._gripper_sent, self._before = False, None
        self._gaps: list[tuple[float, float]] = []
        self.finished_steps: list[Step] = []  #: steps that ended in the last update

    @property
    def finished(self) -> bool:
        return self.index >= len(self.steps)

    @property
    def current_step(self) -> Step | None:
        """The step playing now (None: the script has ended)."""
        return None if self.finished else self.steps[self.index]

    @property
    def current_label(self) -> str:
        step = self.current_step
        return "" if step is None else step.label

    def update(self, now: float, measured: ToolPose | None, measured_at: float | None = None,
               gaps: Sequence[tuple[float, float]] = (), gripper_reports: bool = False
               ) -> Tick:
        """Advance to time ``now`` (s); ``measured`` is the latest TCP (None if unknown),
        ``gaps`` the finger gaps (time s, gap m) measured since the last call (none when the
        gripper reports nothing). ``gripper_reports``: the gripper has reported before, so a
        silence after a command means it is not there (its node died and is coming back), not
        that it reports nothing: the grip waits for it.

        Steps that finish within this call hand their gripper command on, so a ``Grip``
        followed at once by a move still reaches the gripper. ``measured_at`` is the time the
        measurement was taken (default ``now``): a move fails to converge only on
        measurements taken ``convergence_timeout_s`` after it ended, so a late /tcp_pose on a
        loaded machine delays the verdict instead of faking a failure.
        """
        self._measured_at = now if measured_at is None else measured_at
        self._gaps.extend(gaps)
        self.gripper_reports = gripper_reports
        self.finished_steps = []
        gripper: float | None = None
        while not self.finished:
            step = self.steps[self.index]
            if self._t0 is None:
                refusal = self._begin(step, now)
                if refusal is not None:
                    return Tick(self.commanded, gripper, False, refusal, step.label)
            tick = self._update_step(step, now, measured)
            if tick.gripper is not None:
                gripper = tick.gripper
            if tick.fault is not None or not tick.done:
                return dataclasses.replace(tick, gripper=gripper)
            self.finished_steps.append(step)
            self._advance(step, now)
        setpoint = self._with_blend(self.commanded, now)
        return Tick(setpoint, gripper, not self._blending)

    # --- internals ------------------------------------------------------------------------------
    def _begin(self, step: Step, now: float) -> StepFault | None:
        """Start ``step``; returns why it is refused (None when it may run)."""
        self._t0 = now
        self._gripper_sent, self._before = False, self.gripper  # the opening commanded so far
        self._gaps = self._gaps[-1:]
        if isinstance(step, Brake):
            self._move = braking_move(self.commanded, step.velocity, step.decel)
        elif isinstance(step, Move | Rise):
            target = self._target(step)
            if not self.in_safe_box(target):
                self._t0 = None
                return StepFault(StepFaultKind.REFUSED,
                                 f"step '{step.label}' would go to ({target.x:.3f}, "
                                 f"{target.y:.3f}, {target.z:.3f}), outside the safe box")
            self._move = LinearMove.plan(self.commanded, target, step.limits)
        return None

    def velocity(self, now: float) -> tuple[float, float, float]:
        """The setpoints' velocity (m/s) at ``now``, from the script's own timing."""
        if self._t0 is None or self._move is None or self.finished:
            return (0.0, 0.0, 0.0)
        dt = 1e-3
        a, b = self._sample(now - dt), self._sample(now)
        return ((b.x - a.x) / dt, (b.y - a.y) / dt, (b.z - a.z) / dt)

    def _sample(self, now: float) -> ToolPose:
        assert self._move is not None and self._t0 is not None
        return self._with_blend(self._move.sample(now - self._t0), now, keep=True)

    def brake(self, now: float, decel: float, then: Sequence[Step] = ()) -> None:
        """Stop the script where it is: decelerate along the current motion, then play
        ``then`` (a recovery) from where the tool comes to rest."""
        velocity = self.velocity(now)
        here = self._sample(now) if self._move is not None and self._t0 is not None \
            else self.commanded
        self.steps = [Brake(velocity, decel), *then]
        self.index = 0
        self.commanded = here
        self._t0 = None
        self._move = None
        self._blending = []

    def retry_current(self, before: Sequence[Step]) -> None:
        """Play ``before`` from where the tool is, then the current step again from its start,
        then the rest (a release that stalled: grip the block again, then open again)."""
        self.steps[self.index:self.index] = list(before)
        self._t0 = None
        self._move = None

    def _target(self, step: Move | Rise) -> ToolPose:
        if isinstance(step, Move):
            return step.target
        return self.commanded.with_z(max(step.z, self.commanded.z))

    def _with_blend(self, pose: ToolPose, now: float, keep: bool = False) -> ToolPose:
        """``pose`` plus what blended previous moves have still to go."""
        if not keep:
            self._blending = [b for b in self._blending if now - b.t0 < b.move.duration]
        for b in self._blending:
            d = b.offset(now)
            pose = pose.plus(d.x, d.y, d.z, d.yaw)
        return pose

    def _update_step(self, step: Step, now: float, measured: ToolPose | None) -> Tick:
        t = 0.0 if self._t0 is None else now - self._t0
        if isinstance(step, Grip):
            return self._update_grip(step, t)
        move = self._move
        assert move is not None
        setpoint = self._with_blend(move.sample(t), now)
        following = self._following_move(step)
        if following is not None:
            overlap = blend_overlap(move, following, step.blend)
            if t >= move.duration - overlap:
                return Tick(setpoint, None, True, label=step.label)
        if t < move.duration:
            return Tick(setpoint, None, False, label=step.label)
        self.commanded = move.end
        converge = step.converge if isinstance(step, Move) else not isinstance(step, Brake)
        if not converge or self._blending:
            return Tick(setpoint, None, not self._blending, label=step.label)
        if measured is not None and measured.distance_to(move.end) <= self.tol:
            return Tick(move.end, None, True, label=step.label)
        late = self._measured_at - (self._t0 + move.duration)
        if late > self.timeout or t > move.duration + STALE_FACTOR * self.timeout:
            off = ("unknown" if measured is None
                   else f"{measured.distance_to(move.end) * 1e3:.1f} mm: at "
                        f"({measured.x:.4f}, {measured.y:.4f}, {measured.z:.4f})")
            end = move.end
            blocked = (isinstance(step, Move) and step.onto is not None
                       and measured is not None
                       and stopped_on_the_way_down(step.onto, end, measured, self.tol))
            kind = StepFaultKind.BLOCKED if blocked else StepFaultKind.NOT_CONVERGED
            return Tick(end, None, False, StepFault(
                kind, f"step '{step.label}': TCP did not reach ({end.x:.4f}, {end.y:.4f}, "
                      f"{end.z:.4f}) within {self.timeout:.1f} s (off by {off})"), step.label)
        return Tick(move.end, None, False, label=step.label)

    def _following_move(self, step: Step) -> LinearMove | None:
        """The move that follows a blended ``step``, planned from its end (None: no blend)."""
        if not isinstance(step, Move | Rise) or step.blend <= 0.0 or self._move is None:
            return None
        if self.index + 1 >= len(self.steps):
            return None
        nxt = self.steps[self.index + 1]
        if not isinstance(nxt, Move | Rise):
            return None
        end = self._move.end
        target = nxt.target if isinstance(nxt, Move) else end.with_z(max(nxt.z, end.z))
        if not self.in_safe_box(target):
            return None
        return LinearMove.plan(end, target, nxt.limits)

    def _update_grip(self, step: Grip, t: float) -> Tick:
        # a command the gripper already has is not sent again (only waited for)
        gripper = None if self._gripper_sent or self.gripper == step.opening else step.opening
        self._gripper_sent = True
        self.gripper = step.opening
        t0 = self._t0 if self._t0 is not None else 0.0
        since_command = [(s, g) for s, g in self._gaps if s >= t0]
        # judged on the reports since the gripper's last pause, its time counted from the
        # first of them: a gripper node that died after the command and came back (it gets
        # the command again with its lease) is judged on what the new node did
        measured = since_pause(since_command, t0 + t)
        heard = t - (measured[0][0] - t0) if measured else 0.0
        if not step.wait:
            done = True
        elif not measured and not (self.gripper_reports or since_command):
            done = t >= step.settle_s
        elif not measured:
            silent = t0 + t - max([t0] + [s for s, _ in since_command[-1:]])
            if silent > GRIPPER_SILENT_S:
                return Tick(self.commanded, gripper, False, StepFault(
                    StepFaultKind.GRIPPER_TIMEOUT, f"step '{step.label}': the gripper has "
                    f"reported nothing for {silent:.0f} s (is its node running?)"), step.label)
            done = False
        else:
            sent = self._before != step.opening  # none sent: nothing to wait GRIP_MIN_S for
            done = (t >= GRIP_MIN_S or not sent) and (
                gripper_done(self._gaps, step.opening, heard, self._before)
                or measured[-1][1] >= step.off_at)
        if not done and heard >= GRIP_STALL_S and opening_stalled(measured, step.opening):
            return Tick(self.commanded, gripper, False, StepFault(
                StepFaultKind.STALLED,
                f"step '{step.label}': the fingers stopped opening at "
                f"{measured[-1][1] * 1e3:.1f} mm (asked for {step.opening * 1e3:.1f} mm)"),
                step.label)
        if not done and measured and heard > GRIP_TIMEOUT_S:
            return Tick(self.commanded, gripper, False, StepFault(
                StepFaultKind.GRIPPER_TIMEOUT,
                f"step '{step.label}': the gripper neither reached {step.opening * 1e3:.1f} mm "
                f"nor stopped within {GRIP_TIMEOUT_S:.0f} s (gap {measured[-1][1] * 1e3:.1f} mm)"),
                step.label)
        return Tick(self.commanded, gripper, done, label=step.label)

    def _advance(self, step: Step, now: float) -> None:
        move = self._move
        if move is not None:
            started = now if self._t0 is None else self._t0
            left = move.duration - (now - started)
            if left > 1e-9:  # blended: the rest of this move runs on under the next
                self._blending.append(Blending(move, now - (move.duration - left)))
            self.commanded = move.end
        self.index += 1
        self._t0 = None
        self._move = None

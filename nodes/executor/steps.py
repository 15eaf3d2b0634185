"""Step scripts: what the executor streams, one step after the other.

A primitive (pick-and-place, push, park) is a list of steps: ``Move`` (a straight,
time-optimal move to a tool pose), ``Rise`` (straight up to a height from wherever the tool
is), ``Grip`` (set the finger opening and wait until the gripper has done it). ``StepRunner``
plays a script: fed the time, the measured TCP and the measured finger gap at every tick, it
returns the setpoint (and gripper command) to publish, so the node stays a thin timer
callback and tests can play a script without ROS.

A move starts from where the script last commanded the tool, so streamed setpoints are
continuous even when tracking lags. A move with a ``blend`` radius hands over to the next
move that far before its end, the way a UR blends ``movel`` segments: the two profiles
overlap (one slowing down while the other speeds up, so the speed never exceeds either's
limit) and the tool rounds the corner within the radius instead of stopping in it. A move
without a blend ends only when the measured TCP has converged on its end point.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

from nodes.executor.motion import Limits, LinearMove, Profile, ToolPose


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


@dataclass(frozen=True, slots=True)
class Rise:
    """Straight up (never down) to ``z`` at the current x, y, yaw."""

    z: float
    limits: Limits
    label: str = "rise"
    blend: float = 0.0


@dataclass(frozen=True, slots=True)
class Grip:
    """Set the finger opening (m) and wait until the fingers are there or stopped on a block.

    ``holds`` says which block is in the fingers afterwards; ``squares`` that they closed on
    it along its other axis just before, at the same TCP (it then stands on the TCP on both
    axes). ``settle_s`` is how long to wait when no finger measurement comes (a gripper that
    reports nothing). ``wait=False`` only sends the command: the fingers move while the script
    goes on.
    """

    opening: float
    settle_s: float
    label: str = ""
    holds: int | None = None
    wait: bool = True
    squares: bool = False


@dataclass(frozen=True, slots=True)
class Brake:
    """Come to rest from ``velocity`` (m/s, x y z) along a straight line, decelerating at
    ``decel`` (m/s^2): how the arm stops safely in the middle of a move."""

    velocity: tuple[float, float, float]
    decel: float
    label: str = "brake"


Step = Move | Rise | Grip | Brake


@dataclass(frozen=True, slots=True)
class Tick:
    """What to publish this tick, and where the script stands."""

    setpoint: ToolPose
    gripper: float | None
    done: bool
    error: str = ""
    label: str = ""
    blocked: bool = False  #: the error is a descent stopped above its end: something below
    stalled: bool = False  #: the error is an opening that stopped short: not let go


#: With no fresh measurement at all, give up after this many convergence timeouts.
STALE_FACTOR = 5.0
#: The gripper is done when its gap is this close to the command (m) ...
GRIP_AT_POSITION = 0.0005
#: ... or, having moved, has moved slower than GRIP_STILL_SPEED over the last GRIP_STILL_S
#: (stopped on a block); never before GRIP_MIN_S (the command must reach the gripper first).
#: Fingers that never move (already stopped on a block) count as done after GRIP_NO_MOTION_S.
GRIP_STILL_SPEED = 0.002  # m/s
GRIP_STILL_S = 0.04
GRIP_MIN_S = 0.04
GRIP_MOVED_M = 0.0005
GRIP_NO_MOTION_S = 0.3
#: Fingers told to open count as stopped only this close to the opening (m): nothing should
#: stop an opening, and one that pauses on a block's face (a pad dragging) must not let the
#: arm rise and tip the block it has just set down.
GRIP_OPEN_SLACK = 0.002
#: An opening still for this long short of it has stalled: something holds the fingers (s).
#: Counted from the command (the fingers stand still before it, and for the gripper's
#: latency after it); a pad that drags on the block pauses for less.
GRIP_STALL_S = 1.0
#: A gripper that neither reaches its opening nor stops within this long has failed (s).
GRIP_TIMEOUT_S = 3.0


@dataclass(slots=True)
class _Blending:
    """A blended move's last part, still added to the setpoints while the next one starts."""

    move: LinearMove
    t0: float

    def offset(self, now: float) -> ToolPose:
        """Where this move still is relative to its end point."""
        p, e = self.move.sample(now - self.t0), self.move.end
        return ToolPose(p.x - e.x, p.y - e.y, p.z - e.z, p.yaw - e.yaw)


def blend_overlap(current: LinearMove, following: LinearMove, radius: float) -> float:
    """How long (s) the two moves may overlap: ``current`` within ``radius`` of its end,
    ``following`` no further than ``radius`` from its start, and no longer than either's
    speed ramp (so one slows down while the other speeds up)."""
    if radius <= 0.0 or current.duration <= 0.0 or following.duration <= 0.0:
        return 0.0
    ending = current.time_left_within(radius)
    starting = following.duration - following.time_left_within(
        max(0.0, following.length - radius))
    return min(ending, starting, current.profile.ramp, following.profile.ramp)


class StepRunner:
    """Plays a step script from ``start`` (the last commanded tool pose)."""

    def __init__(
        self,
        steps: Sequence[Step],
        start: ToolPose,
        convergence_tol: float,
        convergence_timeout_s: float,
        in_safe_box=lambda pose: True,
    ) -> None:
        self.steps = list(steps)
        self.commanded = start  #: the end point of the last move begun (the nominal pose)
        self.tol = convergence_tol
        self.timeout = convergence_timeout_s
        self.in_safe_box = in_safe_box
        self.index = 0
        self._measured_at = 0.0
        self._t0: float | None = None
        self._move: LinearMove | None = None
        self._blending: list[_Blending] = []
        self.gripper: float | None = None
        self._gripper_sent = False
        self._gaps: list[tuple[float, float]] = []
        self.finished_steps: list[Step] = []  #: steps that ended in the last update

    @property
    def finished(self) -> bool:
        return self.index >= len(self.steps)

    @property
    def current_label(self) -> str:
        return "" if self.finished else self.steps[self.index].label

    def update(self, now: float, measured: ToolPose | None, measured_at: float | None = None,
               gaps: Sequence[tuple[float, float]] = ()) -> Tick:
        """Advance to time ``now`` (s); ``measured`` is the latest TCP (None if unknown),
        ``gaps`` the finger gaps (time s, gap m) measured since the last call (none when the
        gripper reports nothing).

        Steps that finish within this call hand their gripper command on, so a ``Grip``
        followed at once by a move still reaches the gripper. ``measured_at`` is the time the
        measurement was taken (default ``now``): a move fails to converge only on
        measurements taken ``convergence_timeout_s`` after it ended, so a late /tcp_pose on a
        loaded machine delays the verdict instead of faking a failure.
        """
        self._measured_at = now if measured_at is None else measured_at
        self._gaps.extend(gaps)
        self.finished_steps = []
        gripper: float | None = None
        while not self.finished:
            step = self.steps[self.index]
            if self._t0 is None:
                refusal = self._begin(step, now)
                if refusal:
                    return Tick(self.commanded, gripper, False, error=refusal, label=step.label)
            tick = self._update_step(step, now, measured)
            if tick.gripper is not None:
                gripper = tick.gripper
            if tick.error or not tick.done:
                return dataclasses.replace(tick, gripper=gripper)
            self.finished_steps.append(step)
            self._advance(step, now)
        setpoint = self._with_blend(self.commanded, now)
        return Tick(setpoint, gripper, not self._blending)

    # --- internals ------------------------------------------------------------------------------
    def _begin(self, step: Step, now: float) -> str:
        """Start ``step``; returns why it is refused (empty when it may run)."""
        self._t0 = now
        self._gripper_sent = False
        self._gaps = self._gaps[-1:]
        if isinstance(step, Brake):
            self._move = _braking_move(self.commanded, step)
        elif isinstance(step, Move | Rise):
            target = self._target(step)
            if not self.in_safe_box(target):
                self._t0 = None
                return (f"step '{step.label}' would go to ({target.x:.3f}, {target.y:.3f}, "
                        f"{target.z:.3f}), outside the safe box")
            self._move = LinearMove.plan(self.commanded, target, step.limits)
        return ""

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
                       and _stopped_on_the_way_down(step.onto, end, measured, self.tol))
            return Tick(end, None, False, label=step.label, blocked=blocked,
                        error=f"step '{step.label}': TCP did not reach ({end.x:.4f}, "
                              f"{end.y:.4f}, {end.z:.4f}) within {self.timeout:.1f} s "
                              f"(off by {off})")
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
        measured = [(s, g) for s, g in self._gaps if s >= t0]
        if not step.wait:
            done = True
        elif not measured:
            done = t >= step.settle_s
        else:
            done = t >= GRIP_MIN_S and _gripper_done(self._gaps, step.opening, t)
        if not done and t >= GRIP_STALL_S and _opening_stalled(measured, step.opening):
            return Tick(self.commanded, gripper, False, label=step.label, stalled=True,
                        error=f"step '{step.label}': the fingers stopped opening at "
                              f"{measured[-1][1] * 1e3:.1f} mm (asked for "
                              f"{step.opening * 1e3:.1f} mm)")
        if not done and measured and t > GRIP_TIMEOUT_S:
            return Tick(self.commanded, gripper, False, label=step.label,
                        error=f"step '{step.label}': the gripper neither reached "
                              f"{step.opening * 1e3:.1f} mm nor stopped within "
                              f"{GRIP_TIMEOUT_S:.0f} s (gap {measured[-1][1] * 1e3:.1f} mm)")
        return Tick(self.commanded, gripper, done, label=step.label)

    def _advance(self, step: Step, now: float) -> None:
        move = self._move
        if move is not None:
            started = now if self._t0 is None else self._t0
            left = move.duration - (now - started)
            if left > 1e-9:  # blended: the rest of this move runs on under the next
                self._blending.append(_Blending(move, now - (move.duration - left)))
            self.commanded = move.end
        self.index += 1
        self._t0 = None
        self._move = None


#: A descent counts as stopped by something below when the TCP came down at least this far
#: (m) over its end's x, y (within BLOCKED_XY_M): an arm that does not move at all is not.
BLOCKED_DROP_M = 0.005
BLOCKED_XY_M = 0.01


def _stopped_on_the_way_down(top: float, end: ToolPose, measured: ToolPose, tol: float
                             ) -> bool:
    """The TCP went down from height ``top`` over ``end`` and stopped above it (it stands on
    something)."""
    over = math.hypot(measured.x - end.x, measured.y - end.y) <= BLOCKED_XY_M
    return over and end.z + tol < measured.z < top - BLOCKED_DROP_M


def _braking_move(start: ToolPose, step: Brake) -> LinearMove:
    """A straight stop from ``step.velocity``: the distance v^2 / (2 a) along it, covered in
    v / a (a constant deceleration, written as the second half of a move)."""
    vx, vy, vz = step.velocity
    speed = math.sqrt(vx * vx + vy * vy + vz * vz)
    if speed < 1e-6:
        return LinearMove(start, start, Profile.fastest(math.inf, math.inf))
    distance = speed * speed / (2.0 * step.decel)
    end = start.offset(vx / speed * distance, vy / speed * distance, vz / speed * distance)
    return BrakingMove(start, end, Profile.fastest(math.inf, math.inf), speed, step.decel)


@dataclass(frozen=True, slots=True)
class BrakingMove(LinearMove):
    """Constant deceleration from ``speed`` to rest over the segment start-end."""

    speed: float = 0.0
    decel: float = 1.0

    @property
    def duration(self) -> float:
        return self.speed / self.decel

    def sample(self, t: float) -> ToolPose:
        t = min(max(t, 0.0), self.duration)
        covered = self.speed * t - 0.5 * self.decel * t * t
        length = self.length
        u = covered / length if length > 0 else 1.0
        if u >= 1.0 - 1e-12:
            return self.end
        a, b = self.start, self.end
        return a.plus(u * (b.x - a.x), u * (b.y - a.y), u * (b.z - a.z), 0.0)


def _opening_stalled(since_command: list[tuple[float, float]], opening: float) -> bool:
    """Told to open, the fingers have stood still for the last half GRIP_STALL_S short of the
    opening. ``since_command``: the (time, gap) samples taken since the command."""
    if len(since_command) < 2:
        return False
    t_last, g_last = since_command[-1]
    span = 0.5 * GRIP_STALL_S
    if g_last >= opening - GRIP_OPEN_SLACK or t_last - since_command[0][0] < span:
        return False
    window = [g for t, g in since_command if t >= t_last - span]
    return max(window) - min(window) <= GRIP_STILL_SPEED * span


def _gripper_done(gaps: list[tuple[float, float]], opening: float, elapsed: float) -> bool:
    """The fingers are at the commanded opening, or have stopped (closing on a block, say;
    an opening only within GRIP_OPEN_SLACK of its end).

    ``gaps`` are (time, gap) samples, the first one taken before the command.
    """
    t_last, g_last = gaps[-1]
    if abs(g_last - opening) <= GRIP_AT_POSITION:
        return True
    if opening > gaps[0][1] + GRIP_MOVED_M and g_last < opening - GRIP_OPEN_SLACK:
        return False  # opening, and still short of it
    first = max((k for k, (t, _) in enumerate(gaps) if t <= t_last - GRIP_STILL_S), default=0)
    window = gaps[first:]  # the last GRIP_STILL_S, from the sample at or before its start
    span = t_last - window[0][0]
    values = [g for _, g in window]
    still = span >= GRIP_STILL_S - 1e-9 and (
        max(values) - min(values) <= GRIP_STILL_SPEED * span)
    moved = abs(g_last - gaps[0][1]) > GRIP_MOVED_M
    return still and (moved or elapsed >= GRIP_NO_MOTION_S)

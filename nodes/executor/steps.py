"""Step scripts: what the executor streams, one step after the other.

A primitive (pick-and-place, push, park) is a list of steps: ``Move`` (a straight
minimum-jerk move to a tool pose), ``Rise`` (straight up to a height from wherever the tool
is), ``Grip`` (set the finger opening and let it settle). ``StepRunner`` plays a script:
fed the time and the measured TCP at every tick, it returns the setpoint (and gripper
command) to publish, so the node stays a thin timer callback and tests can play a script
without ROS. A move starts from the last *commanded* pose, so streamed setpoints are
continuous even when tracking lags; it ends only when the measured TCP has converged.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from nodes.executor.motion import Limits, LinearMove, ToolPose


@dataclass(frozen=True, slots=True)
class Move:
    target: ToolPose
    limits: Limits
    label: str = ""
    converge: bool = True


@dataclass(frozen=True, slots=True)
class Rise:
    """Straight up (or down) to ``z`` at the current x, y, yaw."""

    z: float
    limits: Limits
    label: str = "rise"


@dataclass(frozen=True, slots=True)
class Grip:
    """Set the finger opening; ``holds`` says which block is in the fingers afterwards."""

    opening: float
    settle_s: float
    label: str = ""
    holds: int | None = None


Step = Move | Rise | Grip


@dataclass(frozen=True, slots=True)
class Tick:
    """What to publish this tick, and where the script stands."""

    setpoint: ToolPose
    gripper: float | None
    done: bool
    error: str = ""
    label: str = ""


#: With no fresh measurement at all, give up after this many convergence timeouts.
STALE_FACTOR = 5.0


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
        self.commanded = start
        self.tol = convergence_tol
        self.timeout = convergence_timeout_s
        self.in_safe_box = in_safe_box
        self.index = 0
        self._measured_at = 0.0
        self._t0: float | None = None
        self._move: LinearMove | None = None
        self.gripper: float | None = None
        self._gripper_sent = False

    @property
    def finished(self) -> bool:
        return self.index >= len(self.steps)

    @property
    def current_label(self) -> str:
        return "" if self.finished else self.steps[self.index].label

    def update(self, now: float, measured: ToolPose | None,
               measured_at: float | None = None) -> Tick:
        """Advance by time ``now`` (s); ``measured`` is the latest TCP (None if unknown).

        Steps that finish within this call hand their gripper command on, so a zero-wait
        ``Grip`` followed at once by a move still reaches the gripper. ``measured_at`` is the
        time the measurement was taken (default ``now``): a move fails to converge only on
        measurements taken ``convergence_timeout_s`` after it ended, so a late /tcp_pose on a
        loaded machine delays the verdict instead of faking a failure.
        """
        self._measured_at = now if measured_at is None else measured_at
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
                return Tick(tick.setpoint, gripper, tick.done, tick.error, tick.label)
            self._advance()
        return Tick(self.commanded, gripper, True)

    # --- internals ------------------------------------------------------------------------------
    def _begin(self, step: Step, now: float) -> str:
        """Start ``step``; returns why it is refused (empty when it may run)."""
        self._t0 = now
        self._gripper_sent = False
        if isinstance(step, Move | Rise):
            if isinstance(step, Move):
                target = step.target
            else:  # a rise never goes down (parking from the park pose, say)
                target = self.commanded.with_z(max(step.z, self.commanded.z))
            if not self.in_safe_box(target):
                self._t0 = None
                return (f"step '{step.label}' would go to ({target.x:.3f}, {target.y:.3f}, "
                        f"{target.z:.3f}), outside the safe box")
            self._move = LinearMove.plan(self.commanded, target, step.limits)
        return ""

    def _update_step(self, step: Step, now: float, measured: ToolPose | None) -> Tick:
        t = 0.0 if self._t0 is None else now - self._t0
        if isinstance(step, Grip):
            gripper = None if self._gripper_sent else step.opening
            self._gripper_sent = True
            self.gripper = step.opening
            return Tick(self.commanded, gripper, t >= step.settle_s, label=step.label)
        move = self._move
        assert move is not None
        setpoint = move.sample(t)
        if t < move.duration:
            return Tick(setpoint, None, False, label=step.label)
        self.commanded = move.end
        converge = step.converge if isinstance(step, Move) else True
        if not converge:
            return Tick(move.end, None, True, label=step.label)
        if measured is not None and measured.distance_to(move.end) <= self.tol:
            return Tick(move.end, None, True, label=step.label)
        late = self._measured_at - (self._t0 + move.duration)
        if late > self.timeout or t > move.duration + STALE_FACTOR * self.timeout:
            off = ("unknown" if measured is None
                   else f"{measured.distance_to(move.end) * 1e3:.1f} mm: at "
                        f"({measured.x:.4f}, {measured.y:.4f}, {measured.z:.4f})")
            end = move.end
            return Tick(end, None, False, label=step.label,
                        error=f"step '{step.label}': TCP did not reach ({end.x:.4f}, "
                              f"{end.y:.4f}, {end.z:.4f}) within {self.timeout:.1f} s "
                              f"(off by {off})")
        return Tick(move.end, None, False, label=step.label)

    def _advance(self) -> None:
        self.index += 1
        self._t0 = None
        self._move = None

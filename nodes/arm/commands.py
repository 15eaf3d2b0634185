"""From the arm controller's playback to what the UR driver takes: joint trajectory snippets,
or joint positions.

Pure logic (no ROS). ``JointStreamer`` steps the ``ArmController`` ahead of the arm, in the
controller's own small steps, and cuts what it commands into messages:

* ``snippet(now)``: the next ``horizon_s`` of commanded joint positions and velocities as a
  ``trajectory_msgs/JointTrajectory`` for ur_robot_driver's ``scaled_joint_trajectory_controller``,
  stamped ``now``, one point every ``point_spacing_s``, the last at rest (the controller refuses
  a trajectory that ends moving), then held ``LATE_HOLD_S`` longer. Stamped, so the controller
  plays it aligned with this node's clock: unstamped snippets (started on receipt, a few ms of
  jitter each) left placements and pushes in the cell up to 5 mm off (2 of 2 scenes failed
  against 2 of 2 done, stamped). Each one replaces the last on the controller, which plays it
  from the state the arm is in, so the arm follows the controller's playback ``horizon_s``
  ahead of it being needed, and comes to rest where its motion ends if the snippets stop
  coming. The controller interpolates between points in C++ at its own rate (500 Hz on a
  UR), which a Python node cannot match; this is why trajectories are the default.
* ``position(now)``: the commanded joints one period ahead, for the ``forward_position_controller``
  (servoj, one position per message; rclpy's timing makes this coarser: the benchmark
  ``densepack-bench arm`` measures both).

While the executor streams, the controller is never stepped past the point where its playback
would need a setpoint newer than the newest (it would have to stop there), so the snippets'
end, which the sim paces its clock on, follows the executor: the sim never outruns the
commander. When the arm stands still nothing is sent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodes.arm.controller import STREAM_GAP_S, ArmController

#: Samples this close (rad) count as the arm standing still.
AT_REST_RAD = 1e-9
#: Every snippet ends holding its last position this long (s) after its motion: a snippet that
#: arrives after its motion's end (this node's clock behind the controller's, as under load:
#: seen 1-8 times a scene in the cell benchmark) is played from where it stands instead of
#: refused whole, which stopped the arm short, then lunged it on with the next one. The
#: sim paces its clock on the motion's end, not the hold's.
LATE_HOLD_S = 0.5


@dataclass(frozen=True, slots=True)
class TrajectorySnippet:
    """A JointTrajectory's content in the controller's joint order (``nodes.robot.ur10e``)."""

    start_s: float  #: header stamp (s)
    times: tuple[float, ...]  #: each point's time_from_start (s)
    positions: np.ndarray  #: (n, 6) rad
    velocities: np.ndarray  #: (n, 6) rad/s, the last row zero

    @property
    def end_s(self) -> float:
        return self.start_s + self.times[-1]

    def as_points(self) -> list[tuple[float, list[float], list[float], list[float], list[float]]]:
        """(time_from_start, positions, velocities, accelerations, effort) per point: a
        JointTrajectory's points as the sim's trajectory controller takes them decoded."""
        return [(t, q.tolist(), v.tolist(), [], [])
                for t, q, v in zip(self.times, self.positions, self.velocities, strict=True)]


class JointStreamer:
    """Runs the arm controller ahead of the arm and hands out its commands."""

    def __init__(self, controller: ArmController, step_s: float = 1.0 / 240.0,
                 horizon_s: float = 0.08, point_spacing_s: float = 0.02) -> None:
        if not 0.0 < step_s <= point_spacing_s <= horizon_s:
            raise ValueError(f"need 0 < step_s ({step_s}) <= point_spacing_s "
                             f"({point_spacing_s}) <= horizon_s ({horizon_s})")
        self.controller = controller
        self.step_s = step_s
        self.horizon_s = horizon_s
        self.point_spacing_s = point_spacing_s
        self.newest_setpoint: float | None = None  #: stamp of the newest accepted setpoint (s)
        self._samples: list[tuple[float, np.ndarray, np.ndarray]] = []
        self._quiet = False  # the last snippet sent ended at rest and nothing moved since

    def reset(self, q: np.ndarray, now: float) -> None:
        """Start again from the arm measured at ``q`` (a protective stop, a restart)."""
        self.controller.reset(q)
        self.controller.now = now
        self.newest_setpoint = None
        self._samples = []
        self._quiet = False

    def on_setpoint(self, stamp_s: float | None) -> None:
        if stamp_s is not None and (self.newest_setpoint is None
                                    or stamp_s > self.newest_setpoint):
            self.newest_setpoint = stamp_s
        self._quiet = False

    def _starved(self, now: float) -> bool:
        """The playback stands on the newest setpoint while the executor still streams: no
        command can be computed beyond it until the next setpoint comes."""
        c = self.controller
        newest = self.newest_setpoint
        return (c.playback is not None and newest is not None
                and now - newest <= STREAM_GAP_S and c.playback >= newest - 1e-9)

    def _advance(self, now: float, end: float) -> None:
        """Step the controller to ``end`` (never back, and no further than its playback has
        setpoints for); keep the samples after ``now``."""
        c = self.controller
        if c.now < now - self.step_s:  # it fell behind (a pause): it cannot command the past
            c.now = now
        while c.now + self.step_s <= end + 1e-9 and not self._starved(now):
            q, v = c.step(self.step_s)
            self._samples.append((c.now, q, v))
            if any(abs(x) > AT_REST_RAD * 1e3 for x in v):
                self._quiet = False
        self._samples = [s for s in self._samples if s[0] > now + 1e-9]

    def snippet(self, now: float) -> TrajectorySnippet | None:
        """The trajectory to send at ``now`` (s), or None: nothing to move."""
        self._advance(now, now + self.horizon_s)
        if not self._samples:
            return None
        moving = not self.controller.settled or any(
            float(np.max(np.abs(q - self._samples[-1][1]))) > AT_REST_RAD
            for _, q, _ in self._samples)
        if not moving and self._quiet:
            return None
        self._quiet = not moving
        picked = self._pick(now)
        times = tuple(t - now for t, _, _ in picked)
        positions = np.array([q for _, q, _ in picked])
        velocities = np.array([v for _, _, v in picked])
        velocities[-1] = 0.0
        times = (*times, times[-1] + LATE_HOLD_S)
        positions = np.vstack([positions, positions[-1]])
        velocities = np.vstack([velocities, velocities[-1]])
        return TrajectorySnippet(now, times, positions, velocities)

    def _pick(self, now: float) -> list[tuple[float, np.ndarray, np.ndarray]]:
        """Samples one point spacing apart from ``now``, and the last one."""
        picked, due = [], now + self.point_spacing_s
        for sample in self._samples:
            if sample[0] >= due - 1e-9:
                picked.append(sample)
                due = sample[0] + self.point_spacing_s
        if not picked or picked[-1] is not self._samples[-1]:
            picked.append(self._samples[-1])
        last_t, last_q, last_v = picked[-1]
        if last_t < now + self.horizon_s - 1e-9 and not np.any(last_v):
            # The playback stands still (a starved stream, or at the end of a move): hold there
            # to the horizon, so the snippet has not ended by the time it arrives late.
            picked.append((now + self.horizon_s, last_q, np.zeros_like(last_q)))
        elif last_t < now + self.point_spacing_s - 1e-9:
            picked.append((now + self.point_spacing_s, last_q, np.zeros_like(last_q)))
        return picked

    def position(self, now: float, period_s: float) -> np.ndarray:
        """The joints commanded ``period_s`` from ``now``, for a forward position command."""
        target = now + period_s
        self._advance(now, target)
        if not self._samples:
            return self.controller.q_cmd.copy()
        best = min(self._samples, key=lambda s: abs(s[0] - target))
        return best[1].copy()


def setpoint_tick_gap(now: float, ticked_at: float, command_rate_hz: float) -> float:
    """The least time (s, node clock) since the last command for a new setpoint to send the
    next at once: half a tick, so a setpoint and the timer do not both send one; but none on a
    clock that has not moved since the last command. The sim holds its clock at the end of
    the last snippet until a longer one comes, so no timer tick comes either (debounced, the
    sim waited out its stall patience, 0.5 s of wall time, each time a late executor tick let
    the snippets run out)."""
    return 0.0 if now == ticked_at else 0.5 / command_rate_hz


def stream_time_or_nan(controller: ArmController) -> float:
    """The stream time the arm is commanded at, NaN for none (a message field)."""
    value = controller.stream_time
    return math.nan if value is None else value

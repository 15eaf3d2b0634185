"""The UR controller's state as its driver reports it, and its dashboard: the sim's stand-in.

Pure logic (no PyBullet, no ROS). A real UR10e running ur_robot_driver's External Control
program reports a safety mode, a robot mode and whether the program runs; the teach pendant's
speed slider scales every motion; the dashboard server takes ``stop``, ``play``,
``unlock_protective_stop`` and the rest, and answers each in words. The sim keeps the same
state here and the node publishes and serves it under the driver's names:

* A protective stop (the world's force guard calls ``protective_stop``) sets the safety mode
  to PROTECTIVE_STOP and pauses the program: no motion command is executed until the stop is
  unlocked (not sooner than ``unlock_after_s`` after it, as a UR refuses) *and* the program is
  played again. ``play`` starts it ``PROGRAM_START_S`` later.
* ``stop`` stops the program; ``pause`` pauses it (both: no motion); ``power_off`` powers the
  arm off (no motion until ``power_on`` and ``brake_release``).
* ``speed_scaling`` is the slider while the program runs (what the scaled trajectory
  controller plays at), reported in percent on the driver's topic.
"""

from __future__ import annotations

from dataclasses import dataclass

from msgs_py.drivers import (
    ROBOT_IDLE,
    ROBOT_POWER_OFF,
    ROBOT_RUNNING,
    SAFETY_MOVING,
    SAFETY_NORMAL,
    SAFETY_PROTECTIVE_STOP,
    safety_mode_name,
)

#: A played program runs this long after ``play`` (s): the External Control program connects.
PROGRAM_START_S = 0.5
#: A UR refuses to unlock a protective stop sooner than this after it (s).
UNLOCK_AFTER_S = 5.0


@dataclass(frozen=True, slots=True)
class DashboardAnswer:
    """A dashboard call's outcome: ``success`` and the server's words."""

    success: bool
    message: str


class RobotState:
    """Safety mode, robot mode, program and slider of the simulated UR."""

    def __init__(self, speed_slider: float = 1.0, unlock_after_s: float = UNLOCK_AFTER_S
                 ) -> None:
        self.unlock_after_s = float(unlock_after_s)
        self.set_speed_slider(speed_slider)
        self.reset(0.0)

    def reset(self, now: float) -> None:
        """Powered, brakes released, the program running (as the cell starts)."""
        self.safety_mode = SAFETY_NORMAL
        self.robot_mode = ROBOT_RUNNING
        self.program_running = True
        self.stop_reason = ""
        self._stopped_at = -1.0
        self._starts_at: float | None = None
        self.now = now

    def set_speed_slider(self, fraction: float) -> None:
        if not 0.0 <= fraction <= 1.0:
            raise ValueError(f"speed slider {fraction} must be in [0, 1]")
        self.speed_slider = float(fraction)

    @property
    def can_move(self) -> bool:
        """Motion commands are executed: a moving safety mode, powered, the program running."""
        return (self.safety_mode in SAFETY_MOVING and self.robot_mode == ROBOT_RUNNING
                and self.program_running)

    @property
    def speed_scaling(self) -> float:
        """What the scaled trajectory controller plays at (fraction): the slider."""
        return self.speed_slider

    def step(self, now: float) -> None:
        self.now = now
        if self._starts_at is not None and now >= self._starts_at:
            self._starts_at = None
            if self.safety_mode in SAFETY_MOVING and self.robot_mode == ROBOT_RUNNING:
                self.program_running = True

    # --- what happens to the robot ------------------------------------------------------------
    def protective_stop(self, now: float, why: str) -> None:
        self.safety_mode = SAFETY_PROTECTIVE_STOP
        self.program_running = False
        self._starts_at = None
        self.stop_reason = why or "protective stop"
        self._stopped_at = now

    # --- the dashboard --------------------------------------------------------------------------
    def dashboard(self, command: str, now: float) -> DashboardAnswer:
        """One dashboard command (``unlock_protective_stop``, ``play`` ...), answered as a
        UR's dashboard server answers it."""
        self.step(now)
        handler = {
            "unlock_protective_stop": self._unlock,
            "close_safety_popup": lambda: DashboardAnswer(True, "closing safety popup"),
            "stop": self._stop,
            "pause": self._pause,
            "play": self._play,
            "power_on": self._power_on,
            "power_off": self._power_off,
            "brake_release": self._brake_release,
        }.get(command)
        if handler is None:
            return DashboardAnswer(False, f"unknown dashboard command '{command}'")
        return handler()

    def _unlock(self) -> DashboardAnswer:
        if self.safety_mode != SAFETY_PROTECTIVE_STOP:
            return DashboardAnswer(
                False, f"Cannot unlock protective stop: the safety mode is "
                       f"{safety_mode_name(self.safety_mode)}")
        if self.now - self._stopped_at < self.unlock_after_s:
            return DashboardAnswer(
                False, f"Cannot unlock protective stop until {self.unlock_after_s:.0f}s after "
                       f"occurrence. Always inspect cause of protective stop before unlocking")
        self.safety_mode = SAFETY_NORMAL
        self.stop_reason = ""
        return DashboardAnswer(True, "Protective stop releasing")

    def _stop(self) -> DashboardAnswer:
        self.program_running = False
        self._starts_at = None
        return DashboardAnswer(True, "Stopped")

    def _pause(self) -> DashboardAnswer:
        self.program_running = False
        self._starts_at = None
        return DashboardAnswer(True, "Pausing program")

    def _play(self) -> DashboardAnswer:
        if self.safety_mode not in SAFETY_MOVING or self.robot_mode != ROBOT_RUNNING:
            return DashboardAnswer(False, "Failed to execute: play")
        if not self.program_running and self._starts_at is None:
            self._starts_at = self.now + PROGRAM_START_S
        return DashboardAnswer(True, "Starting program")

    def _power_on(self) -> DashboardAnswer:
        if self.robot_mode == ROBOT_POWER_OFF:
            self.robot_mode = ROBOT_IDLE
        return DashboardAnswer(True, "Powering on")

    def _power_off(self) -> DashboardAnswer:
        self.robot_mode = ROBOT_POWER_OFF
        self.program_running = False
        self._starts_at = None
        return DashboardAnswer(True, "Powering off")

    def _brake_release(self) -> DashboardAnswer:
        if self.robot_mode == ROBOT_POWER_OFF:
            return DashboardAnswer(False, "Failed to execute: brake release (powered off)")
        self.robot_mode = ROBOT_RUNNING
        return DashboardAnswer(True, "Brake releasing")

"""Playing one script at a time on the arm's setpoint stream, and what its end leads to."""

from __future__ import annotations

from collections.abc import Sequence

from nodes.executor.config import ExecutorConfig
from nodes.executor.decisions import Script, Then
from nodes.executor.motion import ToolPose
from nodes.executor.steps import Step, StepRunner, Tick

#: A tick advances the running script by at most this many tick periods (see ``advance``).
MAX_TICKS_PER_STEP = 2.0
#: Deceleration when a fault stops the arm mid-move (m/s^2).
BRAKE_DECEL = 5.0


class Player:
    """The script the arm follows (if any), what its end leads to, and the last setpoint."""

    def __init__(self, cfg: ExecutorConfig) -> None:
        self.cfg = cfg
        self.runner: StepRunner | None = None
        self.then: Then | None = None
        self.commanded: ToolPose | None = None  #: the last setpoint streamed
        self._lag = 0.0  # how far the runner's script time trails the clock (s)
        self._last_run: float | None = None

    @property
    def busy(self) -> bool:
        return self.runner is not None

    @property
    def step(self) -> Step | None:
        """The step playing now (None: no script)."""
        return None if self.runner is None else self.runner.current_step

    @property
    def finished_steps(self) -> list[Step]:
        """The steps that ended in the last ``advance``."""
        return [] if self.runner is None else self.runner.finished_steps

    @property
    def nominal(self) -> ToolPose:
        """Where the script's last move begun ends (the pose it holds the tool at)."""
        assert self.runner is not None
        return self.runner.commanded

    def start(self, script: Script, now: float, here: ToolPose | None) -> None:
        """Play ``script`` from the last setpoint (or ``here``, the measured TCP, before the
        first); a braking script first stops the current motion along its path."""
        if script.brake and self.runner is not None:
            self.runner.brake(now - self._lag, BRAKE_DECEL, script.steps)
        else:
            self._lag = 0.0
            self._last_run = None
            start = self.commanded or here
            assert start is not None
            self.runner = StepRunner(script.steps, start, self.cfg.convergence_tol,
                                     self.cfg.convergence_timeout_s, self.cfg.in_safe_box)
        self.then = script.then

    def advance(self, now: float, tcp: ToolPose | None, tcp_stamp: float | None,
                gaps: Sequence[tuple[float, float]], gripper_reports: bool = False) -> Tick:
        """The script at ``now``, given the measured TCP (taken at ``tcp_stamp``) and the
        finger gaps (time, gap) measured since the last tick (``gripper_reports``: the
        gripper has reported before, see ``StepRunner.update``).

        Script time advances at most MAX_TICKS_PER_STEP ticks per tick: an executor held up
        (a loaded machine) resumes its trajectory where it was, so consecutive setpoints
        stay close in space, never a chord across a corner of the path."""
        assert self.runner is not None
        step = 0.0 if self._last_run is None else now - self._last_run
        self._lag += max(0.0, step - MAX_TICKS_PER_STEP / self.cfg.rate_hz)
        self._last_run = now
        lag = self._lag
        measured_at = None if tcp_stamp is None else tcp_stamp - lag
        tick = self.runner.update(now - lag, tcp, measured_at, [(t - lag, g) for t, g in gaps],
                                  gripper_reports)
        self.commanded = tick.setpoint
        return tick

    def retry(self, before: Sequence[Step]) -> None:
        """Play ``before``, then the current step again (``StepRunner.retry_current``)."""
        assert self.runner is not None
        self.runner.retry_current(before)

    def finish(self) -> Then:
        """The script has run to its end: what that leads to."""
        assert self.then is not None
        then = self.then
        self.drop()
        return then

    def drop(self) -> None:
        """Stream nothing more of the script."""
        self.runner, self.then = None, None

"""Playing one script at a time on the arm's setpoint stream, and what its end leads to."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from nodes.executor.config import ExecutorConfig
from nodes.executor.decisions import Script, Then
from nodes.executor.motion import ToolPose
from nodes.executor.steps import Step, StepRunner, Tick

#: A tick advances the running script by at most this many tick periods (see ``advance``) ...
MAX_TICKS_PER_STEP = 2.0
#: ... unless it comes at most this long (s) after the last: then it streams the ticks it
#: missed as well, each at its own time, so the script keeps the clock's pace. The sim's
#: lockstep lets its clock run up to about a servo delay past the newest setpoint before it
#: waits, so a tick that computed longer (a look decided, a placement published) comes 2-7
#: periods late, 46 times in a default run: charged to the script as lag, 1.8 s of its 54 s.
MAX_BACKFILL_S = 0.2
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
        self._finished: list[Step] = []

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
        return [] if self.runner is None else self._finished

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

        A tick up to MAX_BACKFILL_S after the last plays the ticks it missed first, each
        with what had been measured by its time, and returns their setpoints in
        ``Tick.missed`` (to be streamed before its own, stamped with their times): the arm
        plays them a servo delay behind, so the path is kept and no time is lost. A later
        one (an executor held up for longer: the arm has stopped at the end of its stream)
        advances script time by at most MAX_TICKS_PER_STEP ticks: it resumes its
        trajectory where it was, so consecutive setpoints stay close in space, never a chord
        across a corner of the path."""
        assert self.runner is not None
        period = 1.0 / self.cfg.rate_hz
        missed: list[float] = []
        if self._last_run is not None:
            step = now - self._last_run
            if step <= MAX_BACKFILL_S:
                missed = [self._last_run + k * period
                          for k in range(1, round(step / period))]
            else:
                self._lag += max(0.0, step - MAX_TICKS_PER_STEP * period)
        self._last_run = now
        self._finished = []
        streamed: list[tuple[float, ToolPose]] = []
        gripper: float | None = None  # the newest gripper command of the ticks played
        for t in missed:  # each with the measurements taken by its time
            known = tcp_stamp is not None and tcp_stamp <= t
            tick = self._update(t, tcp if known else None, tcp_stamp if known else None,
                                [g for g in gaps if g[0] <= t], gripper_reports)
            gaps = [g for g in gaps if g[0] > t]
            gripper = gripper if tick.gripper is None else tick.gripper
            if tick.fault is not None or tick.done:
                return dataclasses.replace(tick, gripper=gripper, missed=tuple(streamed))
            streamed.append((t, tick.setpoint))
        tick = self._update(now, tcp, tcp_stamp, gaps, gripper_reports)
        gripper = gripper if tick.gripper is None else tick.gripper
        return dataclasses.replace(tick, gripper=gripper, missed=tuple(streamed))

    def _update(self, now: float, tcp: ToolPose | None, tcp_stamp: float | None,
                gaps: Sequence[tuple[float, float]], gripper_reports: bool) -> Tick:
        """One runner update at ``now`` on the clock (script time trails it by the lag)."""
        assert self.runner is not None
        lag = self._lag
        measured_at = None if tcp_stamp is None else tcp_stamp - lag
        tick = self.runner.update(now - lag, tcp, measured_at, [(t - lag, g) for t, g in gaps],
                                  gripper_reports)
        self._finished.extend(self.runner.finished_steps)
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

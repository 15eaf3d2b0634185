"""Getting a UR out of a protective stop: what its driver needs, in order.

Pure logic (no ROS): the arm node makes the calls ``UnlockSequence`` names and reports their
answers. After a protective stop the UR's program is paused, so unlocking alone does not make
the arm move again: the dashboard's ``close_safety_popup`` and ``unlock_protective_stop``,
then ``stop`` and ``play`` to restart ur_robot_driver's External Control program, then waiting
until the driver reports ``robot_program_running`` (its robot_state_helper does the same).
A UR refuses the unlock sooner than 5 s after the stop: the sequence then fails with the
dashboard's words and the executor asks again.
"""

from __future__ import annotations

from dataclasses import dataclass, field

#: The dashboard calls, in order.
UNLOCK_CALLS = ("close_safety_popup", "unlock_protective_stop", "stop", "play")


@dataclass
class UnlockSequence:
    """One attempt: the calls in turn, then the wait for the program."""

    started_s: float
    program_timeout_s: float = 5.0
    _next: int = 0
    _played_at: float | None = None
    failure: str = ""
    done: bool = False
    answers: list[str] = field(default_factory=list)

    @property
    def finished(self) -> bool:
        return self.done or bool(self.failure)

    def next_call(self) -> str | None:
        """The dashboard call to make now (None: none, waiting or finished)."""
        if self.finished or self._next >= len(UNLOCK_CALLS):
            return None
        return UNLOCK_CALLS[self._next]

    def on_answer(self, call: str, success: bool, message: str, now: float) -> None:
        """The dashboard answered ``call``. A refused call ends the attempt, except the popup
        (there may be none to close)."""
        if self.finished or call != self.next_call():
            return
        self.answers.append(f"{call}: {message}")
        if not success and call != "close_safety_popup":
            self.failure = f"{call} refused: {message}"
            return
        self._next += 1
        if call == "play":
            self._played_at = now

    def on_program_running(self, running: bool, now: float) -> None:
        """What the driver reports; after ``play`` it must report the program running within
        ``program_timeout_s``."""
        if self.finished or self._played_at is None:
            return
        if running:
            self.done = True
        elif now - self._played_at > self.program_timeout_s:
            self.failure = (f"the program did not start within {self.program_timeout_s:.0f} s "
                            "of play")

    def on_timeout(self, now: float, call_timeout_s: float) -> None:
        """A call not answered within ``call_timeout_s`` of the attempt's start fails it."""
        if not self.finished and self._played_at is None \
                and now - self.started_s > call_timeout_s:
            self.failure = (f"the dashboard did not answer {self.next_call()} within "
                            f"{call_timeout_s:.0f} s")

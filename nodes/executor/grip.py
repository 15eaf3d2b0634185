"""When a gripper command is done, from the finger gaps measured since it was sent.

The fingers are done at the commanded opening, or once they stand still after moving
(closed on a block); an opening must get near its end (a pad dragging on the block only
pauses it). An opening that stands still short of its end for ``GRIP_STALL_S`` has stalled
(the fingers still press on the block), and a command neither reached nor stopped on within
``GRIP_TIMEOUT_S`` has failed.
"""

from __future__ import annotations

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
#: A gripper that neither reaches its opening nor stops within this long has failed (s),
#: counted from its first report after the command.
GRIP_TIMEOUT_S = 3.0
#: A gripper that has reported before and reports nothing for this long after a command is
#: gone (s): its node died and was not brought back (a respawn takes a few seconds).
GRIPPER_SILENT_S = 20.0
#: A pause in the gripper's reports this long is its node gone (s): what it reports after
#: one comes from a node that started anew (and got the command again).
GRIPPER_PAUSE_S = 1.0


def since_pause(samples: list[tuple[float, float]], now: float) -> list[tuple[float, float]]:
    """The (time, gap) samples since the last pause of GRIPPER_PAUSE_S in them; none while
    the gripper is in one now."""
    if not samples or now - samples[-1][0] > GRIPPER_PAUSE_S:
        return []
    start = 0
    for k in range(1, len(samples)):
        if samples[k][0] - samples[k - 1][0] > GRIPPER_PAUSE_S:
            start = k
    return samples[start:]


def opening_stalled(since_command: list[tuple[float, float]], opening: float) -> bool:
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


def gripper_done(gaps: list[tuple[float, float]], opening: float, elapsed: float,
                 before: float | None = None) -> bool:
    """The fingers are at the commanded opening, or have stopped (closing on a block, say;
    an opening only within GRIP_OPEN_SLACK of its end).

    ``gaps`` are (time, gap) samples, the first one taken before the command. ``before``:
    the opening commanded before this one (None: none known). Fingers that stop there have
    finished that command, not this one: a pick's fingers still coming in to the release
    opening as the tool converged at grasp height stopped there before the grip reached the
    gripper, and the grip was judged a miss on nothing at 58.8 mm (16 blocks, seed 7).
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
    moved = abs(g_last - gaps[0][1]) > GRIP_MOVED_M and (
        before is None or abs(g_last - before) > GRIP_MOVED_M)
    return still and (moved or elapsed >= GRIP_NO_MOTION_S)

"""The UR's protective stop, as the sim makes it: the force on the robot past a limit.

Part of a ``SimWorld`` (``world.guard``). The UR10e's controller knows the force on its tool
from its wrist force/torque sensor and joint currents; the sim sums the contact forces blocks
and table exert on the robot. The physics step that sum passes ``tool_force_limit``, the
robot's state turns protective stop (``RobotState``: the program pauses, the arm holds where
it is measured). After an unlock the arm may back off what stopped it: pressing harder than it
did stops it again, until the force has stayed below half the limit for ``BACK_OFF_S``.
"""

from __future__ import annotations

import numpy as np

from nodes.sim.bodies import WorldBodies
from nodes.sim.robot_state import RobotState

#: After an unlock the arm is off what stopped it once the force has stayed below half the
#: limit this long (s): a block pressed into the table springs back for a few steps.
BACK_OFF_S = 0.1


class ForceGuard:
    def __init__(self, world: WorldBodies, robot_state: RobotState) -> None:
        self.world = world
        self.robot_state = robot_state
        self.reset()

    def reset(self) -> None:
        self.protective_stops = 0
        #: unlocked while still in contact: the force that stops the arm again (N), until the
        #: force has fallen below the limit
        self._backing_off: float | None = None
        self._off_since: float | None = None

    def tool_force(self) -> np.ndarray:
        """The net force (N, world) blocks and table exert on the robot: what the UR10e's
        wrist force/torque sensor and joint currents tell its controller, with the tool's
        own weight (set as the payload) taken out. A grip's squeeze cancels in the sum."""
        w = self.world
        total = np.zeros(3)
        for pt in w.client.getContactPoints(bodyA=w.robot):
            if pt[2] == w.robot:
                continue
            total += (pt[9] * np.asarray(pt[7]) + pt[10] * np.asarray(pt[11])
                      + pt[12] * np.asarray(pt[13]))
        return total

    def check(self) -> None:
        """After a physics step: a protective stop the step the force passes the limit, the
        arm holding where it is, pressing no further (measured: a finger coming down at
        0.37 m/s on a block's edge met 298 N in one step and tipped it within 0.1 s)."""
        w = self.world
        force = float(np.linalg.norm(self.tool_force()))
        limit = w.config.tool_force_limit
        if self._backing_off is not None:  # unlocked in contact: free to move off it ...
            if force > 0.5 * limit:
                self._off_since = None
            elif self._off_since is None:
                self._off_since = w.time_s
            if self._off_since is not None and w.time_s - self._off_since >= BACK_OFF_S:
                self._backing_off = None  # off it for good (a pressed block springs back)
                return
            limit = self._backing_off  # ... not to press harder
        if force > limit:
            tcp = w.tcp_pose()[0]
            why = (f"{force:.0f} N on the robot at TCP ({tcp[0]:.3f}, {tcp[1]:.3f}, "
                   f"{tcp[2]:.3f}), limit {limit:.0f} N")
            self.robot_state.protective_stop(w.time_s, why)
            self.protective_stops += 1

    def unlocked(self) -> None:
        """The dashboard unlocked the stop: the arm may back off what it still presses on."""
        self._backing_off = float(np.linalg.norm(self.tool_force())) \
            + self.world.config.tool_force_limit
        self._off_since = None

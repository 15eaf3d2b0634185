"""The arm-based camera calibration: the arm sets one block down at known poses.

A real cell has no board of blocks at surveyed poses, but it has an arm that knows where its
TCP is. The routine (``ArmCalibration``, ROS-free; ``densepack-calibrate`` with
``mode:=arm`` runs it on the graph):

1. **Locate**: a frame with the arm out of view; the block is found with the *current*
   calibration. That one may be off by a centimetre on the table (0.5 degrees of camera
   tilt alone shift it 10 mm at 1.2 m), more than the 9 mm a plan's grasp leaves on each
   side, so this first grasp opens ``first_grasp_clearance`` wider on each side.
2. **Centre the block in the fingers**: a 2F-85 centres what it grips along its closing axis
   only. So the arm picks the block and sets it down where it was (now centred along the
   first closing axis), then picks it again with the closing axis turned 90 degrees
   (centred along the second one, and still along the first): from now on the block sits
   on the TCP, faces aligned with the fingers (block yaw = tool yaw modulo 90 degrees).
3. **Placements**: the arm carries it to each of ``placements`` in turn, releases it, moves
   to the look pose (outside the workspace's robot-side edge, out of the camera's view) and
   the camera takes ``frames`` frames. The block's pose there is the *measured* TCP at
   release: x, y, and its yaw up to the quarter turn, which the detection tells apart. The
   next transfer grips it there (exactly where it is known to be).
4. **Solve**: every frame's tag corners against the corners of the block at its placement
   (``calibrate_views``, one group per placement), after which the arm parks.

The arm moves by the executor's own step scripts (``nodes.executor.primitives``, played by
``StepRunner``): the same motions, heights and speeds as a pick-and-place of a plan.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum

from msgs_py import BlockPose, PickPlace, Pose2D, Workspace
from msgs_py.cell import GripperGeometry
from msgs_py.poses import wrap_angle
from nodes.common.params import configs_from_parameters, param, read_params_file
from nodes.common.paths import config_path
from nodes.detector.calibration import View
from nodes.detector.tags import TagDetection
from nodes.executor.config import ExecutorConfig
from nodes.executor.motion import ToolPose
from nodes.executor.primitives import look_steps, park_steps, pick_place_steps
from nodes.executor.steps import Grip, Step, StepRunner

#: Default placements (x, y, theta): the corners, edge middles and centre of the default
#: workspace (0.45-0.95 x -0.35-0.35 m) less a block's reach, at varied yaws.
DEFAULT_PLACEMENTS = (
    0.52, -0.27, 0.3, 0.52, 0.0, -0.5, 0.52, 0.27, 0.9,
    0.70, -0.27, -0.2, 0.70, 0.0, 0.6, 0.70, 0.27, -0.9,
    0.88, -0.27, 0.7, 0.88, 0.0, -0.3, 0.88, 0.27, 0.2,
)
#: The 2F-85's stroke leaves at most this much beside a 50.8 mm block on each side (m).
MAX_FIRST_CLEARANCE = 0.017
#: A tick advances the running script by at most this many tick periods, as the executor's:
#: a routine held up (a loaded machine) resumes its trajectory where it was instead of
#: sending a setpoint far along the path (a chord across a corner).
MAX_TICKS_PER_STEP = 2.0
#: Ask the camera again after this long without an accepted frame (s).
FRAME_RETRY_S = 1.0


@dataclass(frozen=True)
class ArmRoutineConfig:
    """``densepack-calibrate`` parameters of the arm-based routine (``arm.*``)."""

    placements: tuple = param(
        list(DEFAULT_PLACEMENTS), "where the arm sets the block down: x, y, theta triples "
        "(world, m and rad), spread over the workspace", unit="m, rad")
    frames: int = param(2, "frames taken with the block at each placement")
    block_id: int = param(-1, "tag id of the block the arm uses (-1: the one block the camera "
                          "sees)")
    workspace: tuple = param(
        [0.45, 0.95, -0.35, 0.35], "x_min, x_max, y_min, y_max: the arm looks from outside "
        "its robot-side edge (x_min - the executor's look_offset)", unit="m")
    first_grasp_clearance: float = param(
        0.016, "finger clearance on each side of the block for the first grasp, where the "
        "block is only known from the current calibration (the 2F-85 opens 85 mm: at most "
        "17 mm beside a 50.8 mm block)", unit="m")
    frame_timeout_s: float = param(
        20.0, "give up when no usable frame came this long after asking (ROS time)", unit="s")
    timeout_s: float = param(900.0, "give up when the routine has not finished by then (wall "
                             "time)", unit="s")
    executor_params_file: str = param(
        "executor.yaml", "the executor's parameter file: heights, speeds, look pose (relative "
        "paths are under config/)")

    def __post_init__(self) -> None:
        if len(self.placements) % 3 or len(self.placements) < 12:
            raise ValueError("parameter 'arm.placements': needs x, y, theta triples, at least "
                             f"4 of them; got {len(self.placements)} numbers")
        if self.frames < 1:
            raise ValueError("parameter 'arm.frames': must be >= 1")
        if len(self.workspace) != 4:
            raise ValueError("parameter 'arm.workspace': needs x_min, x_max, y_min, y_max")
        if not 0.0 < self.first_grasp_clearance <= MAX_FIRST_CLEARANCE:
            raise ValueError("parameter 'arm.first_grasp_clearance': must be in (0, "
                             f"{MAX_FIRST_CLEARANCE}] m")
        if not self.frame_timeout_s > 0.0:
            raise ValueError("parameter 'arm.frame_timeout_s': must be > 0")

    @property
    def poses(self) -> list[Pose2D]:
        p = self.placements
        return [Pose2D(p[k], p[k + 1], p[k + 2]) for k in range(0, len(p), 3)]

    def executor_config(self) -> ExecutorConfig:
        """The executor's parameters from ``executor_params_file``.

        Raises:
            ValueError: an unknown parameter or a bad value (names the file).
            OSError: the file cannot be read.
        """
        file = config_path(self.executor_params_file)
        values = read_params_file(file, node_name="executor")
        (config,) = configs_from_parameters((("", ExecutorConfig),), values, str(file))
        return config


class Phase(Enum):
    LOCATE = "locate"  # waiting for a frame that shows the block
    MOVE = "move"  # a step script runs
    LOOK = "look"  # the arm is out of view: frames of the block at its placement
    DONE = "done"
    FAILED = "failed"


@dataclass
class Placement:
    """One place the block was set down: the commanded pose, the measured TCP at release,
    the block's known pose, and the views taken there."""

    index: int
    target: Pose2D
    tcp: ToolPose | None = None
    block: BlockPose | None = None
    views: list[View] = field(default_factory=list)
    perceived: list[BlockPose] = field(default_factory=list)  #: with the old calibration


@dataclass
class Outputs:
    setpoint: ToolPose | None = None
    gripper: float | None = None
    want_frame: bool = False
    log: list[str] = field(default_factory=list)


def snap_yaw(tool_yaw: float, seen_theta: float) -> float:
    """The yaw of a block the fingers squared up: ``tool_yaw`` plus the whole quarter turns
    that bring it nearest the yaw the camera sees (the tag tells the quarter apart)."""
    quarter = math.pi / 2.0
    return wrap_angle(tool_yaw + quarter * round(math.remainder(seen_theta - tool_yaw,
                                                                2.0 * math.pi) / quarter))


class ArmCalibration:
    """The routine as a state machine: feed it the TCP, finger gaps and frames; ``tick`` says
    what to publish. ``views()`` are the frames to solve the camera pose from."""

    def __init__(self, config: ArmRoutineConfig, executor: ExecutorConfig,
                 geometry: GripperGeometry | None = None) -> None:
        self.config = config
        self.cfg = executor
        self.geo = geometry or GripperGeometry()
        x0, x1, y0, y1 = config.workspace
        self.workspace = Workspace(x0, x1, y0, y1)
        self.phase = Phase.LOCATE
        self.block_id: int | None = None if config.block_id < 0 else config.block_id
        self.placements = [Placement(k, p) for k, p in enumerate(config.poses)]
        self.current: Placement | None = None  #: where the block is (None: not placed yet)
        self.error = ""
        self.tcp: ToolPose | None = None
        self.tcp_stamp: float | None = None
        self._gaps: list[tuple[float, float]] = []
        self.commanded: ToolPose | None = None
        self.runner: StepRunner | None = None
        self._release: Step | None = None
        self._placing: Placement | None = None
        self._parking = False
        self._lag = 0.0  #: how far the script's time trails the clock (s)
        self._last_run: float | None = None
        self._since = -math.inf  #: frames must be taken at or after this time (s)
        self._asked = -math.inf
        self._frames_seen = 0
        self._log: list[str] = []

    # --- inputs ---------------------------------------------------------------------------
    def on_tcp(self, pose: ToolPose, stamp: float | None = None) -> None:
        self.tcp, self.tcp_stamp = pose, stamp

    def on_finger_gap(self, gap: float, stamp: float) -> None:
        self._gaps.append((stamp, gap))

    def on_frame(self, stamp: float, detections: Sequence[TagDetection],
                 perceived: Mapping[int, BlockPose]) -> None:
        """A frame taken at ``stamp`` (s): its tag detections and the block poses the
        detector makes of them with the current calibration."""
        if self.phase not in (Phase.LOCATE, Phase.LOOK) or stamp < self._since:
            return
        if self.block_id is None:
            if len(perceived) != 1:
                self._fail(f"arm.block_id is -1, so exactly one block must be in view; the "
                           f"camera sees {sorted(perceived) or 'none'}")
                return
            self.block_id = next(iter(perceived))
        seen = perceived.get(self.block_id)
        if seen is None:
            self._log.append(f"frame at {stamp:.2f} s: block {self.block_id} not seen")
            return
        if self.phase is Phase.LOCATE:
            if self._start_pose is None:
                return  # the arm's pose not heard yet: a later frame starts the script
            self._log.append(f"block {self.block_id} seen at ({seen.x:.4f}, {seen.y:.4f}, "
                             f"{math.degrees(seen.theta):.1f} deg): centring it in the fingers")
            self._start_moving(self._regrip_steps(Pose2D(seen.x, seen.y, seen.theta)))
            return
        here = self.current
        assert here is not None and here.tcp is not None
        if here.block is None:
            here.block = BlockPose(self.block_id, here.tcp.x, here.tcp.y,
                                   snap_yaw(here.tcp.yaw, seen.theta))
        here.views.append(View(tuple(detections), {self.block_id: here.block}, here.index))
        here.perceived.append(seen)
        self._frames_seen += 1
        self._asked = -math.inf
        if len(here.views) >= self.config.frames:
            self._log.append(self._placement_line(here))
            self._next()

    # --- the loop ---------------------------------------------------------------------------
    def tick(self, now: float) -> Outputs:
        out = Outputs()
        if self.phase in (Phase.LOCATE, Phase.LOOK):
            if self._since == -math.inf:
                self._since = now
            if now - self._since > self.config.frame_timeout_s:
                self._fail(self._no_frame_reason())
            elif now - self._asked >= FRAME_RETRY_S:
                self._asked = now
                out.want_frame = True
        elif self.phase is Phase.MOVE:
            self._run(now, out)
        out.log, self._log = self._log, []
        return out

    def _run(self, now: float, out: Outputs) -> None:
        runner = self.runner
        assert runner is not None
        step = 0.0 if self._last_run is None else now - self._last_run
        self._lag += max(0.0, step - MAX_TICKS_PER_STEP / self.cfg.rate_hz)
        self._last_run = now
        lag = self._lag
        gaps, self._gaps = [(t - lag, g) for t, g in self._gaps], []
        measured_at = None if self.tcp_stamp is None else self.tcp_stamp - lag
        tick = runner.update(now - lag, self.tcp, measured_at, gaps)
        self.commanded = tick.setpoint
        out.setpoint, out.gripper = tick.setpoint, tick.gripper
        if self._release is not None and any(s is self._release for s in runner.finished_steps):
            self._released()
        if tick.error:
            self._fail(tick.error)
        elif tick.done:
            self.runner = None
            if self._parking:
                self.phase = Phase.DONE
                self._log.append("parked: every placement done")
            elif self.current is not None and self._placing is None:
                self.phase, self._since = Phase.LOOK, now  # set down, arm out of view
            else:
                self._fail("a transfer ended without releasing the block")

    def _released(self) -> None:
        """The fingers let go: the block stands where the TCP is."""
        placing, self._placing, self._release = self._placing, None, None
        assert placing is not None
        if self.tcp is None:
            self._fail("no /arm/tcp_pose measurement when the block was released")
            return
        placing.tcp = self.tcp
        self.current = placing

    def _next(self) -> None:
        """After the frames of one placement: carry the block to the next, or park."""
        here = self.current
        assert here is not None and here.block is not None
        following = [p for p in self.placements if p.index > here.index]
        if not following:
            self._parking = True
            self._start_moving(park_steps(self.cfg))
            return
        start = Pose2D(here.block.x, here.block.y, here.block.theta)
        self._start_moving(self._transfer(start, following[0], grasp=0))

    # --- scripts ----------------------------------------------------------------------------
    def _regrip_steps(self, seen: Pose2D) -> list[Step]:
        """Pick where seen, set down in place, pick again turned 90 degrees, carry to the
        first placement, release, look."""
        assert self.block_id is not None
        wide = replace(self.geo, approach_clearance=self.config.first_grasp_clearance)
        put_back = pick_place_steps(PickPlace(self.block_id, seen, seen), seen, wide, self.cfg)
        return put_back + self._transfer(seen, self.placements[0], grasp=1)

    def _transfer(self, start: Pose2D, to: Placement, grasp: int) -> list[Step]:
        assert self.block_id is not None
        steps = pick_place_steps(PickPlace(self.block_id, start, to.target, grasp), start,
                                 self.geo, self.cfg)
        self._release = next(s for s in reversed(steps)
                             if isinstance(s, Grip) and s.label.endswith("release"))
        self._placing = to
        near = ToolPose(to.target.x, to.target.y, self.cfg.travel_height, 0.0)
        return steps + look_steps(self.cfg, self.workspace, near)

    @property
    def _start_pose(self) -> ToolPose | None:
        """Where a script starts: the last setpoint, else the measured tool (None: neither)."""
        return self.commanded or self.tcp

    def _no_frame_reason(self) -> str:
        """Why the frame wait timed out: no arm pose to start from, or no frame of the block."""
        timeout = f"{self.config.frame_timeout_s:.0f} s"
        if self._start_pose is None:
            return f"no /arm/tcp_pose measurement within {timeout}: cannot start moving"
        what = "the block" if self.block_id is None else f"block {self.block_id}"
        return f"no frame showing {what} within {timeout} ({self.phase.value})"

    def _start_moving(self, steps: list[Step]) -> None:
        start = self._start_pose
        if start is None:
            self._fail("no /arm/tcp_pose measurement: cannot start moving")
            return
        self.runner = StepRunner(steps, start, self.cfg.convergence_tol,
                                 self.cfg.convergence_timeout_s, self.cfg.in_safe_box)
        self._lag, self._last_run = 0.0, None
        self.phase = Phase.MOVE
        self._since = -math.inf

    def _fail(self, reason: str) -> None:
        self.phase, self.error = Phase.FAILED, reason
        self.runner = None
        self._log.append(f"failed: {reason}")

    # --- results ----------------------------------------------------------------------------
    @property
    def finished(self) -> bool:
        return self.phase in (Phase.DONE, Phase.FAILED)

    def views(self) -> list[View]:
        return [v for p in self.placements for v in p.views]

    @staticmethod
    def _placement_line(p: Placement) -> str:
        assert p.block is not None
        seen = p.perceived
        dx = 1e3 * (sum(b.x for b in seen) / len(seen) - p.block.x)
        dy = 1e3 * (sum(b.y for b in seen) / len(seen) - p.block.y)
        assert p.tcp is not None
        return (f"placement {p.index}: block at ({p.block.x:.4f}, {p.block.y:.4f}, "
                f"{math.degrees(p.block.theta):.1f} deg) by the TCP (yaw "
                f"{math.degrees(p.tcp.yaw):.1f} deg); the current calibration sees it "
                f"{dx:+.2f}, {dy:+.2f} mm off")

    def report(self) -> str:
        return "\n".join(self._placement_line(p) for p in self.placements if p.views)

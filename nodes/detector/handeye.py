"""Perception checked against the arm: a table-plane correction from the arm's own placements.

A camera calibration that is a few millimetres or a few tenths of a degree off (a bumped
camera, a rough hand-eye calibration) shifts every perceived pose by nearly the same rigid
motion of the table plane: ``perceived = R(w) (true - c) + c + d``. The arm knows where it
sets blocks down; the camera then says where it sees them. The difference would be the error
itself but for the gripper: the 2F-85's fingers centre a block along their closing axis only,
so a block picked where the camera (wrongly) saw it keeps, across that axis, the offset the
error gave it. With ``e(p) = perceived - true`` at p, a block picked at P (perceived) along
axis a and released with the TCP at G is seen at

    O = G + e(G) - perp_a(e(P))        and its yaw at    theta_G + w,

(once a correction is in use the fingers grip at the corrected Q instead of P, and the block
keeps ``perp_a(P - Q)`` more across them),

(the pads square the block up with the tool, so the yaw error shows whole). A block gripped
along each of its axes in turn at one TCP (the executor's camera check, a ``squared``
placement) keeps no offset at all: ``O = G + e(G)``, both axes from one placement. Both are
linear in
(dx, dy, w) for a fixed centre c: a few placements with closing axes in different directions
give the error by least squares, and the detector then corrects its output (``PlaneCorrection``)
so that perception and arm agree. Pure logic (numpy), no ROS.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from msgs_py import BlockPose, BlockSet, Pose2D, wrap_angle
from msgs_py.placement import Placement

#: Noise of a perceived position (m) and yaw (rad) after a placement, to weigh the equations.
#: The yaw's is mostly the block turning as the pads let go: 0.34 deg (the worst of 270 placed
#: blocks, 30 scenes at a06bdb2, was 1.3 deg in the ground truth, about 3 sigma). At 0.17 deg
#: (before) placement yaws alone made turns of 0.1-0.2 deg where the camera had none.
POSITION_SIGMA = 0.0003
YAW_SIGMA = 0.006
#: Correct only an error at least this large somewhere in the workspace (m at its edge) ...
MIN_ERROR = 0.0004
#: ... known to this fraction of itself (one sigma), from closing axes at least this far
#: from parallel (sine of the angle between them).
MAX_RELATIVE_SIGMA = 0.3
MIN_AXIS_SPREAD = 0.5
#: A placement this far (m) from where the others put the error was disturbed: not used.
OUTLIER_M = 0.0015


@dataclass(frozen=True, slots=True)
class PlaneCorrection:
    """The map perceived -> true on the table plane: undo a rotation ``w`` (rad) about
    ``centre`` and a shift ``d`` (m): ``true = R(-w) (perceived - c - d) + c``."""

    dx: float = 0.0
    dy: float = 0.0
    w: float = 0.0
    cx: float = 0.0
    cy: float = 0.0

    def apply(self, p: Pose2D) -> Pose2D:
        """The true pose of a block perceived at ``p``."""
        c, s = math.cos(-self.w), math.sin(-self.w)
        x, y = p.x - self.cx - self.dx, p.y - self.cy - self.dy
        return Pose2D(c * x - s * y + self.cx, s * x + c * y + self.cy,
                      wrap_angle(p.theta - self.w))

    def error_at(self, x: float, y: float) -> float:
        """How far (m) a block perceived at (x, y) is moved by this correction."""
        q = self.apply(Pose2D(x, y, 0.0))
        return math.hypot(q.x - x, q.y - y)

    def describe(self) -> str:
        return (f"shift ({self.dx * 1e3:+.2f}, {self.dy * 1e3:+.2f}) mm, turn "
                f"{math.degrees(self.w):+.3f} deg about ({self.cx:.3f}, {self.cy:.3f})")


@dataclass(frozen=True, slots=True)
class Sample:
    """One placement: the block perceived at ``picked`` (in the camera's uncorrected frame),
    gripped with the fingers centred at ``gripped`` (arm frame; None: at ``picked``, as when no
    correction is in use), released with the TCP at ``placed`` (arm frame), closing axis at
    ``axis_yaw``, then seen at ``seen`` (uncorrected). ``squared``: gripped along both axes
    in turn at ``placed``, so it kept no offset from its pick."""

    picked: Pose2D
    placed: Pose2D
    axis_yaw: float
    seen: Pose2D
    gripped: Pose2D | None = None
    squared: bool = False

    @property
    def constraints(self) -> int:
        """Position equations that pin the error: one (along the closing axis) or two."""
        return 2 if self.squared else 1


@dataclass(frozen=True, slots=True)
class Estimate:
    correction: PlaneCorrection
    sigma: tuple[float, float, float]  #: one-sigma uncertainty of dx, dy (m), w (rad)
    samples: int
    rms_residual: float  #: RMS of the fit's position residuals (m)


def _equations(s: Sample, centre: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """One sample's three equations in (dx, dy, w): position x, y and yaw, unweighted."""
    cx, cy = centre
    a = np.array([math.cos(s.axis_yaw), math.sin(s.axis_yaw)])
    par = np.eye(2) if s.squared else np.outer(a, a)  # v -> (v.a) a: centred along a
    perp = np.eye(2) - par  # what the fingers left where it was
    turn = np.array([[0.0, -1.0], [1.0, 0.0]])  # d/dw of R(w) v at w = 0
    g = np.array([s.placed.x - cx, s.placed.y - cy])
    p = np.array([s.picked.x - cx, s.picked.y - cy])
    # The block stood at true = P - e(P); the fingers centred it along a about Q, so it is set
    # down at G + perp (true - Q) and seen there plus e: with e(x) = d + w J (x - c),
    # O - G - perp (P - Q) = par (d) + w (J g - perp J p); the yaw shows the turn whole.
    q = s.picked if s.gripped is None else s.gripped
    across = perp @ np.array([s.picked.x - q.x, s.picked.y - q.y])
    a_w = turn @ g - perp @ (turn @ p)
    rows = np.array([np.append(par[0], a_w[0]), np.append(par[1], a_w[1]), [0.0, 0.0, 1.0]])
    rhs = np.array([s.seen.x - s.placed.x - across[0], s.seen.y - s.placed.y - across[1],
                    math.remainder(s.seen.theta - s.placed.theta, math.pi / 2)])
    return rows, rhs


def estimate(samples: Sequence[Sample], centre: tuple[float, float],
             with_turn: bool = True) -> Estimate | None:
    """The error (dx, dy, w) about ``centre`` that best explains the samples (``with_turn``
    False: the shift alone, w = 0); None while they pin fewer than two position equations
    (two placements, or one squared)."""
    if sum(s.constraints for s in samples) < 2:
        return None
    equations = [_equations(s, centre) for s in samples]
    rows = np.vstack([r for r, _ in equations])
    rhs = np.concatenate([b for _, b in equations])
    if not with_turn:
        keep = [k for k in range(len(rhs)) if k % 3 < 2]
        rows, rhs = rows[keep][:, :2], rhs[keep]
    per_sample = [1.0 / POSITION_SIGMA] * 2 + ([1.0 / YAW_SIGMA] if with_turn else [])
    weights = np.tile(per_sample, len(samples))
    a_mat = rows * weights[:, None]
    b = rhs * weights
    solution, *_ = np.linalg.lstsq(a_mat, b, rcond=None)
    normal = a_mat.T @ a_mat
    try:
        cov = np.linalg.inv(normal)
    except np.linalg.LinAlgError:
        return None
    fit = rows @ solution - rhs
    pos = fit[[k for k in range(len(rhs)) if (k % len(per_sample)) < 2]]
    dx, dy, w = (float(v) for v in (*solution, 0.0)[:3])
    sigma = [float(math.sqrt(max(v, 0.0))) for v in np.diag(cov)] + [0.0]
    return Estimate(PlaneCorrection(dx, dy, w, centre[0], centre[1]),
                    (sigma[0], sigma[1], sigma[2]), len(samples),
                    float(np.sqrt(np.mean(pos ** 2))))


def misfit(s: Sample, c: PlaneCorrection) -> float:
    """How far (m) sample ``s`` lands from where correction ``c`` predicts it."""
    rows, rhs = _equations(s, (c.cx, c.cy))
    fit = rows[:2] @ np.array([c.dx, c.dy, c.w]) - rhs[:2]
    return float(np.hypot(*fit))


def robust_estimate(samples: Sequence[Sample], centre: tuple[float, float]
                    ) -> tuple[Estimate | None, list[Sample]]:
    """``estimate`` without the samples that disagree with the rest by more than OUTLIER_M
    (a block knocked, or pushed by a neighbour, as it was set down: the arm did not leave it
    where it says), worst first, as long as more than two remain; and the samples dropped."""
    kept = list(samples)
    dropped: list[Sample] = []
    while True:
        est = estimate(kept, centre)
        if est is None or len(kept) <= 2:
            return est, dropped
        worst = max(kept, key=lambda s: misfit(s, est.correction))
        if misfit(worst, est.correction) <= OUTLIER_M:
            return est, dropped
        kept.remove(worst)
        dropped.append(worst)


def axis_spread(samples: Sequence[Sample]) -> float:
    """Largest |sin| of the angle between two samples' closing axes (0: all parallel; 1
    with a squared sample, gripped along two square axes)."""
    if any(s.squared for s in samples):
        return 1.0
    yaws = [s.axis_yaw for s in samples]
    return max((abs(math.sin(a - b)) for i, a in enumerate(yaws) for b in yaws[i + 1:]),
               default=0.0)


def worth_correcting(est: Estimate, samples: Sequence[Sample],
                     corners: Sequence[tuple[float, float]]) -> bool:
    """The estimate is well determined and moves some corner of the workspace by more than
    MIN_ERROR: apply it."""
    if axis_spread(samples) < MIN_AXIS_SPREAD:
        return False
    if est.rms_residual > OUTLIER_M:  # the placements disagree: no correction explains them
        return False
    c = est.correction
    biggest = max(c.error_at(x, y) for x, y in corners)
    if biggest < MIN_ERROR:
        return False
    shift = math.hypot(c.dx, c.dy)
    shift_sigma = math.hypot(est.sigma[0], est.sigma[1])
    ok_shift = shift < MIN_ERROR / 2 or shift_sigma <= MAX_RELATIVE_SIGMA * shift
    # a turn is applied only once pinned: one below a placement's yaw noise is still a turn
    # (0.2 deg moves a block 0.3 m out by 1 mm), and one placement's yaw alone made such turns
    ok_turn = abs(c.w) < 1e-9 or est.sigma[2] <= MAX_RELATIVE_SIGMA * abs(c.w)
    return ok_shift and ok_turn


#: Placements whose pick may have been seen through an older correction are not used: a
#: pick-and-place takes less than this (s, the placement's stamp after the correction).
SETTLE_AFTER_CORRECTION_S = 15.0
#: A detection counts for a placement once the fingers have let go this long (s).
SEEN_AFTER_RELEASE_S = 0.05
#: A new estimate replaces the correction in use when it moves a workspace corner this far (m)
#: ...
UPDATE_MIN_CHANGE = 0.0002
#: ... and the one in use misplaces some placement by more than this (m, about twice a
#: placement's noise). Below, the view stays as it is: every move of it shifts every block
#: the executor checks, and a move it does not need costs a replan.
KEEP_MISFIT_M = 0.0006


#: A placement this far (m) from where the correction in use puts it, after the correction was
#: updated from it, says perception and arm disagree (twice OUTLIER_M, which a correction
#: leaves out as disturbed).
DISAGREE_M = 2 * OUTLIER_M


class Verdict(enum.Enum):
    """What the placements say of the correction in use."""

    UNKNOWN = "not known yet"
    AGREES = "perception and arm agree"
    DISAGREES = "perception and arm disagree"


class HandEye:
    """The detector's side of the hand-eye check: placements in, corrected detections out.

    ``on_placement`` takes what the arm reports it set down; ``correct`` takes each raw
    detection (in the camera's uncorrected frame), turns pending placements into samples,
    re-estimates, and returns the detection through the correction in use. ``log`` collects
    what is worth telling (a correction adopted).
    """

    def __init__(self, workspace_corners: Sequence[tuple[float, float]],
                 centre: tuple[float, float], correction: PlaneCorrection | None = None) -> None:
        self.corners = list(workspace_corners)
        self.centre = centre
        #: in use: the identity about the view's centre, or one a recent check found
        self.correction = correction or PlaneCorrection(cx=centre[0], cy=centre[1])
        self.samples: list[Sample] = []
        self.pending: list[tuple[Placement, Pose2D]] = []  # (placement, its pick in raw)
        self.corrected_at_ns = -(10**18)
        self.log: list[str] = []

    def on_placement(self, placement: Placement) -> None:
        # a block set down again (or pushed) before it was seen: only the last placement
        # says where it is, and a push's end is no equation (the fingers did not let it go)
        self.pending = [(p, raw) for p, raw in self.pending if p.block != placement.block]
        if placement.pushed:
            return
        if placement.stamp_ns < self.corrected_at_ns + SETTLE_AFTER_CORRECTION_S * 1e9:
            return  # picked while another correction was in use: its pick pose is unreliable
        self.pending.append((placement, self._raw(placement.picked_from)))

    def _raw(self, corrected: Pose2D) -> Pose2D:
        """Undo the correction in use: the camera's own reading of a corrected pose."""
        c = self.correction
        cos, sin = math.cos(c.w), math.sin(c.w)
        x, y = corrected.x - c.cx, corrected.y - c.cy
        return Pose2D(cos * x - sin * y + c.cx + c.dx, sin * x + cos * y + c.cy + c.dy,
                      wrap_angle(corrected.theta + c.w))

    def correct(self, raw: BlockSet) -> BlockSet:
        """``raw`` (poses in the camera's calibrated frame) through the correction, after
        learning from it."""
        seen = {b.id: b.pose for b in raw.blocks}
        still = []
        for placement, picked in self.pending:
            if (raw.stamp_ns < placement.stamp_ns + SEEN_AFTER_RELEASE_S * 1e9
                    or placement.block in raw.occluded):
                # too soon, or the arm covers it (a frame taken as the arm moves on): the
                # placement waits for a frame that shows the block (the camera check's one
                # placement was lost so, and with it the whole correction)
                still.append((placement, picked))
            elif placement.block in seen:
                self.samples.append(Sample(picked, placement.pose, placement.closing_axis_yaw,
                                           seen[placement.block], placement.picked_from,
                                           placement.squared))
                self._update(raw.stamp_ns)
        self.pending = still
        if self.correction == PlaneCorrection(cx=self.centre[0], cy=self.centre[1]):
            return raw
        return dataclasses.replace(raw, blocks=tuple(
            BlockPose(b.id, *_xyt(self.correction.apply(b.pose))) for b in raw.blocks))

    def verdict(self) -> Verdict:
        """Whether the placements so far agree with the correction in use: they pin the error
        (two position equations from closing axes far enough from parallel) and every one
        lands within OUTLIER_M of where the correction puts it (AGREES); one lands
        further than DISAGREE_M and no correction could be adopted (DISAGREES); else not
        known yet."""
        if not self.samples:
            return Verdict.UNKNOWN
        worst = max(misfit(s, self.correction) for s in self.samples)
        if worst > DISAGREE_M:
            return Verdict.DISAGREES
        pinned = (sum(s.constraints for s in self.samples) >= 2
                  and axis_spread(self.samples) >= MIN_AXIS_SPREAD)
        return Verdict.AGREES if pinned and worst <= OUTLIER_M else Verdict.UNKNOWN

    def _still_fits(self) -> bool:
        """A correction is in use and places every sample within KEEP_MISFIT_M of where it
        was seen."""
        if self.correction == PlaneCorrection(cx=self.centre[0], cy=self.centre[1]):
            return False
        return all(misfit(s, self.correction) <= KEEP_MISFIT_M for s in self.samples)

    def _update(self, stamp_ns: int) -> None:
        est, dropped = robust_estimate(self.samples, self.centre)
        for sample in dropped:
            self.samples.remove(sample)
            self.log.append(f"placement at ({sample.placed.x:.3f}, {sample.placed.y:.3f}) "
                            f"left out of the camera check: it disagrees with the others by "
                            f"{misfit(sample, est.correction) * 1e3:.1f} mm (disturbed?)")
        if est is not None and not worth_correcting(est, self.samples, self.corners):
            # a turn the placements do not pin down yet (two at one spot, noisy yaws): the
            # shift alone, which they do, is already worth having
            est = estimate(self.samples, self.centre, with_turn=False)
        if est is None or not worth_correcting(est, self.samples, self.corners):
            return
        change = max(abs(est.correction.error_at(x, y) - self.correction.error_at(x, y))
                     for x, y in self.corners)
        if change < UPDATE_MIN_CHANGE or self._still_fits():
            return
        self.correction = est.correction
        self.corrected_at_ns = stamp_ns
        plural = "s" if est.samples != 1 else ""
        self.log.append(f"perception corrected from {est.samples} placement{plural} of the arm: "
                        f"{est.correction.describe()} (RMS residual "
                        f"{est.rms_residual * 1e3:.2f} mm)")


def _xyt(p: Pose2D) -> tuple[float, float, float]:
    return p.x, p.y, p.theta

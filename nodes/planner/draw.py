"""Draw a plan with matplotlib: workspace, start and goal footprints, every action numbered.

Pick-and-place actions are solid blue arrows from the pick pose to the place pose; pushes are
thick orange arrows; the number of each action sits at its start. Start footprints are filled
(with the block id), goal footprints dashed green outlines, intermediate poses (clearing, regrasp,
before a push) dotted grey outlines.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.patches import Polygon as PatchPolygon
from matplotlib.patches import Rectangle

from msgs_py import Plan, Push, Scene
from msgs_py.footprint import block_corners
from nodes.planner.unlabeled.goal_check import goal_slots

PICK_COLOR = "tab:blue"
PUSH_COLOR = "tab:orange"


def draw_plan(scene: Scene, plan: Plan | None, path: str | Path, title: str = "") -> Path:
    """Write a PNG of ``scene`` (start and goal) and ``plan``'s actions to ``path``."""
    fig, ax = plt.subplots(figsize=(8, 8))
    w, s = scene.workspace, scene.block_size
    ax.add_patch(Rectangle((w.x_min, w.y_min), w.x_max - w.x_min, w.y_max - w.y_min,
                           fill=False, lw=1.5, ec="black"))
    labeled = scene.goal is not None and scene.goal.labeled
    slots = goal_slots(scene)
    for key, goal in slots:
        ax.add_patch(PatchPolygon(block_corners(goal.x, goal.y, goal.theta, s), closed=True,
                                  fill=False, ls="--", ec="tab:green", lw=1.2))
        ax.text(goal.x, goal.y, str(key) if labeled else "any", color="tab:green",
                ha="center", va="center", fontsize=7, alpha=0.8)
    for b in scene.blocks:
        ax.add_patch(PatchPolygon(block_corners(b.x, b.y, b.theta, s), closed=True,
                                  fc="burlywood", ec="saddlebrown", alpha=0.7))
        ax.text(b.x, b.y, str(b.id), ha="center", va="center", fontsize=8, weight="bold")
    goals = dict(slots) if labeled else {}
    for k, action in enumerate(plan.actions if plan is not None else (), start=1):
        push = isinstance(action, Push)
        color = PUSH_COLOR if push else PICK_COLOR
        ends = [goals[action.block]] if action.block in goals else [] if labeled else \
            [g for _, g in slots]
        if not any(action.to.distance_to(g) <= 1e-6 for g in ends):  # an intermediate pose
            ax.add_patch(PatchPolygon(block_corners(action.to.x, action.to.y, action.to.theta,
                                                     s), closed=True, fill=False, ls=":",
                                      ec="grey", lw=0.8))
        ax.annotate("", xy=(action.to.x, action.to.y), xytext=(action.from_.x, action.from_.y),
                    arrowprops={"arrowstyle": "-|>", "color": color, "lw": 2.5 if push else 1.2,
                                "shrinkA": 0, "shrinkB": 0,
                                "linestyle": "-" if push else (0, (4, 2))})
        ax.text(action.from_.x, action.from_.y + 0.25 * s, str(k), color=color, fontsize=7,
                ha="center", weight="bold",
                bbox={"boxstyle": "circle,pad=0.15", "fc": "white", "ec": color, "lw": 0.8})
    ax.plot([], [], color=PICK_COLOR, ls="--", label="pick-and-place")
    ax.plot([], [], color=PUSH_COLOR, lw=2.5, label="push")
    ax.plot([], [], color="tab:green", ls="--", label="goal")
    ax.legend(loc="upper right", fontsize=8)
    margin = 0.05
    ax.set_xlim(w.x_min - margin, w.x_max + margin)
    ax.set_ylim(w.y_min - margin, w.y_max + margin)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, world)")
    ax.set_ylabel("y (m, world)")
    n = len(plan.actions) if plan is not None else 0
    ax.set_title(title or f"{len(scene.blocks)} blocks, {n} actions")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path

"""The run timeline: action spans from the executor's status stream, and their PNG."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from nodes.cell.timeline import KIND_COLOURS, ActionSpan, TimelineBuilder, write_timeline


def feed_two_plans() -> TimelineBuilder:
    """Plan p1 (pick, push); after action 2 the executor finds drift and replans once: plan
    p2 (one pick of block 4), which a slip interrupts (recovering) and which then ends."""
    t = TimelineBuilder()
    t.add_plan("p1", ["pick_place", "push"])
    t.add_plan("p2", ["pick_place"])
    t.on_status(1.0, "idle", "p1", 0, 2, None)
    t.on_status(2.0, "observing", "p1", 0, 2, None)
    t.on_status(2.5, "running", "p1", 1, 2, 3)
    t.on_status(3.5, "running", "p1", 1, 2, 3)  # the once-a-second repeat changes nothing
    t.on_status(7.0, "observing", "p1", 1, 2, 3)
    t.on_status(8.0, "running", "p1", 2, 2, 5)
    t.on_status(11.0, "observing", "p1", 2, 2, 5)
    t.on_corrections(1)
    t.on_status(12.0, "replanning", "p1", 2, 2, 5)
    t.on_status(13.0, "running", "p2", 1, 1, 4)
    t.on_status(15.0, "recovering", "p2", 1, 1, 4)  # still this action
    t.on_status(19.5, "observing", "p2", 1, 1, 4)
    t.on_status(20.0, "done", "p2", 1, 1, None)
    return t


def test_spans_follow_the_status_stream():
    spans = feed_two_plans().finish(21.0, {3: 0.0004, 5: 0.0011})
    assert [(s.plan_id, s.index, s.kind, s.block) for s in spans] == [
        ("p1", 1, "pick_place", 3), ("p1", 2, "push", 5), ("p2", 1, "pick_place", 4)]
    assert [s.duration_s for s in spans] == [4.5, 3.0, 6.5]
    # the replan after action 2 is that action's correction, not the next one's
    assert [s.corrections for s in spans] == [0, 1, 0]
    assert [s.final_error_m for s in spans] == [0.0004, 0.0011, None]  # block 4 not reported


def test_an_action_cut_short_ends_when_the_run_does():
    t = TimelineBuilder()
    t.on_status(5.0, "running", "p9", 3, 7, 2)  # its plan never heard: kind unknown
    (span,) = t.finish(9.25)
    assert (span.kind, span.start_s, span.end_s) == ("?", 5.0, 9.25)


def test_no_action_no_span():
    t = TimelineBuilder()
    t.on_status(1.0, "running", "p1", 0, 0, None)  # action 0: before the first one
    assert t.finish(2.0) == []


def test_the_png_shows_a_bar_per_action_in_its_kind_colour(tmp_path):
    spans = feed_two_plans().finish(21.0, {3: 0.0004, 5: 0.0011, 4: 0.0002})
    png, js = tmp_path / "timeline.png", tmp_path / "timeline.json"
    write_timeline(spans, png, js, title="test run", tolerance_m=0.002)
    image = cv2.imread(str(png))
    assert image is not None and image.shape[0] > 100 and image.shape[1] > 500
    rgb = image[:, :, ::-1].reshape(-1, 3).astype(int)

    def pixels_of(hex_colour: str) -> int:
        want = np.array([int(hex_colour[k:k + 2], 16) for k in (1, 3, 5)])
        return int((np.abs(rgb - want).sum(axis=1) < 6).sum())

    # pushes' bars are a third of the pick-and-place bars' simulated time (3 s vs 11 s),
    # drawn twice each (timeline and error panels) plus a legend patch
    push, pick = pixels_of(KIND_COLOURS["push"]), pixels_of(KIND_COLOURS["pick_place"])
    assert push > 200 and pick > push
    rows = json.loads(js.read_text())
    assert [r["duration_s"] for r in rows] == [4.5, 3.0, 6.5]
    assert rows[1]["corrections"] == 1 and rows[2]["final_error_m"] == 0.0002


def test_an_empty_run_still_draws(tmp_path):
    write_timeline([], tmp_path / "t.png")
    assert cv2.imread(str(tmp_path / "t.png")) is not None


def test_duration_is_end_minus_start():
    assert ActionSpan("p", 1, 1, "push", 0, 2.0, 5.5).duration_s == pytest.approx(3.5)


def test_json_rows_read_back_as_the_spans():
    spans = feed_two_plans().finish(21.0, {3: 0.0004})
    from nodes.cell.timeline import spans_from_json, spans_to_json

    assert spans_from_json(json.loads(json.dumps(spans_to_json(spans)))) == spans

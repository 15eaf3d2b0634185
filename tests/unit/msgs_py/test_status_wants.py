"""What the executor reads from the planner's status."""

from msgs_py.status import PlannerStatus


def test_the_planner_wants_a_frame_only_while_it_waits_for_a_detection():
    assert PlannerStatus("waiting", last_error="waiting for a detection").wants_detection
    assert PlannerStatus("waiting", last_error="blocks [3] are occluded in the last detection; "
                         "waiting for one that shows every block").wants_detection
    assert not PlannerStatus("waiting", last_error="waiting for a goal layout").wants_detection
    assert not PlannerStatus("planning").wants_detection

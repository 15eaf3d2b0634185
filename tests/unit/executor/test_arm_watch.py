"""ArmWatch: the arm node judged gone from TCP reports counted on arrival, and back only once
it takes the executor's setpoints again."""

from __future__ import annotations

from nodes.executor.arm_watch import ArmWatch

ME = "/executor"


def mine(holder: str) -> bool:  # the lease client's word: connected, and the status names me
    return holder == ME


def test_an_arm_that_reports_between_ticks_is_never_lost_however_late_the_reports():
    watch = ArmWatch(silent_ticks=3)
    for _burst in range(20):  # a loaded executor: three ticks, then the reports in a burst
        assert [watch.on_tick(True, mine) for _ in range(3)] == [None] * 3
        watch.on_tcp()


def test_an_arm_never_heard_is_not_lost():
    watch = ArmWatch(silent_ticks=3)
    assert all(watch.on_tick(True, mine) is None for _ in range(50))


def test_a_silent_arm_is_lost_and_back_only_when_its_status_names_the_executor():
    watch = ArmWatch(silent_ticks=3)
    watch.on_tcp()
    watch.on_status(ME)
    assert [watch.on_tick(True, mine) is None for _ in range(4)] == [True, True, True, False]
    assert "silent" in watch.lost
    watch.on_tcp()  # the node respawned: it reports, and holds no lease yet
    assert "its lease held by nobody" in watch.on_tick(True, mine)
    watch.on_status("")
    assert watch.on_tick(True, mine) is not None
    watch.on_status(ME)  # the executor took the lease again
    watch.on_tcp()
    assert watch.on_tick(True, mine) is None


def test_the_dead_nodes_last_word_on_its_lease_does_not_end_the_loss():
    watch = ArmWatch(silent_ticks=1)
    watch.on_status(ME)
    watch.on_tcp()
    watch.on_tick(True, mine)
    watch.on_tick(True, mine)
    assert watch.lost is not None
    watch.on_tcp()  # reports from the new node before any status of its own
    assert watch.on_tick(True, mine) is not None


def test_a_lost_arm_back_while_the_executor_wants_no_arm_is_taken_at_its_reports():
    watch = ArmWatch(silent_ticks=1)
    watch.on_tcp()
    watch.on_tick(False, mine)
    assert watch.on_tick(False, mine) is not None
    watch.on_tcp()
    assert watch.on_tick(False, mine) is None


def test_the_silence_limit_follows_the_tick_rate():
    assert ArmWatch.at_rate(50.0).silent_ticks == 25
    assert ArmWatch.at_rate(1.0).silent_ticks == 2


def test_an_arm_leased_to_a_predecessor_of_the_same_name_holds_until_the_lease_is_taken():
    watch = ArmWatch(silent_ticks=3)
    watch.on_tcp()
    watch.on_status(ME)  # the executor that died still holds the lease, under our name
    taken = False

    def inherited(holder: str) -> bool:
        return holder == ME and not taken

    def anyone(holder: str) -> bool:  # never connected: the device is taken at its word
        return True

    assert "not on this node's connected lease yet" in watch.on_tick(True, anyone, inherited)
    assert watch.on_tick(False, anyone, inherited) is None  # no motion wanted: nothing held
    taken = True  # the respawned executor's lease is connected
    watch.on_tcp()
    assert watch.on_tick(True, mine, inherited) is None


def test_a_lease_held_by_nobody_or_another_name_is_not_inherited():
    watch = ArmWatch(silent_ticks=3)
    watch.on_tcp()
    for holder in ("", "/other_tool"):
        watch.on_status(holder)
        assert watch.on_tick(True, lambda h: True, lambda h: h == ME) is None

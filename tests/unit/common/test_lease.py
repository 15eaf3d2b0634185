"""One commander at a time, without ROS: the device's lease book (who holds it, who is
refused, a holder that left the graph) and the holder's side (when it asks, gives back,
and where its commands go)."""

from __future__ import annotations

import itertools

import pytest

from nodes.common.lease import MAX_NAMED, Ask, LeaseBook, LeaseConfig, LeaseKeeper


def book(absent_checks: int = 2) -> LeaseBook:
    tokens = (f"t{k}" for k in itertools.count())
    return LeaseBook("the arm", absent_checks, token_fn=lambda: next(tokens))


def test_the_first_asker_holds_it_and_a_second_is_refused_with_the_holders_name():
    b = book()
    first = b.request("/executor", 3.0)
    assert first.granted and first.lease.holder == "/executor" and first.lease.token == "t0"
    assert first.lease.since_s == 3.0 and first.ended is None
    second = b.request("/executor_b", 4.0)
    assert not second.granted and "/executor holds the arm (since 3.0 s)" in second.message
    assert second.lease == first.lease  # unchanged
    assert b.status().refused_commanders == ("/executor_b",)


def test_the_same_holder_asking_again_gets_a_new_token_and_the_old_lease_ends():
    b = book()
    old = b.request("/executor", 1.0).lease
    again = b.request("/executor", 9.0)  # a respawned executor, under the same name
    assert again.granted and again.lease.token != old.token and again.ended == old
    assert b.lease.since_s == 9.0


def test_only_the_holder_gives_it_back_and_a_stale_token_leaves_the_new_lease_alone():
    b = book()
    b.request("/executor", 1.0)
    new = b.request("/executor", 2.0).lease
    assert not b.release("/executor", "t0").ended  # the old lease's late give-back
    assert not b.release("/tool").ended  # not its lease
    assert b.lease == new
    given = b.release("/executor", new.token)
    assert given.ended == new and b.lease is None and b.holder == ""
    assert "nobody holds" in b.release("/executor").message


@pytest.mark.parametrize("name", ["executor", "/", "/executor/", "/my executor", ""])
def test_a_name_that_is_no_node_name_is_refused(name):
    b = book()
    answer = b.request(name, 0.0)
    assert not answer.granted and "fully qualified" in answer.message and b.lease is None


def test_a_refused_command_is_counted_and_charged_to_every_publisher_but_the_holder():
    b = book()
    b.request("/executor", 0.0)
    assert b.refuse(["/executor", "/stray_tool", "/densepack_run"]) == [
        "/densepack_run", "/stray_tool"]
    assert b.refuse(["/executor"]) == []  # sent before the holder switched, or by one gone
    status = b.status()
    assert status.holder == "/executor" and status.refused_commands == 2
    assert set(status.refused_commanders) == {"/stray_tool", "/densepack_run"}


def test_names_are_kept_most_recent_first_without_repeats_and_bounded():
    b = book()
    b.request("/executor", 0.0)
    for k in range(MAX_NAMED + 3):
        b.refuse([f"/tool_{k}"])
    b.refuse(["/tool_5"])
    named = b.status().refused_commanders
    assert len(named) == MAX_NAMED and named[0] == "/tool_5" and len(set(named)) == MAX_NAMED
    assert named[1] == f"/tool_{MAX_NAMED + 2}"


def test_a_holder_missing_from_the_graph_at_enough_looks_in_a_row_loses_the_lease():
    b = book(absent_checks=2)
    lease = b.request("/executor", 0.0).lease
    assert b.on_graph({"/arm", "/executor"}) is None
    assert b.on_graph({"/arm"}) is None  # one look without it: discovery may lag
    assert b.on_graph({"/arm", "/executor"}) is None  # back: the count starts again
    assert b.on_graph({"/arm"}) is None
    assert b.on_graph({"/arm"}) == lease and b.lease is None
    assert b.on_graph({"/arm"}) is None  # nothing left to end


def test_a_new_grant_starts_the_absence_count_again():
    b = book(absent_checks=2)
    b.request("/executor", 0.0)
    b.on_graph(set())
    b.request("/executor", 1.0)  # asked again: it is there
    assert b.on_graph(set()) is None and b.lease is not None


def test_lease_parameters_are_checked():
    with pytest.raises(ValueError, match="absent_checks"):
        LeaseConfig(absent_checks=0)
    with pytest.raises(ValueError, match="check_period_s"):
        LeaseConfig(check_period_s=0.0)


# --- the holder's side -----------------------------------------------------------------------


def keeper() -> LeaseKeeper:
    return LeaseKeeper("the arm's", retry_s=1.0, answer_timeout_s=5.0, connect_timeout_s=5.0)


def test_the_holder_asks_when_it_wants_control_and_publishes_privately_once_connected():
    k = keeper()
    assert k.step(False, 0.0, True, 0) is None  # no run: nothing to ask
    assert k.step(True, 0.1, True, 0) is Ask.TAKE
    assert k.step(True, 0.2, True, 0) is None  # one request at a time
    k.on_answer(True, "t1", "/arm/lease/t1/cartesian_setpoint", "granted", 0.3)
    assert k.holds and not k.connected  # the device's subscriber not seen yet: public
    assert k.step(True, 0.4, True, 1) is None and k.connected
    assert k.switched  # the caller sends its last command again, privately
    k.switched = False
    k.step(True, 0.45, True, 1)
    assert not k.switched  # once per switch
    assert k.step(False, 5.0, True, 1) is Ask.GIVE_BACK
    assert k.connected  # commands go on privately until the answer
    k.on_answer(False, "", "", "/executor gave the arm back", 5.1)
    assert not k.holds and not k.connected and k.topic == ""


def test_a_refused_holder_asks_again_each_retry_and_says_why_once():
    k = keeper()
    assert k.step(True, 0.0, True, 0) is Ask.TAKE
    k.on_answer(False, "", "", "refused: /executor_a holds the arm", 0.1)
    assert k.step(True, 0.5, True, 0) is None
    assert k.step(True, 1.2, True, 0) is Ask.TAKE
    k.on_answer(False, "", "", "refused: /executor_a holds the arm", 1.3)
    lines = k.take_log()
    assert len(lines) == 1 and "/executor_a holds the arm" in lines[0]


def test_a_device_that_restarts_is_asked_again():
    k = keeper()
    k.step(True, 0.0, True, 0)
    k.on_answer(True, "t1", "/arm/lease/t1/cartesian_setpoint", "granted", 0.0)
    k.step(True, 0.1, True, 1)
    assert k.connected
    assert k.step(True, 3.0, False, 0) is None  # the arm node died: its subscriber went
    assert not k.holds and "lost" in k.take_log()[-1]
    assert k.step(True, 3.1, False, 0) is None  # no service yet: wait
    assert k.step(True, 4.2, True, 0) is Ask.TAKE  # it is back


def test_a_device_that_restarted_and_names_no_holder_is_asked_again_before_dds_notices():
    """A SIGKILLed gripper node is back within seconds holding no lease, while its old
    subscriber on the private topic may still be counted: its status says so first."""
    k = keeper()
    k.step(True, 0.0, True, 0)
    k.on_answer(True, "t1", "/gripper/lease/t1/command", "granted", 0.0)
    k.step(True, 0.1, True, 1)
    k.on_device_holder("/executor", "/executor", 0.2)
    k.on_device_holder("", "/executor", 0.3)  # one status from before the grant: no harm
    k.on_device_holder("/executor", "/executor", 0.4)
    assert k.holds
    k.on_device_holder("", "/executor", 5.0)  # restarted
    k.on_device_holder("", "/executor", 5.3)
    assert k.holds  # not yet: a status may be late
    k.on_device_holder("", "/executor", 5.6)
    assert not k.holds and "says nobody holds it" in k.take_log()[-1]
    assert k.step(True, 5.6, True, 1) is Ask.TAKE  # (the dead subscriber still counted)


def test_a_lease_never_connected_or_never_answered_is_given_up_and_asked_again():
    k = keeper()
    k.step(True, 0.0, True, 0)
    assert k.step(True, 4.0, True, 0) is None  # waiting for the answer
    assert k.step(True, 5.5, True, 0) is None and "no answer" in k.take_log()[0]
    assert k.step(True, 6.6, True, 0) is Ask.TAKE
    k.on_answer(True, "t2", "/arm/lease/t2/cartesian_setpoint", "granted", 6.7)
    assert k.step(True, 12.0, True, 0) is Ask.TAKE  # nobody listened on it in 5 s
    assert "nobody listened" in k.take_log()[-1]


def test_without_the_service_the_holder_keeps_to_the_public_topic():
    k = keeper()
    for t in range(5):
        assert k.step(True, float(t), False, 0) is None
    assert not k.holds and not k.connected

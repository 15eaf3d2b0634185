"""The one table of the executor's states and the changes between them."""

from __future__ import annotations

from msgs_py import EXECUTOR_STATES, ExecutorStatus
from msgs_py.status import ExecutorState
from nodes.executor.states import TRANSITIONS, State, transitions_markdown


def test_the_state_table_covers_every_state_and_names_every_change():
    assert set(TRANSITIONS) == set(State)
    assert all(reason for targets in TRANSITIONS.values() for reason in targets.values())
    assert {s.value for s in State} == set(EXECUTOR_STATES)


def test_the_executor_publishes_the_message_layers_own_states():
    """One enum: the executor's states are the status's, a status given a word keeps the
    member, and the table of docs/nodes.md names every change by the states' words."""
    assert State is ExecutorState
    assert ExecutorStatus("observing").state is State.OBSERVING
    table = transitions_markdown()
    assert table.count("\n") == 1 + sum(len(t) for t in TRANSITIONS.values())
    assert "| `stopping` | `failed` |" in table

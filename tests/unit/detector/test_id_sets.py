"""The id-set syntax of allowed_ids / expected_ids."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from nodes.detector.id_sets import format_id_set, parse_id_set


def test_ranges_and_single_ids():
    assert parse_id_set("0-3, 7,9-10") == {0, 1, 2, 3, 7, 9, 10}
    assert parse_id_set("") == frozenset()


@pytest.mark.parametrize("text", ["a", "3-1", "-2", "1-x", "1--2"])
def test_malformed_sets_name_the_parameter(text):
    with pytest.raises(ValueError, match="allowed_ids"):
        parse_id_set(text, "allowed_ids")


@given(st.sets(st.integers(0, 60)))
def test_format_reads_back(ids):
    assert parse_id_set(format_id_set(ids)) == ids

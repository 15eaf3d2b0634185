"""Quaternion/matrix conversions and the downward tool frame."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from nodes.common.transforms import (
    matrix_to_quaternion,
    quaternion_to_matrix,
    rotation_angle,
    tool_down_matrix,
    tool_down_quaternion,
    yaw_of_matrix,
)

unit = st.floats(-1, 1)


@given(st.tuples(unit, unit, unit, unit).filter(lambda q: sum(v * v for v in q) > 1e-3))
def test_quaternion_matrix_round_trip(q):
    q = np.array(q) / np.linalg.norm(q)
    q = -q if q[3] < 0 else q
    r = quaternion_to_matrix(q)
    assert np.allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(r), 1.0)
    back = matrix_to_quaternion(r)
    assert np.allclose(back, q, atol=1e-9) or np.allclose(back, -q, atol=1e-9)


@given(st.floats(-math.pi, math.pi))
def test_tool_down_points_down_with_the_closing_axis_at_yaw(yaw):
    r = tool_down_matrix(yaw)
    assert np.allclose(r[:, 2], [0, 0, -1])
    assert math.isclose(math.remainder(yaw_of_matrix(r) - yaw, 2 * math.pi), 0, abs_tol=1e-12)
    assert np.isclose(np.linalg.det(r), 1.0)
    assert rotation_angle(quaternion_to_matrix(tool_down_quaternion(yaw)), r) < 1e-7

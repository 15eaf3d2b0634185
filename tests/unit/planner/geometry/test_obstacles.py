"""Geometry predicates: footprints, fingers, push sweeps, containment, fixed vs movable hits."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from msgs_py.footprint import (
    block_corners,
    face_normals,
    grasp_finger_corners,
    push_corners,
    rect_corners,
    to_polygons,
)
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.obstacles import (
    Bounds,
    Obstacles,
    frames,
    mask_to_ids,
    penetration,
    popcount,
)

S = 0.0508
GEOM = PlannerConfig().gripper(S)


def poly(corners):
    """One shapely polygon from (4, 2) corners (leading unit axes dropped)."""
    return to_polygons(np.asarray(corners).reshape(4, 2)[None])[0]


def test_block_footprint_is_the_rotated_square():
    square = poly(block_corners(0.5, 0.1, 0.3, S))
    assert square.area == pytest.approx(S * S)
    assert square.centroid.x == pytest.approx(0.5) and square.centroid.y == pytest.approx(0.1)
    edge = np.diff(block_corners(0.0, 0.0, 0.3, S)[:2], axis=0)[0]
    assert math.atan2(edge[1], edge[0]) == pytest.approx(0.3)


@pytest.mark.parametrize("grasp, axis", [(0, 0.0), (1, math.pi / 2)])
def test_grasp_fingers_stand_beside_the_faces_along_the_closing_axis(grasp, axis):
    pads = grasp_finger_corners(GEOM, 0.0, 0.0, 0.0, grasp)
    offset = S / 2 + GEOM.approach_clearance + GEOM.finger_thickness / 2
    centres = pads.mean(axis=-2)
    expected = offset * np.array([math.cos(axis), math.sin(axis)])
    assert np.allclose(sorted(map(tuple, centres)), sorted([tuple(expected), tuple(-expected)]))
    pad = poly(pads[0])
    assert pad.area == pytest.approx(GEOM.finger_thickness * GEOM.finger_width)
    # pads never touch the block they grasp, and the opening fits the stroke
    assert not pad.intersects(poly(block_corners(0, 0, 0, S)))
    assert S + 2 * GEOM.approach_clearance <= 0.085


def test_grasp_fingers_follow_the_block_yaw():
    a = grasp_finger_corners(GEOM, 0.0, 0.0, 0.4, 1)
    b = grasp_finger_corners(GEOM, 0.0, 0.0, 0.4 + math.pi / 2, 0)
    assert np.allclose(sorted(map(tuple, a.mean(-2))), sorted(map(tuple, b.mean(-2))))


def test_push_sweeps_block_and_two_fingertips_behind_the_rear_face():
    length = 0.1
    parts = push_corners(GEOM, 0.0, 0.0, 1.0, 0.0, length)
    block, pad_a, pad_b = (poly(p) for p in parts)
    assert block.bounds == pytest.approx((-S / 2, -S / 2, length + S / 2, S / 2))
    back = S / 2 + GEOM.push_contact_depth + GEOM.finger_width
    for pad in (pad_a, pad_b):
        x0, y0, x1, y1 = pad.bounds
        assert x0 == pytest.approx(-back)  # where the tips land, behind the face
        assert x1 == pytest.approx(length - S / 2)  # the tips end on the rear face at p2
        assert y1 - y0 == pytest.approx(GEOM.finger_thickness)
        assert y0 >= -S / 2 and y1 <= S / 2  # both tips on the face: two-point contact
    assert pad_a.distance(pad_b) == pytest.approx(GEOM.push_opening)


def test_face_normals_are_the_four_axes_of_the_block():
    n = face_normals(0.25)
    assert n.shape == (4, 2)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    assert np.allclose(n[0], [math.cos(0.25), math.sin(0.25)])
    assert abs(float(n[0] @ n[1])) < 1e-12


def test_bounds_contain_only_shapes_entirely_inside():
    ws = Bounds(0.0, 1.0, 0.0, 1.0)
    inside = block_corners(0.5, 0.5, 0.7, S)
    touching = block_corners(S / 2, 0.5, 0.0, S)
    poking = block_corners(S / 2 - 0.001, 0.5, 0.0, S)
    assert ws.contains(np.stack([inside, touching, poking])).tolist() == [True, True, False]
    assert ws.grown(0.01).contains(poking)


def test_obstacles_separate_fixed_from_movable_and_count_them():
    ids = [3, 7, 9]
    corners = block_corners([0.0, 0.1, 0.2], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], S)
    obstacles = Obstacles(ids, corners, [False, True, True], {3: 0, 7: 1, 9: 2})
    queries = np.stack([
        block_corners(0.0, 0.03, 0.0, S),  # overlaps fixed 3
        block_corners(0.15, 0.0, 0.0, S),  # overlaps movable 7 and 9
        block_corners(0.1, S, 0.0, S),  # touches 7 exactly: no collision
        block_corners(0.5, 0.5, 0.0, S),  # free
    ])[:, None]
    fixed, mask = obstacles.query(queries)
    assert fixed.tolist() == [True, False, False, False]
    assert popcount(mask).tolist() == [0, 2, 0, 0]
    assert mask_to_ids(mask[1], [3, 7, 9]) == [7, 9]
    assert obstacles.fixed_ids_hit(queries[0]) == [3]


def test_multi_part_shapes_count_any_part():
    corners = block_corners([0.0], [0.0], [0.0], S)
    obstacles = Obstacles([1], corners, [True], {1: 0})
    pads = grasp_finger_corners(GEOM, 0.0, 0.0, 0.0, np.arange(2))  # around block 1
    fixed, mask = obstacles.query(pads)
    assert not fixed.any() and not mask.any()  # a grasp's own fingers miss its block
    shifted = grasp_finger_corners(GEOM, 0.03, 0.0, 0.0, np.arange(2))
    _, mask = obstacles.query(shifted)
    assert mask.tolist() == [[1], [0]]  # grasp 0's left pad now lands on block 1


def test_polygons_built_in_bulk_match_shapely_boxes():
    p = poly(block_corners(0.0, 0.0, 0.0, 1.0))
    assert p.equals(shapely.box(-0.5, -0.5, 0.5, 0.5))


def test_masks_hold_any_number_of_blocks():
    # 150 movable blocks in a row: a shape over the last two sets bits 148 and 149 (word 2)
    n = 150
    corners = block_corners(np.arange(n) * 0.06, np.zeros(n), np.zeros(n), S)
    obstacles = Obstacles(list(range(n)), corners, [True] * n, {k: k for k in range(n)})
    _, mask = obstacles.query(block_corners(148.5 * 0.06, 0.0, 0.0, S)[None, None])
    assert mask.shape == (1, 3)
    assert popcount(mask).tolist() == [2]
    assert mask_to_ids(mask[0], list(range(n))) == [148, 149]


def projected_overlap(a: np.ndarray, b: np.ndarray) -> float:
    """The least overlap of the two rectangles' corner projections on their four edge
    directions, corner by corner (the separating-axis test, spelled out)."""
    axes = [e / np.linalg.norm(e) for r in (a, b) for e in (r[1] - r[0], r[2] - r[1])]
    return min(min((a @ u).max(), (b @ u).max()) - max((a @ u).min(), (b @ u).min())
               for u in axes)


def test_penetration_from_frames_is_the_separating_axis_overlap():
    """Random rectangles of any yaw and size, and a grid's neighbours 3 mm apart, touching
    and overlapping: the depth from per-shape frames is the corner projections' overlap,
    positive exactly where shapely finds a shared area."""
    rng = np.random.default_rng(7)
    k = 400
    a = rect_corners(rng.uniform(0, .2, k), rng.uniform(0, .2, k), rng.uniform(-3, 3, k),
                     rng.uniform(.01, .1, k), rng.uniform(.01, .1, k))
    b = rect_corners(rng.uniform(0, .2, k), rng.uniform(0, .2, k), rng.uniform(-3, 3, k),
                     rng.uniform(.01, .1, k), rng.uniform(.01, .1, k))
    steps = np.array([S + 0.003, S, S - 0.002])
    grid_a = block_corners(np.zeros(3), np.zeros(3), np.zeros(3), S)
    grid_b = block_corners(steps, np.zeros(3), np.full(3, math.pi / 2), S)
    a, b = np.concatenate([a, grid_a]), np.concatenate([b, grid_b])
    depth = penetration(frames(a), frames(b))
    expected = np.array([projected_overlap(p, q) for p, q in zip(a, b, strict=True)])
    assert np.allclose(depth, expected, atol=1e-12)
    assert depth[-3] < 0 and abs(depth[-2]) < 1e-12 and depth[-1] == pytest.approx(0.002)
    shared = shapely.area(shapely.intersection(to_polygons(a), to_polygons(b)))
    clear = np.abs(depth) > 1e-9
    assert np.array_equal((depth > 0)[clear], (shared > 1e-12)[clear])

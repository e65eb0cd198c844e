"""Floor tag groups of paper 003 (Sec. 3.3, Fig. 6): tag counts and even spacing, ids, outline geometry, the
paper's same-perimeter sizes, reading a tag, and validation messages that name the field."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_common.geometry import point_segment_distance
from rfidnav_common.tag_groups import (
    HF_READ_RANGE_M,
    SHAPES,
    TagGroup,
    minimum_width,
    paper_size_for_separation,
    tags_in_range,
)

pytestmark = pytest.mark.tier("unit")

PERIMETER_PER_SIZE = {"cross": 2.0, "circle": math.pi, "triangle": 3.0, "square": 4.0}


def outline_distance(group: TagGroup, points: np.ndarray) -> np.ndarray:
    """Distance of each point from the group's outline polylines."""
    distances = [point_segment_distance(points, a, b)
                 for piece in group.outline_segments() for a, b in zip(piece[:-1], piece[1:])]
    return np.min(distances, axis=0)


@pytest.mark.parametrize(("shape", "count"), [("cross", 13), ("circle", 19), ("triangle", 18), ("square", 24)])
def test_prototype_size_groups_have_the_expected_tag_counts(shape: str, count: int) -> None:
    # 30 cm at 5 cm: cross arms of 15 cm get 3 gaps each plus the shared centre; the circle's 94.2 cm outline
    # gets 19 gaps; triangle and square sides get 6 gaps each, the corners shared.
    assert len(TagGroup("G", shape, (0.0, 0.0)).tags()) == count


@pytest.mark.parametrize("shape", SHAPES)
def test_tags_lie_on_the_outline_evenly_spaced_with_unique_ids(shape: str) -> None:
    group = TagGroup("G7", shape, (1.2, -0.4), size_m=0.37, rotation_rad=0.3, tag_spacing_m=0.045)
    tags = group.tags()
    ids = [tag_id for tag_id, _ in tags]
    assert len(set(ids)) == len(ids)
    assert ids[:2] == ["G7-00", "G7-01"]
    positions = np.array([position for _, position in tags])
    assert np.all(outline_distance(group, positions) < 1e-4 * group.size_m)  # the circle's 256-gon is inscribed
    # No two tags coincide, and the nearest-neighbour gaps are all the same: one gap length per shape
    # (the circle's is a chord of the true circle, which the 256-gon follows to 1e-4 R).
    gaps = np.linalg.norm(positions[:, None] - positions[None, :], axis=2)
    np.fill_diagonal(gaps, np.inf)
    nearest = gaps.min(axis=1)
    assert nearest.min() > 0.5 * group.tag_spacing_m
    assert np.ptp(nearest) < 1e-9
    assert abs(nearest[0] - group.tag_spacing_m) < 0.2 * group.tag_spacing_m


def test_cross_tags_are_the_centre_then_each_arm_outwards() -> None:
    positions = TagGroup("C", "cross", (0.0, 0.0), size_m=0.30, rotation_rad=0.0).tag_positions()
    np.testing.assert_allclose(positions[0], [0.0, 0.0])
    np.testing.assert_allclose(positions[1:4], [[0.05, 0.0], [0.10, 0.0], [0.15, 0.0]], atol=1e-12)
    np.testing.assert_allclose(positions[10:13], [[0.0, -0.05], [0.0, -0.10], [0.0, -0.15]], atol=1e-12)


@pytest.mark.parametrize("shape", SHAPES)
def test_rotation_and_centre_move_the_group_rigidly(shape: str) -> None:
    base = TagGroup("R", shape, (0.0, 0.0), size_m=0.25).tag_positions()
    angle = 0.7
    moved = TagGroup("R", shape, (2.0, 3.0), size_m=0.25, rotation_rad=angle).tag_positions()
    c, s = math.cos(angle), math.sin(angle)
    np.testing.assert_allclose(moved, base @ np.array([[c, s], [-s, c]]) + [2.0, 3.0], atol=1e-12)


@pytest.mark.parametrize("shape", SHAPES)
def test_outline_length_and_minimum_width(shape: str) -> None:
    size = 0.3
    group = TagGroup("W", shape, (0.0, 0.0), size_m=size, rotation_rad=0.2)
    pieces = group.outline_segments()
    length = sum(np.linalg.norm(np.diff(piece, axis=0), axis=1).sum() for piece in pieces)
    assert length == pytest.approx(PERIMETER_PER_SIZE[shape] * size, rel=1e-4)
    points = np.vstack(pieces)
    directions = 0.2 + np.linspace(0.0, math.pi, 3601)  # on the grid: the rotation plus multiples of pi/3600
    projections = points @ np.vstack([np.cos(directions), np.sin(directions)])
    assert np.ptp(projections, axis=0).min() == pytest.approx(minimum_width(shape, size), rel=1e-4)


def test_paper_sizes_share_the_circle_perimeter() -> None:
    d = 0.03
    separation = 2.0 * math.pi * d
    expected = {"circle": 2 * math.pi * d, "cross": math.pi ** 2 * d, "triangle": 2 * math.pi ** 2 * d / 3,
                "square": math.pi ** 2 * d / 2}
    for shape, size in expected.items():
        assert paper_size_for_separation(shape, separation) == pytest.approx(size)
        assert PERIMETER_PER_SIZE[shape] * size == pytest.approx(2 * math.pi ** 2 * d)


def test_hf_reader_at_the_default_spacing_reads_every_outline_point() -> None:
    # Spacing <= 2 x read range: any path over the outline passes within range of a tag.
    for shape in SHAPES:
        group = TagGroup("H", shape, (0.0, 0.0))
        samples = np.vstack([piece[:-1] + t * np.diff(piece, axis=0)
                             for piece in group.outline_segments() for t in np.linspace(0.0, 1.0, 50)])
        positions = group.tag_positions()
        nearest = np.min(np.linalg.norm(samples[:, None] - positions[None], axis=2), axis=1)
        assert nearest.max() <= HF_READ_RANGE_M


def test_tags_in_range_returns_indices_within_the_read_disc() -> None:
    positions = np.array([[0.0, 0.0], [0.04, 0.0], [0.06, 0.0], [0.0, -0.05]])
    np.testing.assert_array_equal(tags_in_range(positions, 0.0, 0.0, 0.05), [0, 1, 3])
    assert tags_in_range(positions, 1.0, 1.0, 0.05).size == 0
    assert tags_in_range(np.empty((0, 2)), 0.0, 0.0, 0.05).size == 0


@pytest.mark.parametrize(("changes", "field"), [
    ({"group_id": ""}, "group_id"),
    ({"shape": "hexagon"}, "shape"),
    ({"centre": (0.0,)}, "centre"),
    ({"centre": (0.0, math.nan)}, "centre"),
    ({"size_m": 0.0}, "size_m"),
    ({"size_m": True}, "size_m"),
    ({"rotation_rad": math.inf}, "rotation_rad"),
    ({"tag_spacing_m": -0.05}, "tag_spacing_m"),
])
def test_invalid_groups_are_rejected_naming_the_field(changes: dict, field: str) -> None:
    arguments = {"group_id": "A", "shape": "cross", "centre": (0.0, 0.0)} | changes
    with pytest.raises(ValueError, match=rf"\b{field}\b"):
        TagGroup(**arguments)


def test_paper_size_rejects_an_unknown_shape() -> None:
    with pytest.raises(ValueError, match="shape"):
        paper_size_for_separation("hexagon", 0.2)

"""Tag deployments and self-describing tag IDs (paper 000 sections 3.1, 3.2, 6.4): property tests of the ID
encoding, coverage and counts of the three lattices, and the geometric segment walk."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rfidnav_common.tag_lattice import (
    COORDINATE_MAX,
    COORDINATE_MIN,
    LAYOUTS,
    DeploymentError,
    Lattice,
    TagIdError,
    decode_tag_id,
    deinterleave,
    encode_tag_id,
    interleave,
    make_deployment,
    partition_centre,
    partitions_along_segment,
    spacing_for,
)

pytestmark = pytest.mark.tier("unit")

coordinates = st.integers(min_value=COORDINATE_MIN, max_value=COORDINATE_MAX)
layouts = st.sampled_from(LAYOUTS)
spacings = st.integers(min_value=1, max_value=(1 << 24) - 1).map(lambda um: um * 1e-6)


@given(coordinates, coordinates)
def test_interleaving_round_trips_over_the_whole_coordinate_range(x: int, y: int) -> None:
    assert deinterleave(interleave(x, y)) == (x, y)


@given(layouts, spacings, coordinates, coordinates)
def test_tag_ids_round_trip_as_96_bit_upper_case_epcs(layout: str, spacing: float, x: int, y: int) -> None:
    epc = encode_tag_id(layout, spacing, (x, y))
    assert len(epc) == 24 and epc == epc.upper() and int(epc, 16) >> 92 == 0xA
    decoded = decode_tag_id(epc)
    assert decoded.layout == layout
    assert decoded.coordinate == (x, y)
    assert decoded.spacing_m == pytest.approx(spacing, abs=1e-12)


@given(st.integers(min_value=-1000, max_value=1000), st.integers(min_value=-1000, max_value=1000))
def test_interleaving_keeps_spatial_order_along_each_axis(x: int, y: int) -> None:
    # Offset binary keeps the Z-order monotone in each coordinate, across zero too (paper 000 sec. 3.2).
    assert interleave(x, y) < interleave(x + 1, y)
    assert interleave(x, y) < interleave(x, y + 1)


def test_interleaving_matches_the_papers_bit_vector() -> None:
    # x bits at odd positions, y bits at even positions: tv = {x1, y1, x2, y2, ...} from the top.
    bias = 1 << 31
    assert interleave(1 - bias, 0 - bias) == 0b10
    assert interleave(0 - bias, 1 - bias) == 0b01
    assert interleave(3 - bias, 0 - bias) == 0b1010


@pytest.mark.parametrize("epc, problem", [
    ("E2801160600002", "96-bit"), ("ZZ" * 12, "hexadecimal"), ("E2" + "0" * 22, "header"),
    ("A2000000" + "0" * 16, "zero lattice spacing"), ("A7" + "0" * 22, "header")])
def test_foreign_or_broken_ids_do_not_decode(epc: str, problem: str) -> None:
    with pytest.raises(TagIdError, match=problem):
        decode_tag_id(epc)


@pytest.mark.parametrize("side_factor", [math.sqrt(3.0), 1.5, 2.7])
def test_equation_1_generalised_to_any_side(side_factor: float) -> None:
    r = 0.2
    lattice = Lattice("triangular", side_factor * r)
    s = lattice.spacing_m
    x, y = lattice.position((3, 2))
    assert (x, y) == pytest.approx((2 / 2 * s + 3 * s, 2 * s * math.sqrt(3) / 2))
    if side_factor == math.sqrt(3.0):   # the paper's form: y = y^ * (3/2) r
        assert y == pytest.approx(2 * 1.5 * r)
    # Every neighbour of a vertex is one side away: the lattice is equilateral.
    neighbours = [(1, 0), (0, 1), (-1, 1), (-1, 0), (0, -1), (1, -1)]
    for di, dj in neighbours:
        nx, ny = lattice.position((3 + di, 2 + dj))
        assert math.hypot(nx - x, ny - y) == pytest.approx(s)


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("r", [0.02, 0.2, 0.5])
def test_every_deployment_covers_its_area(layout: str, r: float) -> None:
    deployment = make_deployment(layout, r, (0.0, 0.0, 5.0, 5.0))
    rng = np.random.default_rng(7)
    step = r / 8.0 if r > 0.1 else r / 4.0
    dense = np.stack(np.meshgrid(np.arange(0.0, 1.0 + 1e-9, step), np.arange(0.0, 1.0 + 1e-9, step)), -1).reshape(-1, 2)
    points = np.concatenate((dense, rng.uniform(0.0, 5.0, (20000, 2))))
    assert len(deployment.uncovered(points)) == 0
    # And the partition at each of a sample of points is not empty and is read within r.
    for x, y in points[::500]:
        tags = deployment.partition_at(x, y)
        assert tags
        for c in tags:
            tx, ty = deployment.lattice.position(c)
            assert math.hypot(tx - x, ty - y) <= r + 1e-12


def test_a_sparser_than_covering_lattice_leaves_holes() -> None:
    """The coverage check can fail: triangles wider than r*sqrt(3) leave the triangles' centres unread."""
    from rfidnav_common.tag_lattice import Deployment
    r = 0.2
    sparse = Deployment(Lattice("triangular", 1.9 * r), r, (0.0, 0.0, 2.0, 2.0))
    centre = np.array([[0.95 * r, 0.95 * r / math.sqrt(3.0)]])    # centroid of the first triangle
    assert len(sparse.uncovered(centre)) == 1


@pytest.mark.parametrize("layout", LAYOUTS)
def test_tag_count_is_the_number_of_deployed_tags(layout: str) -> None:
    deployment = make_deployment(layout, 0.2, (-1.0, 0.5, 3.0, 4.0))
    coordinates_ = deployment.coordinates()
    assert deployment.tag_count() == len(coordinates_) == len({tuple(c) for c in coordinates_})
    # Each deployed tag's disc reaches into the area; a vertex just outside them does not.
    x_min, y_min, x_max, y_max = deployment.area
    for c in coordinates_:
        x, y = deployment.lattice.position(tuple(c))
        dx, dy = max(x_min - x, 0.0, x - x_max), max(y_min - y, 0.0, y - y_max)
        assert math.hypot(dx, dy) < deployment.read_range_m


def test_triangular_needs_fewer_tags_than_grid_by_the_lattice_density() -> None:
    counts = {layout: make_deployment(layout, 0.02, (0.0, 0.0, 30.0, 30.0)).tag_count() for layout in LAYOUTS}
    # Densities: grid 1/(2 r^2), triangular 1/(3 sqrt3/2 r^2), compressed 1/(9 sqrt3/8 r^2).
    assert 1 - counts["triangular"] / counts["grid"] == pytest.approx(1 - 2 / (1.5 * math.sqrt(3)), abs=0.005)
    assert counts["compressed"] / counts["grid"] == pytest.approx(2 / (9 * math.sqrt(3) / 8), abs=0.005)
    assert 860_000 < counts["triangular"] < 880_000


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("r", [0.02, 0.2, 0.5])
def test_segment_walk_gives_the_read_set_along_the_segment(layout: str, r: float) -> None:
    deployment = make_deployment(layout, r, (0.0, 0.0, 5.0, 5.0))
    rng = np.random.default_rng(11)
    for _ in range(40):
        start, end = tuple(rng.uniform(-0.3, 5.3, 2)), tuple(rng.uniform(-0.3, 5.3, 2))
        pieces = partitions_along_segment(deployment, start, end)
        assert pieces[0].t_start == 0.0 and pieces[-1].t_end == pytest.approx(1.0)
        for before, after in zip(pieces, pieces[1:]):
            assert before.t_end == after.t_start and before.tags != after.tags
        for t in rng.uniform(0.0, 1.0, 30):
            x, y = start[0] + t * (end[0] - start[0]), start[1] + t * (end[1] - start[1])
            piece = next(p for p in pieces if p.t_start <= t <= p.t_end)
            # Away from a boundary (where both sides are right) the point's read set is the piece's.
            if min(t - piece.t_start, piece.t_end - t) * math.dist(start, end) > 1e-6:
                assert deployment.partition_at(x, y) == piece.tags


def test_reader_query_reads_exactly_the_tags_within_r() -> None:
    deployment = make_deployment("triangular", 0.02, (0.0, 0.0, 30.0, 30.0))
    rng = np.random.default_rng(3)
    for x, y in rng.uniform(0.0, 1.0, (200, 2)):
        found = set(deployment.tags_reading(x, y))
        brute = {(i, j) for i in range(-40, 40) for j in range(-3, 40)
                 if math.dist(deployment.lattice.position((i, j)), (x, y)) <= 0.02 and deployment.is_deployed((i, j))}
        assert found == brute and found


def test_partition_location_is_the_mean_of_its_tags() -> None:
    lattice = Lattice("triangular", spacing_for("triangular", 0.2))
    assert partition_centre(lattice, [(0, 0), (1, 0), (0, 1)]) == pytest.approx(
        (lattice.spacing_m / 2, lattice.row_height_m / 3))
    with pytest.raises(ValueError):
        partition_centre(lattice, [])


@pytest.mark.parametrize("layout, r, area, field", [
    ("hexagonal", 0.2, (0, 0, 5, 5), "layout"), ("triangular", 0.0, (0, 0, 5, 5), "read_range_m"),
    ("grid", -1.0, (0, 0, 5, 5), "read_range_m"), ("triangular", math.nan, (0, 0, 5, 5), "read_range_m"),
    ("triangular", 0.2, (0, 0, 0, 5), "area"), ("triangular", 0.2, (0, 5, 5, 1), "area")])
def test_bad_deployments_are_rejected_naming_the_field(layout, r, area, field) -> None:
    with pytest.raises(DeploymentError, match=f"^{field}:"):
        make_deployment(layout, r, area)


@settings(max_examples=50)
@given(st.floats(min_value=-30.0, max_value=30.0), st.floats(min_value=-30.0, max_value=30.0),
       st.sampled_from([0.02, 0.2, 0.5]), layouts)
def test_every_tag_id_decodes_to_where_the_simulator_put_it(x: float, y: float, r: float, layout: str) -> None:
    lattice = Lattice(layout, spacing_for(layout, r))
    for coordinate in lattice.within(x, y, r):
        decoded = decode_tag_id(lattice.tag_id(coordinate))
        assert Lattice(decoded.layout, decoded.spacing_m).position(decoded.coordinate) == \
            pytest.approx(lattice.position(coordinate), abs=1e-12)

"""Rogue-tag rejection: the tags read together in one round lie within ``rogue_distance_factor`` * r of each
other (2 r for a true partition: every tag is within r of the reader). The largest mutually consistent group is
kept, so a single bad or mis-programmed tag cannot throw the robot across the room."""

from __future__ import annotations

import math
from collections.abc import Sequence


def _maximum_cliques(adjacent: list[set[int]]) -> list[set[int]]:
    """Every largest set of mutually adjacent vertices (Bron-Kerbosch with pivoting; rounds read few tags)."""
    best: list[set[int]] = []

    def extend(clique: set[int], candidates: set[int], excluded: set[int]) -> None:
        nonlocal best
        if not candidates and not excluded:
            if not best or len(clique) > len(best[0]):
                best = [clique]
            elif len(clique) == len(best[0]):
                best.append(clique)
            return
        pivot = max(candidates | excluded, key=lambda v: len(adjacent[v] & candidates))
        for vertex in list(candidates - adjacent[pivot]):
            extend(clique | {vertex}, candidates & adjacent[vertex], excluded & adjacent[vertex])
            candidates = candidates - {vertex}
            excluded = excluded | {vertex}

    extend(set(), set(range(len(adjacent))), set())
    return best


def consistent_group(positions: Sequence[tuple[float, float]], limit_m: float,
                     previous: tuple[float, float] | None) -> list[int]:
    """Indices of the largest group of points (in the caller's tie-break order) within ``limit_m`` of each
    other; ties go to the group holding the point closest to ``previous`` (else the earliest point)."""
    count = len(positions)
    limit = limit_m * (1.0 + 1e-9)
    # Plain Python: a round reads a handful of tags, for which numpy's call overhead dominates.
    adjacent = [{m for m in range(count) if m != k and math.dist(positions[k], positions[m]) <= limit}
                for k in range(count)]
    if all(len(neighbours) == count - 1 for neighbours in adjacent):
        return list(range(count))
    groups = _maximum_cliques(adjacent)
    if previous is not None:
        chosen = min(groups, key=lambda group: min(math.dist(positions[k], previous) for k in group))
    else:
        chosen = min(groups, key=min)
    return sorted(chosen)


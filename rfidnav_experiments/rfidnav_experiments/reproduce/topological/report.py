"""reproduce topological: the text tables and the JSON rows (what the results file keeps)."""

from __future__ import annotations

from typing import Any

from rfidnav_common.topological_map import UNKNOWN
from rfidnav_experiments.reproduce.tables import Condition, condition_json_rows, condition_lines, table
from rfidnav_experiments.reproduce.topological.conditions import (
    DEVELOPMENT_FLOORS,
    EVALUATION_FLOORS,
    EVALUATION_SET,
    EXPERIMENT,
    FLOOR_ORDER,
    HISTORY,
    PATH_TARGET,
    POOLED,
    RADII_M,
    ROLES,
    SEEDS,
    TARGET_RATE,
    TARGET_SUCCESS_PCT,
)
from rfidnav_experiments.reproduce.topological.summary import (
    CAUSE_TEXT,
    CAUSES,
    RateSummary,
    failure_counts,
    paired,
    pooled_ours,
    target_met,
)
from rfidnav_experiments.runners.topological import METHODS, MissionRun, load_floor
from rfidnav_scenario.metrics import GOAL_RADIUS_M


def floor_title(floor: str) -> str:
    if floor == POOLED:
        return f"the {len(EVALUATION_FLOORS)} evaluation floors pooled ({', '.join(EVALUATION_FLOORS)})"
    return f"{floor} ({ROLES[floor]}, seed {SEEDS[floor]}{'' if floor not in HISTORY else '; ' + HISTORY[floor]})"


def floor_table(floor: str, summaries: list[RateSummary],
                results: dict[tuple[str, str, float], list[MissionRun]]) -> list[str]:
    rows = []
    for s in summaries:
        if s.floor != floor:
            continue
        difference = paired(results, floor, s.miss_rate, "success") if s.method == "ours" else None
        rows.append([s.method, f"{s.miss_rate * 100:g} %", s.success.text(1.0, 0),
                     s.path_ratio.text(1.0, 3), s.duration_s.text(1.0, 0),
                     f"{s.mean_passages_missed:.2f} / {s.mean_tags_missed:.2f}",
                     f"{s.mean_replans:.2f}", str(s.bumps), str(s.wall_crossings),
                     "-" if difference is None else difference.text(1.0, 1),
                     s.arrived.text(1.0, 0), "-" if s.stop_distance_m is None else f"{s.stop_distance_m:.2f}",
                     " / ".join("-" if w.mean is None else f"{w.mean:.0f}" for w in s.within)])
    return [f"{floor_title(floor)}: success % [95 % Wilson interval] (stopped within {GOAL_RADIUS_M} m of the goal "
            "node), path / shortest and time over the successful missions (± 95 %); ours minus paper, paired by "
            "mission; tag passages missed (truth) / missed tags the executor noticed, a mission; arrived: the "
            "executor's success wherever it stopped, and the median distance from the node "
            f"where those stopped; success within {' / '.join(f'{r:g}' for r in RADII_M)} m",
            *table(["method", "tag misses", "success %", "path / shortest", "time s", "missed / noticed", "replans",
                    "bumps", "wall crossings", "success: ours - paper", "arrived %", "stop m", "within radii %"],
                   rows)]


def failure_lines(counts: dict[str, dict[str, tuple[int, int]]], missions: dict[str, int]) -> list[str]:
    rows = [[CAUSE_TEXT[cause], *(f"{counts[method][cause][0]} ({counts[method][cause][1]})" for method in METHODS)]
            for cause in CAUSES]
    rows.append(["all failures", *(f"{sum(c for c, _ in counts[method].values())} of {missions[method]}"
                                   for method in METHODS)])
    return ["failures of the evaluation missions (every floor and rate) by cause: count (of them with a tag passage "
            "missed)",
            *table(["cause", *METHODS], rows)]


def report_lines(paper: MissionRun, summaries: list[RateSummary], results,
                 condition_rows: list[Condition]) -> list[str]:
    turns = ", ".join(f"{action} at {node}" for node, action in paper.turns) or "none"
    ours = pooled_ours(summaries)
    lines = ["reproduce topological: paper 004, in-process", "", *condition_lines(condition_rows, list(METHODS)), "",
             f"The paper's run (tag 23 -> tag 19, building_fig5, ours): {'success' if paper.success else 'FAILED'} "
             f"({paper.message}); turns: {turns}; driven {paper.path_length_m:.1f} m, shortest "
             f"{paper.shortest_path_m:.1f} m (paper: a right turn, 1.6 m passage, about 8 m)", ""]
    for floor in (POOLED, *FLOOR_ORDER):
        lines += [*floor_table(floor, summaries, results), ""]
    counts = failure_counts(results, EVALUATION_FLOORS)
    evaluated = {method: sum(len(runs) for (floor, name, _), runs in results.items()
                             if floor in EVALUATION_FLOORS and name == method) for method in METHODS}
    lines += [*failure_lines(counts, evaluated), ""]
    met = "met" if target_met(summaries) else "NOT met"
    lines.append(f"target (ours, evaluation floors pooled, {TARGET_RATE * 100:g} % misses: success >= "
                 f"{TARGET_SUCCESS_PCT:g} %, path <= {PATH_TARGET} x shortest): {met} — success "
                 f"{ours.success.text(1.0, 0)}, path {ours.path_ratio.text(1.0, 3)}")
    return lines


def json_rows(paper: MissionRun, summaries: list[RateSummary], results,
              condition_rows: list[Condition]) -> list[dict[str, Any]]:
    rows = condition_json_rows(EXPERIMENT, condition_rows)
    rows.append({"experiment": "paper_run", "setting": {"from_tag": "23", "goal": "g"}, "metric": "path_length_m",
                 "ours": paper.path_length_m, "paper": 8.0, "success": paper.success})
    for s in summaries:
        setting = {"floor": s.floor, "role": "evaluation" if s.floor == POOLED else ROLES[s.floor],
                   "seed": list(EVALUATION_SET.seeds) if s.floor == POOLED else SEEDS[s.floor], "method": s.method,
                   "miss_rate": s.miss_rate, "missions": s.missions}
        figures: list[tuple[str, Any]] = [
            ("missions", s.missions),
            ("success_pct", s.success.mean), ("success_ci95_pct", list(s.success.bounds or ())),
            ("success_ci95_low_pct", s.success.bounds[0] if s.success.bounds else None),
            ("success_ci95_high_pct", s.success.bounds[1] if s.success.bounds else None),
            ("path_over_shortest", s.path_ratio.mean), ("path_over_shortest_ci95", s.path_ratio.half_width),
            ("mean_duration_s", s.duration_s.mean), ("mean_tags_missed", s.mean_tags_missed),
            ("mean_passages_missed", s.mean_passages_missed),
            ("bumps", s.bumps), ("wall_crossings", s.wall_crossings),
            ("arrived_pct", s.arrived.mean), ("median_stop_distance_m", s.stop_distance_m)]
        if s.method == "ours":
            for figure in ("success", "time"):
                difference = paired(results, s.floor, s.miss_rate, figure)
                figures += [(f"paired_{figure}_difference", difference.mean),
                            (f"paired_{figure}_difference_ci95", difference.half_width)]
        rows += [{"experiment": "random_missions", "setting": dict(setting), "metric": metric, "ours": value,
                  "paper": None} for metric, value in figures]
        for radius, success in zip(RADII_M, s.within):
            rows += [{"experiment": "success_radius", "setting": {**setting, "radius_m": radius}, "metric": metric,
                      "ours": value, "paper": None}
                     for metric, value in (("success_within_pct", success.mean),
                                           ("success_within_ci95_pct", list(success.bounds or ())),
                                           ("success_within_ci95_low_pct",
                                            success.bounds[0] if success.bounds else None),
                                           ("success_within_ci95_high_pct",
                                            success.bounds[1] if success.bounds else None))]
    # The failures by cause: over the evaluation (set "evaluation"), and on each development floor apart.
    for name, floors in (("evaluation", EVALUATION_FLOORS), *((floor, (floor,)) for floor in DEVELOPMENT_FLOORS)):
        for method, causes in failure_counts(results, floors).items():
            for cause, (count, missed) in causes.items():
                setting = {"set": name, "method": method, "cause": cause, "means": CAUSE_TEXT[cause]}
                rows += [{"experiment": "failures", "setting": dict(setting), "metric": metric, "ours": value,
                          "paper": None}
                         for metric, value in (("failures", count), ("failures_with_missed_tag", missed))]
            missions = [run for key, runs in results.items() if key[0] in floors and key[1] == method
                        for run in runs]
            rows += [{"experiment": "failures", "setting": {"set": name, "method": method}, "metric": metric,
                      "ours": value, "paper": None}
                     for metric, value in (("missions", len(missions)),
                                           ("failures_total", sum(not run.success for run in missions)))]
    rows += floor_rows()
    return rows


def floor_rows() -> list[dict[str, Any]]:
    """What each floor is: junctions, hallways, mapped dead ends (junctions with one hallway), '?' dead ends,
    nodes with no side opening (hallways only ahead and behind), tags, and the hallways' length."""
    rows = []
    for floor in FLOOR_ORDER:
        robot_map, world = load_floor(floor)
        mapped = {name: [side for side, hallway in node.hallways.items() if hallway.neighbour != UNKNOWN]
                  for name, node in robot_map.nodes.items()}
        figures = {"junctions": len(robot_map.nodes), "hallways": len(robot_map.edges()),
                   "dead_end_nodes": sum(len(sides) == 1 for sides in mapped.values()),
                   "unknown_sides": sum(hallway.neighbour == UNKNOWN for node in robot_map.nodes.values()
                                        for hallway in node.hallways.values()),
                   "straight_through_nodes": sum(len(node.hallways) == 2 and set(node.hallways) in ({"N", "S"},
                                                                                                  {"E", "W"})
                                                 for node in robot_map.nodes.values()),
                   "wall_tags": len(world.wall_tags),
                   "hallway_length_m": sum(robot_map.hallway_length_m(edge.node_a, edge.side_a)
                                           for edge in robot_map.edges()),
                   "north_deg": robot_map.north_deg}
        setting = {"floor": floor, "role": ROLES[floor], "seed": SEEDS[floor]}
        rows += [{"experiment": "floors", "setting": dict(setting), "metric": metric, "ours": value, "paper": None}
                 for metric, value in figures.items()]
    return rows

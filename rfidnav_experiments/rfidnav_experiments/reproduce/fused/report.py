"""reproduce fused: the text report, the conditions' four tables and each world's figures."""

from __future__ import annotations

from rfidnav_experiments.reproduce.fused.conditions import ARRIVING_WORLDS, driver_of, kidnap_times_of, localizers_of
from rfidnav_experiments.reproduce.fused.summary import METRICS, Arrival, FusedRun, figures, recovery_figures
from rfidnav_experiments.reproduce.tables import Condition, Interval, condition_lines, table
from rfidnav_experiments.runners.fused import CONVERGED_FOR_S, CONVERGED_M


def condition_columns(rows: list[Condition]) -> list[str]:
    return list(rows[0].values)


def conditions_report(parts: dict[str, list[Condition]]) -> list[str]:
    lines = []
    for title, rows in parts.items():
        lines += [f"{title}:", *condition_lines(rows, condition_columns(rows)), ""]
    return lines


def report_lines(results: list[FusedRun], runs: int) -> list[str]:
    lines = [f"reproduce fused: the fused localizer beside each paper's own, same runs ({runs} per world)", ""]
    for world in dict.fromkeys(r.world for r in results):
        arrived = sum(r.success for r in results if r.world == world)
        names = localizers_of(world)
        lines += [f"{world} ({driver_of(world)}; {arrived}/{runs} arrived)"]
        world_figures = figures(results, world)
        rows = [[label, *(_text(world_figures[metric][name], scale, digits) for name in names)]
                for metric, (label, scale, digits) in METRICS.items()]
        lines += table(["metric", *names], rows)
        if len(names) > 1:
            rows = [[label, _text(world_figures[metric][f"{name} - fused"], scale, digits)]
                    for metric, (label, scale, digits) in METRICS.items() for name in names[1:]
                    for label in (f"{METRICS[metric][0]}: {name} - fused",)]
            lines += table(["paired difference", "mean [95 % interval]"], rows)
        if world in ARRIVING_WORLDS:
            arrival = Arrival.of(results, world)
            low, high = arrival.rate.bounds or (0.0, 0.0)
            lines += [f"arrived {arrival.arrived}/{arrival.runs} (95 % interval {low:.0f}-{high:.0f} %); true "
                      f"distance from the target at the end {arrival.final_error_m.text(1.0, 3)} m"]
        recovery = recovery_figures(results, world)
        found = [f"from the start {recovery['global_s'][0].text(1.0, 1)} s in {recovery['global_s'][1]}/{runs} runs"]
        if "kidnap_recovery_s" in recovery:
            late_s, kidnap_s = kidnap_times_of(world)
            found += [f"started at {late_s:g} s {recovery['late_global_s'][0].text(1.0, 1)} s in "
                      f"{recovery['late_global_s'][1]}/{runs}",
                      f"kidnapped at {kidnap_s:g} s, found again after "
                      f"{recovery['kidnap_recovery_s'][0].text(1.0, 1)} s in {recovery['kidnap_recovery_s'][1]}/{runs}"]
        lines += [f"global localization (error below {CONVERGED_M:g} m for {CONVERGED_FOR_S:g} s): {'; '.join(found)}",
                  ""]
    return lines


def _text(interval: Interval, scale: float, digits: int) -> str:
    return interval.text(scale, digits) if interval.n else "-"     # a localizer without such a figure

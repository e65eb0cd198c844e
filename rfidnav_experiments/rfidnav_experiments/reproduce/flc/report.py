"""reproduce flc: the text report: the conditions, the RMSE beside the paper's, the error envelope, the approach to
the first tag, the random routes and the calibration's spread."""

from __future__ import annotations

from typing import Any

from rfidnav_experiments.calibrate.flc import CALIBRATION_SEEDS, FITTED_SCENARIOS, spread_lines
from rfidnav_experiments.evaluation import current
from rfidnav_experiments.reproduce.flc.conditions import (
    BASELINE,
    EXPERIMENT,
    PAPER,
    PAPER_TIME_TO_FIRST_TAG_S,
    PARAM_SETS,
    RANDOM,
    SCENARIOS,
    TIME_SCENARIO,
    TOLERANCE,
    TUNED,
    TUNED_FRACTION,
    role,
)
from rfidnav_experiments.reproduce.flc.provenance import calibration_record
from rfidnav_experiments.reproduce.flc.summary import Summary, paired_difference, succeeded
from rfidnav_experiments.reproduce.tables import Condition, condition_lines, table
from rfidnav_experiments.runners.tag_route import RouteRun
from rfidnav_scenario.metrics import FIRST_TAG_RADIUS_M


def cm(value_m: float | None, digits: int = 1) -> str:
    return "-" if value_m is None else f"{value_m * 100:.{digits}f}"


def against_paper(summary: Summary) -> str:
    """The baseline's RMSE against the paper's: the relative difference and whether it is within tolerance."""
    if summary.rmse.mean is None:
        return "-"
    paper = PAPER[summary.scenario].rmse_m
    off = summary.rmse.mean / paper - 1.0
    within = abs(off) <= TOLERANCE[role(summary.scenario)]
    return f"{off * 100:+.0f} % ({'within' if within else 'outside'} ±{TOLERANCE[role(summary.scenario)] * 100:.0f} %)"


def rmse_table(summaries: dict[tuple[str, str], Summary], results: dict[tuple[str, str], list[RouteRun]]) -> list[str]:
    rows = []
    for scenario in SCENARIOS:
        baseline, tuned = summaries[(BASELINE, scenario)], summaries[(TUNED, scenario)]
        difference = paired_difference(results, scenario)
        target = None if baseline.rmse.mean is None else TUNED_FRACTION * baseline.rmse.mean
        met = "-" if tuned.rmse.mean is None or target is None else ("yes" if tuned.rmse.mean <= target else "no")
        rows.append([scenario, f"{role(scenario)} / development", cm(PAPER[scenario].rmse_m), baseline.rmse.text(),
                     against_paper(baseline), tuned.rmse.text(), difference.text(),
                     "-" if target is None else f"<= {cm(target, 2)}", met])
    return ["tracking RMSE [cm] from the first tag's read area to the last (ground truth): mean ± 95 % interval "
            f"over the successful runs (n); the difference is paired, {TUNED} minus {BASELINE} on the same seeds; "
            f"role: for {BASELINE} / for {TUNED} (developed on these four routes)",
            *table(["scenario", "role", "paper", BASELINE, f"{BASELINE} vs paper", TUNED, "difference",
                    f"target {TUNED} (baseline/2)", "met?"], rows)]


def envelope_table(summaries: dict[tuple[str, str], Summary]) -> list[str]:
    rows = []
    for scenario in SCENARIOS:
        low, high = PAPER[scenario].envelope_m
        rows.append([scenario, f"{low * 100:+.0f}..{high * 100:+.0f}",
                     *(cm(summaries[(params, scenario)].max_abs_mean_m) for params in PARAM_SETS),
                     *(f"{summaries[(params, scenario)].successes}/{summaries[(params, scenario)].runs}"
                       for params in PARAM_SETS)])
    return ["max |e| [cm] (mean over successful runs) beside the paper's error envelope; runs reaching every tag",
            *table(["scenario", "paper envelope", f"{BASELINE} max|e|", f"{TUNED} max|e|",
                    f"{BASELINE} success", f"{TUNED} success"], rows)]


def random_lines(summaries: dict[tuple[str, str], Summary], results: dict[tuple[str, str], list[RouteRun]],
                 route_seeds: list[int]) -> list[str]:
    """Both on the fresh random routes (one run each, on the route's seed)."""
    if not route_seeds or (BASELINE, RANDOM) not in summaries:
        return []
    difference = paired_difference(results, RANDOM)
    rows = [[params, summaries[(params, RANDOM)].rmse.text(),
             cm(summaries[(params, RANDOM)].max_abs_mean_m),
             f"{summaries[(params, RANDOM)].successes}/{summaries[(params, RANDOM)].runs}",
             summaries[(params, RANDOM)].search.text(1.0, 1)] for params in PARAM_SETS]
    lines = [f"fresh random routes ({len(route_seeds)}, ledger set '{current(EXPERIMENT).name}': 6 ceiling tags, "
             "legs 2-12 m, turns 20-150 degrees; neither controller was developed on them), RMSE [cm] over routes",
             *table(["params", "RMSE", "max|e| [cm]", "success", "searching [s]"], rows),
             f"  paired difference {TUNED} minus {BASELINE}: {difference.text()} cm"]
    for params in PARAM_SETS:
        per_route = ", ".join(f"{run.seed}: {cm(run.metrics.tracking_rmse_m, 1) if succeeded(run) else 'failed'}"
                              for run in results[(params, RANDOM)])
        lines.append(f"  {params} by route seed: {per_route}")
    return lines


def calibration_lines(record: dict[str, Any]) -> list[str]:
    """The calibration's uncertainty, from flc_paper_calibration.json."""
    held = record.get("held_out")
    if not held:
        return ["calibration: flc_paper_calibration.json has no held-out spread (rerun ./rfidnav calibrate flc)"]
    chosen = record["chosen"]
    return [f"calibration (./rfidnav calibrate flc, seeds {', '.join(map(str, record['seeds']))}): noise "
            f"{chosen['phase_noise_rad_per_m']:g} rad/m, output scale {chosen['output_scale']:g}, "
            f"{'inside' if record.get('interior') else 'on the edge of'} the grid; fitted figures there "
            f"{cm(chosen['rmse_m']['line_follow_90'], 2)} / {cm(chosen['rmse_m']['line_follow_0'], 2)} cm, approach "
            f"{chosen['approach_s']:.1f} s (paper 3.4 / 9.3 cm, ~110 s)",
            f"held-out RMSE over the grid points within {held['near_best'] * 100:.0f} % of the best objective "
            "(calibration seeds): how far the baseline's held-out figures rest on the fit's tie-break",
            *spread_lines(held["spread"])]


def first_tag_lines(summaries: dict[tuple[str, str], Summary], results: dict[tuple[str, str], list[RouteRun]]) \
        -> list[str]:
    baseline = summaries[(BASELINE, TIME_SCENARIO)].first_arrival
    lines = [f"{TIME_SCENARIO}: the approach to the first tag (paper: about {PAPER_TIME_TO_FIRST_TAG_S:.0f} s to "
             f"within {FIRST_TAG_RADIUS_M * 100:.0f} cm; target for {TUNED}: at most half {BASELINE}'s)"]
    for params in PARAM_SETS:
        s = summaries[(params, TIME_SCENARIO)]
        within = s.time_to_first_tag_mean_s
        came = f"mean {within:.1f} s over those runs" if within is not None else "no time to compare"
        lines.append(f"  {params}: entered the first tag's read area after {s.approach.text(1.0, 1)} s; "
                     f"arrival declared after {s.first_arrival.text(1.0, 1)} s; "
                     f"{len(s.first_tag_times_s)}/{s.runs} runs came within {FIRST_TAG_RADIUS_M * 100:.0f} cm "
                     f"({came})")
    difference = paired_difference(results, TIME_SCENARIO, "arrival")
    tuned = summaries[(TUNED, TIME_SCENARIO)].first_arrival
    met = ("-" if tuned.mean is None or baseline.mean is None else
           "met" if tuned.mean <= TUNED_FRACTION * baseline.mean else "not met")
    lines.append(f"  paired difference {TUNED} minus {BASELINE}: {difference.text(1.0, 1)} s; target {met}")
    return lines


def human_report(summaries: dict[tuple[str, str], Summary], results: dict[tuple[str, str], list[RouteRun]],
                 seeds: list[int], condition_rows: list[Condition], route_seeds: list[int] | None = None,
                 record: dict[str, Any] | None = None) -> str:
    lines = [f"reproduce flc: paper 001 section V, in-process; evaluation seeds {seeds[0]}-{seeds[-1]} "
             f"({len(seeds)} per setting; the calibration used seeds "
             f"{', '.join(map(str, CALIBRATION_SEEDS))}); fitted: {', '.join(FITTED_SCENARIOS)}, the rest held out",
             "", *condition_lines(condition_rows, PARAM_SETS), "", *rmse_table(summaries, results), "",
             *envelope_table(summaries), "", *first_tag_lines(summaries, results), "",
             *random_lines(summaries, results, route_seeds or []), "",
             *calibration_lines(record if record is not None else calibration_record()), "",
             f"wall crossings (ground truth) in the {sum(s.runs for s in summaries.values())} runs: "
             f"{sum(s.wall_crossings for s in summaries.values())} (a run that crosses one is no success)"]
    return "\n".join(lines)

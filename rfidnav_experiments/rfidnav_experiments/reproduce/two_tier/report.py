"""reproduce two_tier: the text tables the command prints."""

from __future__ import annotations

import statistics

import numpy as np

from rfidnav_experiments import evaluation
from rfidnav_experiments.reproduce.tables import Condition, Interval, condition_lines, paired_interval, table
from rfidnav_experiments.reproduce.two_tier.conditions import (
    DEVELOPMENT_SEED,
    EVALUATION,
    EVALUATION_SEED,
    EXPERIMENT,
    FIG10_DISTANCES_M,
    FIG10_SIZE_M,
    HOMES,
    LATENCY,
    LEGS,
    LONG_ROUTE,
    MAIN_VARIANT,
    METHODS,
    OURS,
    PAPER,
    PAPER_FIG10_M,
    PERIOD,
    ROUTES,
    SENSITIVITY_VARIANTS,
    TARGET_FIX_ERROR_M,
    TEST_POINTS,
    Variant,
    delay_text,
    spiral_methods,
)
from rfidnav_experiments.reproduce.two_tier.navigations import HomeRun, Leg
from rfidnav_experiments.reproduce.two_tier.searches import Search
from rfidnav_experiments.reproduce.two_tier.summary import (
    Crossings,
    FixFigures,
    Median,
    done,
    home_figures,
    legs_at,
    paired_difference,
    spiral_point,
    variant_difference,
)


def _cm(value_m: float | None, digits: int = 0) -> str:
    return "-" if value_m is None else f"{value_m * 100:.{digits}f}"


def fig10_lines(spiral: dict[str, dict[float, list[Search]]], runs: int) -> list[str]:
    methods = spiral_methods()
    lines = [f"Fig. 10: spiral search length [cm] from a {FIG10_SIZE_M * 100:g} cm cross, {runs} random placements "
             "per distance, the same for both; mean ± 95 % interval over the placements where a poll read a tag (n), "
             "the share found [Wilson 95 %]; difference paired, ours minus the paper's, on the placements both found",
             "  " + "; ".join(f"{method}: d = {spiral.d_m * 100:.2f} cm at {spiral.speed_mps:g} m/s"
                              for method, spiral in methods.items())]
    rows = []
    for distance in FIG10_DISTANCES_M:
        points = {method: spiral_point(spiral[method][distance]) for method in METHODS}
        paper = PAPER_FIG10_M.get(distance)
        rows.append([f"{distance * 100:g}", "-" if paper is None else f"~{paper * 100:.0f}",
                     *(points[m].length.text(100.0, 0) for m in METHODS),
                     *(points[m].found.text(1.0, 1) for m in METHODS),
                     paired_difference(spiral, distance).text(100.0, 0)])
    lines += table(["distance cm", "paper's figure", PAPER, OURS, f"{PAPER} found %", f"{OURS} found %",
                    "difference"], rows)
    return lines


def sensitivity_lines(sensitivity: dict[Variant, dict[str, dict[float, list[Search]]]],
                      main: dict[str, dict[float, list[Search]]], runs: int) -> list[str]:
    """Fig. 10 under each distance definition and each reading of the reader's delay, the same placements."""
    variants = (MAIN_VARIANT, *SENSITIVITY_VARIANTS)
    lines = [f"Fig. 10 sensitivity: search length [cm], mean ± 95 % interval (n found of {runs}); the distance to the "
             "group's centre or to its nearest tag; the reader's delay as its period (" + delay_text(PERIOD) + ") or "
             "as a latency (" + delay_text(LATENCY) + "); the same placements (bearing, rotation, heading, reader "
             "seed). Paired: the variant less the main figure (group_centre, period), on the placements both found"]
    for method in METHODS:
        rows = []
        for distance in FIG10_DISTANCES_M:
            paper = PAPER_FIG10_M.get(distance)
            cells = [f"{distance * 100:g}", "-" if paper is None else f"~{paper * 100:.0f}"]
            for variant in variants:
                spiral = main if variant == MAIN_VARIANT else sensitivity[variant]
                cells.append(spiral_point(spiral[method][distance]).length.text(100.0, 0))
            cells += [variant_difference(sensitivity[variant], main, method, distance).text(100.0, 0)
                      for variant in SENSITIVITY_VARIANTS]
            rows.append(cells)
        lines += [f"{method}'s search:"]
        lines += table(["distance cm", "paper's figure", *(f"{to}, {delay}" for to, delay in variants),
                        *(f"{to}, {delay} - main" for to, delay in SENSITIVITY_VARIANTS)], rows)
    return lines


def fig10_against_paper(spiral: dict[str, dict[float, list[Search]]]) -> list[str]:
    lines = ["Fig. 10 at the paper's distances (sec. 4.2):"]
    for distance, paper in PAPER_FIG10_M.items():
        points = {method: spiral_point(spiral[method][distance]) for method in METHODS}
        parts = []
        for method in METHODS:
            mean = points[method].length.mean
            off = "-" if mean is None else f"{(mean / paper - 1.0) * 100:+.0f} %"
            parts.append(f"{method} {points[method].length.text(100.0, 0)} cm ({off})")
        lines.append(f"  {distance * 100:g} cm: paper ~{paper * 100:.0f} cm; " + "; ".join(parts)
                     + f"; ours minus paper {paired_difference(spiral, distance).text(100.0, 0)} cm")
    return lines


def fix_lines(legs: list[Leg], fixes: FixFigures) -> list[str]:
    lines = ["Fig. 12: position error [cm] at the turning points: median [95 % interval] (n); fingerprinting "
             "alone, the two-tier scheme's last tag fix on arriving, ours and the paper's way on the same polls"]
    for route, (_, points) in ROUTES.items():
        lines += [f"{route}:"]
        lines += table(["turning point", "fingerprinting", f"two-tier {OURS}", f"two-tier {PAPER}"],
                       [[point, Median.of([leg.fingerprint_m for leg in legs_at(legs, route, point)]).text(100.0, 0),
                         Median.of([leg.fix_m for leg in legs_at(legs, route, point) if leg.fix_m is not None]).text(),
                         Median.of([leg.tag_position_m for leg in legs_at(legs, route, point)
                                    if leg.tag_position_m is not None]).text()] for point in points])
    met = fixes.target_met
    verdict = "-" if met is None else ("met" if met else "not met")
    fingerprinting = Median.of([leg.fingerprint_m for leg in legs])
    lines += [f"all turning points: fingerprinting median {fingerprinting.text(100.0, 0)} cm (RADAR: 2-3 m)",
              f"  tag fix, ours: {fixes.at_turning_points[OURS].text()} cm; the paper's way (the tags read): "
              f"{fixes.at_turning_points[PAPER].text()} cm; ours minus the paper's, paired: {fixes.paired_m.text()} cm",
              f"  every tag fix on the way: ours {fixes.all_fixes[OURS].text()} cm, the paper's way "
              f"{fixes.all_fixes[PAPER].text()} cm; legs that did not arrive with a fix: {fixes.failed_legs}",
              f"target (ours, median tag-fix error at the turning points <= {TARGET_FIX_ERROR_M * 100:g} cm with the "
              f"reader's delay and failures): {verdict}"]
    return lines


def report_lines(condition_rows: list[Condition], spiral, sensitivity, theorem, moving, legs: list[Leg],
                 fixes: FixFigures, radio, crossings: Crossings, grid_count: int, survey_count: int, runs: int,
                 fig10_runs: int, seed: int) -> list[str]:
    lines = [f"reproduce two_tier: paper 003 section 4.2, in-process; seed {seed}: "
             f"{evaluation.seed_set(EXPERIMENT, seed, DEVELOPMENT_SEED)} "
             f"(the ledger's evaluation set is '{EVALUATION.name}', "
             f"seed {EVALUATION_SEED}; development seed {DEVELOPMENT_SEED}); {runs} runs per route",
             "", *condition_lines(condition_rows, METHODS), "", *fig10_lines(spiral, fig10_runs), "",
             *fig10_against_paper(spiral), "", *sensitivity_lines(sensitivity, spiral, fig10_runs), "",
             "Theorem 1: expected search length [cm] for a Gaussian tier-one error sd sigma (our spiral, a reader that "
             "reads continuously, as the theorem assumes)"]
    lines += table(["sigma cm", "as printed", "Rayleigh form", "simulated", "simulated / Rayleigh"],
                   [[f"{s * 100:g}", f"{p * 100:.0f}", f"{r * 100:.0f}", f"{m * 100:.0f}", f"{m / r:.2f}"]
                    for s, p, r, m in theorem])
    lines += ["", f"Fig. 11: final position error [cm] from {LONG_ROUTE[0][:2]} to {LONG_ROUTE[1]}: median [95 % "
                  "interval] (n); paper: indirect moving accumulates less error"]
    lines += table(["moving", "median", "mean", "max", "failed"],
                   [[kind, Median.of(done(errors)).text(), Interval.of(done(errors)).text(100.0, 1),
                     _cm(max(done(errors), default=None), 1), str(len(errors) - len(done(errors)))]
                    for kind, errors in moving.items()])
    difference = paired_interval(moving["indirect"], moving["direct"])
    lines += [f"indirect minus direct, paired (same streams): {difference.text(100.0, 1)} cm", ""]
    lines += fix_lines(legs, fixes)
    lines += [f"wall crossings (ground truth) in the {crossings.navigations} navigations of Figs. 11 and 12: "
              f"{crossings.count}"]
    lines += ["", f"radio map: tier-one error [cm] at {TEST_POINTS} random points"]
    lines += table(["radio map", "fingerprints", "median", "mean", "p90"],
                   [[kind, str(count), Median.of(v).text(100.0, 0), f"{statistics.fmean(v) * 100:.0f}",
                     f"{np.percentile(v, 90) * 100:.0f}"]
                    for (kind, v), count in zip(radio.items(), (grid_count, survey_count))])
    return lines


def home_lines(results: list[HomeRun], runs: int) -> list[str]:
    lines = [f"homes (ours): each scenario from its start to its goal in-process, {runs} runs each, the same streams "
             "for both kinds of legs; arrived [Wilson 95 %], the final error of those that arrived and the path of "
             "all: median [95 % interval] (n); bumps: steps the walls stopped, in all (runs with none); wall "
             "crossings of the true tracks, in all"]
    rows = []
    for home in HOMES:
        for legs, note in LEGS.items():
            figures = home_figures(results, home, legs)
            rows.append([home, note, figures.arrived.text(1.0, 0), figures.final_error.text(),
                         figures.path_length.text(1.0, 1), f"{figures.bumps} ({figures.runs_without_bumps})",
                         str(figures.wall_crossings)])
    return lines + table(["home", "legs", "arrived %", "final error cm", "path m", "bumps", "crossings"], rows)

"""./rfidnav reproduce fused: the fused localizer beside paper 003's own on the same seeded runs, beside each kind of
evidence alone on the mixed floor, and what its estimate means for tf (map -> odom composed with odom -> base_link is
the estimated pose)."""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from rfidnav_common.frames import map_to_odom
from rfidnav_experiments import evaluation
from rfidnav_experiments.reproduce.fused.conditions import (
    ARRIVING_WORLDS,
    DEVELOPMENT_SEED,
    DRIVING,
    EVALUATION_SEED,
    EXPERIMENT,
    HALLWAY,
    MIXED,
    PARTITION_DRIVING,
    PARTITIONS,
    RING,
    SINGLE_EVIDENCE,
    TIER_ONE,
    WORLDS,
    localizer_file,
    localizers_of,
    reader_file,
)
from rfidnav_experiments.reproduce.fused.jobs import home_run, world_run
from rfidnav_experiments.reproduce.fused.provenance import (
    LOCALIZER_FILES,
    LOCALIZER_NOT_READ,
    LOCALIZER_SOURCES,
    POSE_NAVIGATOR_NOT_READ,
    POSE_NAVIGATOR_SOURCES,
    READER_FILES,
    READER_NOT_READ,
    all_condition_rows,
    conditions,
)
from rfidnav_experiments.reproduce.fused.summary import METRICS, TrackFigures, recovery_keys
from rfidnav_experiments.reproduce.tables import interpreted, is_condition_source
from rfidnav_experiments.reproduce.two_tier import HOMES
from rfidnav_experiments.runners.fused import Track
from rfidnav_localization.fused.filter import PoseEstimate, Update
from rfidnav_localization.fused.localizer import FusedEstimate
from rfidnav_localization.parameters import RfidLocalizerParameters
from rfidnav_planning.parameters import PoseNavigatorParameters
from rfidnav_sim.parameters import ReaderParameters
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("slow")


def field_names(cls: type) -> set[str]:
    return {field.name for field in dataclasses.fields(cls)}


def test_every_parameter_a_run_reads_has_a_row_and_every_other_field_a_reason() -> None:
    rows = {row.setting: row for row in all_condition_rows(conditions(DEVELOPMENT_SEED, 1))}
    for prefix, cls, not_read in (("rfid_localizer", RfidLocalizerParameters, LOCALIZER_NOT_READ),
                                  ("reader", ReaderParameters, READER_NOT_READ),
                                  ("pose_navigator", PoseNavigatorParameters, POSE_NAVIGATOR_NOT_READ)):
        listed = {key.removeprefix(f"{prefix}.") for key in rows if key.startswith(f"{prefix}.")}
        assert field_names(cls) - set(not_read) <= listed, f"{prefix}: fields without a row"
        assert not listed & set(not_read) and set(not_read) <= field_names(cls)
    assert set(LOCALIZER_SOURCES) | set(LOCALIZER_NOT_READ) == field_names(RfidLocalizerParameters)
    assert set(POSE_NAVIGATOR_SOURCES) | set(POSE_NAVIGATOR_NOT_READ) == field_names(PoseNavigatorParameters)
    # Every world's localizer and reader file is a column of the table; paper 003's robot's rows are two_tier's.
    assert {localizer_file(world).name for world in WORLDS} == {path.name for path in LOCALIZER_FILES.values()}
    assert {path.name for world in WORLDS if (path := reader_file(world)) is not None} == \
        {path.name for path in READER_FILES.values()}
    assert {f"world.{world}" for world in WORLDS} <= set(rows)
    for key in ("two_tier_navigator.search_speed_mps", "location_server.k", "robot_sim.footprint_radius_m",
                "compass_sim.noise_sd_deg", "wifi_sim.scan_noise_sd_db"):
        assert key in rows
    assert all(is_condition_source(row.source) for row in rows.values())
    assert rows["reader.rate_hz"].sources is not None and rows["reader.rate_hz"].sources["hf_floor"].startswith(
        interpreted(""))


def test_the_evaluation_seed_is_the_ledgers_and_the_conditions_name_the_set() -> None:
    assert EVALUATION_SEED == evaluation.current(EXPERIMENT).seeds[0] != 401
    seed = {row.setting: row for row in all_condition_rows(conditions(EVALUATION_SEED, 1))}["runs.seed"]
    assert seed.values["value"].startswith(f"{EVALUATION_SEED} (evaluation set ")
    old = {row.setting: row for row in all_condition_rows(conditions(401, 1))}["runs.seed"]
    assert "development set" in old.values["value"]


@pytest.mark.parametrize("world", ["two_tier_flat", "two_tier_corridor"])
def test_beside_the_two_tier_navigator_the_fused_localizer_tracks_within_half_a_metre_and_consistently(
        world: str) -> None:
    run = home_run((world, 0, DEVELOPMENT_SEED))
    assert run.success
    fused, paper = run.figures["fused"], run.figures["paper"]
    assert fused.fix_rate == 1.0 and paper.fix_rate == 1.0
    assert fused.position_rmse_m is not None and fused.position_rmse_m < 0.6
    assert fused.heading_rmse_deg is not None and fused.heading_rmse_deg < 5.0
    assert fused.consistent is not None and fused.consistent > 0.8


def test_on_the_mixed_floor_every_kind_of_evidence_together_beats_each_alone_and_a_kidnap_is_found_again() -> None:
    run = home_run((MIXED, 1, DEVELOPMENT_SEED))
    assert run.success and set(run.figures) == {"fused", *SINGLE_EVIDENCE, "paper"}
    fused = run.figures["fused"].position_rmse_m
    assert fused is not None and fused < 0.2
    assert all(figure.position_rmse_m is not None and fused < figure.position_rmse_m
               for name, figure in run.figures.items() if name != "fused")
    assert run.figures["fused"].heading_rmse_deg is not None and run.figures["fused"].heading_rmse_deg < 2.0
    assert run.global_s is not None and run.global_s < 30.0
    assert run.kidnap_recovery_s is not None and run.kidnap_recovery_s < 30.0


def test_on_paper_000s_field_the_fused_localizer_places_the_robot_as_well_as_the_partitions_and_finds_it_again(
        ) -> None:
    run = world_run((PARTITIONS, 0, DEVELOPMENT_SEED))
    assert run.success and set(run.figures) == {"fused", "paper"}
    fused, paper = run.figures["fused"].position_rmse_m, run.figures["paper"].position_rmse_m
    assert fused is not None and paper is not None and fused < 0.15 and fused < paper
    assert run.global_s is not None and run.global_s < 1.0      # a lattice tag's id is its position
    assert run.kidnap_recovery_s is not None and run.kidnap_recovery_s < 5.0


def test_on_paper_004s_ring_the_fused_localizer_rides_the_mission_and_scores_the_executors_node_without_nees(
        ) -> None:
    run = world_run((RING, 1, DEVELOPMENT_SEED))
    assert run.success and set(run.figures) == {"fused", "paper"}
    assert run.figures["paper"].consistent is None and run.figures["paper"].heading_rmse_deg is None
    fused = run.figures["fused"].position_rmse_m
    assert fused is not None and fused < run.figures["paper"].position_rmse_m
    # Found from its wall tags within the mission (58 s here: plates tens of metres apart, no compass).
    assert run.global_s is not None


def test_on_paper_001s_hallway_the_fused_localizer_beside_the_route_follower_beats_its_odometry_by_far() -> None:
    run = world_run((HALLWAY, 0, DEVELOPMENT_SEED))
    assert run.success and set(run.figures) == {"fused", "paper"}
    fused, odometry = run.figures["fused"], run.figures["paper"]
    assert odometry.consistent is None and odometry.heading_rmse_deg is not None
    assert fused.position_rmse_m is not None and odometry.position_rmse_m is not None
    assert fused.position_rmse_m < 0.5 < 2.0 < odometry.position_rmse_m        # the odometry drifts metres
    assert run.global_s is not None and run.global_s < 30.0      # by the first floor tag under a ceiling tag


def test_pose_navigator_driving_on_the_fused_pose_in_process_arrives_and_the_pose_it_drove_on_was_right() -> None:
    run = world_run((DRIVING, 0, DEVELOPMENT_SEED))
    assert run.success and set(run.figures) == {"fused"}
    assert run.final_error_m is not None and run.final_error_m < 0.3
    fused = run.figures["fused"]
    assert fused.position_rmse_m is not None and fused.position_rmse_m < 0.15
    assert run.late_global_s is None and run.kidnap_recovery_s is None     # the pose that drives is left alone


def test_the_partition_navigator_driving_on_the_fused_localizer_arrives_with_paper_000s_localizer_beside() -> None:
    run = world_run((PARTITION_DRIVING, 0, DEVELOPMENT_SEED))
    assert run.success and set(run.figures) == {"fused", "paper"}
    # Position arrival within r/4 of the goal by the estimate (r = 20 cm), so a few centimetres by the truth.
    assert run.final_error_m is not None and run.final_error_m < 0.1
    fused, paper = run.figures["fused"].position_rmse_m, run.figures["paper"].position_rmse_m
    assert fused is not None and paper is not None and fused < 0.15 and fused < paper
    assert run.global_s is not None and run.global_s < 1.0
    assert run.late_global_s is None and run.kidnap_recovery_s is None     # the pose that drives is left alone


def test_paper_003s_navigator_with_tier_one_from_the_fused_pose_runs_the_mission_and_both_estimates_are_scored(
        ) -> None:
    run = world_run(("two_tier_flat_fused", 0, DEVELOPMENT_SEED))
    assert "two_tier_flat_fused" in TIER_ONE and set(run.figures) == {"fused", "paper"}
    assert run.success and run.final_error_m is not None and run.final_error_m < 0.3
    fused = run.figures["fused"].position_rmse_m
    assert fused is not None and fused < 1.5 and run.global_s is not None
    assert run.late_global_s is None and run.kidnap_recovery_s is None     # the pose in the loop is left alone


def test_map_to_odom_composed_with_the_odometry_pose_is_the_estimated_pose() -> None:
    estimate = FusedEstimate(PoseEstimate(3.0, -1.0, 2.5, np.eye(3)), (0.7, 1.9, -0.4), Update((), (), 0))
    pose = estimate.pose
    tx, ty, tyaw = map_to_odom((pose.x, pose.y, pose.yaw), estimate.odom)     # what rfid_localizer sends on /tf
    ox, oy, oyaw = estimate.odom
    x = tx + math.cos(tyaw) * ox - math.sin(tyaw) * oy
    y = ty + math.sin(tyaw) * ox + math.cos(tyaw) * oy
    assert (x, y) == pytest.approx((3.0, -1.0), abs=1e-12)
    assert math.remainder(tyaw + oyaw - 2.5, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


def test_the_heading_on_the_papers_rounds_is_scored_only_on_the_rounds_where_the_paper_had_a_heading() -> None:
    fused, paper = Track(), Track()
    for time_s, error in ((0.0, 0.4), (1.0, 0.1), (2.0, -0.2)):
        fused.add_position(time_s, (0.0, 0.0), error)
    paper.add_position(0.0, (0.0, 0.0))                 # no heading yet: paper 000 has one after a straight stretch
    paper.add_position(1.0, (0.0, 0.0), 0.3)
    paper.add_position(2.0, (0.0, 0.0), 0.0)
    figures = TrackFigures.of(fused, paper.heading_times_s)
    assert figures.heading_rmse_deg == pytest.approx(math.degrees(math.sqrt((0.16 + 0.01 + 0.04) / 3)))
    assert figures.heading_rmse_paper_rounds_deg == pytest.approx(math.degrees(math.sqrt((0.01 + 0.04) / 2)))
    assert TrackFigures.of(paper, paper.heading_times_s).heading_rmse_paper_rounds_deg == pytest.approx(
        TrackFigures.of(paper).heading_rmse_deg)
    assert TrackFigures.of(fused).heading_rmse_paper_rounds_deg is None


def test_the_command_prints_every_metric_for_every_world_with_both_localizers_and_the_paired_difference(
        tmp_path) -> None:
    # One run a world: the rows' shape, every world's and localizer's, is what this checks (the figures over many
    # runs are test_results.py's pinned subset); each more run costs a minute of the suite.
    runs = 1
    result = subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", "reproduce", "fused", "--runs", str(runs),
                             "--workers", "2", "--json", "--out", str(tmp_path)], cwd=WORKSPACE,
                            capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr
    rows = json.loads(result.stdout)
    assert json.loads((tmp_path / "fused_rows.json").read_text()) == rows
    assert all(set(row) == {"experiment", "setting", "metric", "ours", "paper"} for row in rows)
    conditions_end = max(i for i, row in enumerate(rows) if row["metric"] == "condition") + 1
    assert all(row["metric"] == "condition" for row in rows[:conditions_end])
    figures = rows[conditions_end:]
    # Quoted in the docs as <!--fig fused METRIC world=... localizer=...-->: single-word values, one row each.
    assert all(" " not in str(value) for row in figures for value in row["setting"].values())
    keys = [(row["metric"], json.dumps(row["setting"], sort_keys=True)) for row in figures]
    assert len(keys) == len(set(keys))
    recovery = ("global_s", "late_global_s", "kidnap_recovery_s")
    arrival = ("arrived", "arrived_pct", "arrived_pct_low", "arrived_pct_high", "final_error_m", "final_error_m_ci95")
    assert {(row["setting"]["world"], row["metric"]) for row in figures} == {
        (w, m) for w in WORLDS
        for m in (*METRICS, *(f"{m}_ci95" for m in METRICS),
                  *(f"{k}{suffix}" for k in recovery_keys(w) for suffix in ("", "_ci95", "_runs_found")),
                  *(arrival if w in ARRIVING_WORLDS else ()))}
    for row in figures:
        world, name, metric = row["setting"]["world"], row["setting"]["localizer"], row["metric"]
        assert row["setting"]["runs"] == runs and row["paper"] is None
        if metric in arrival:           # of the localizer the navigator drove on
            assert name == ("paper" if world in (*HOMES, PARTITIONS) else "fused")
            if metric == "arrived":
                assert 0 <= row["ours"] <= runs
            continue
        if metric.removesuffix("_ci95").removesuffix("_runs_found") in recovery:
            assert name == "fused"
            continue
        names = localizers_of(world)
        assert name in (*names, *(f"{n}-fused" for n in names[1:]))
        if name not in names or metric.endswith("_ci95"):
            continue
        # The mission executor has a node, not a pose with a covariance: no heading and no NEES, so no localizer
        # has a heading on the paper's rounds; paper 001's odometry has a heading but no covariance; the driving
        # world has no paper's localizer.
        paper_rounds = {(n, "heading_rmse_paper_rounds_deg") for n in names}
        without = {RING: {("paper", "heading_rmse_deg"), ("paper", "consistent"), *paper_rounds},
                   HALLWAY: {("paper", "consistent")}, DRIVING: paper_rounds}.get(world, set())
        assert row["setting"]["n"] == (0 if (name, metric) in without else runs), (world, name, metric)
    # The figures the docs quote: the fused localizer on the mixed floor beats every single kind of evidence.
    def value(metric: str, **setting) -> float:
        found = [row["ours"] for row in figures if row["metric"] == metric
                 and all(row["setting"].get(k) == v for k, v in setting.items())]
        assert len(found) == 1, (metric, setting)
        return found[0]

    fused = value("position_rmse_m", world=MIXED, localizer="fused")
    assert all(fused < value("position_rmse_m", world=MIXED, localizer=name) for name in SINGLE_EVIDENCE)
    assert fused < value("position_rmse_m", world=MIXED, localizer="paper") and fused < 0.1
    assert value("heading_rmse_deg", world=MIXED, localizer="fused") < 2.0

"""./rfidnav reproduce topological: its conditions (a row for every setting a run reads, sources that say what the
paper gives), the evaluation floors the ledger draws, the failure classes, and a small run whose rows are checked
for their consistency and pinned to their figures."""

from __future__ import annotations

import dataclasses
import inspect
import json
from pathlib import Path

import pytest
import yaml

from rfidnav_common.errors import ConfigError
from rfidnav_common.wall_tags import InductionArea
from rfidnav_control.parameters import WallFollowerParameters
from rfidnav_experiments.evaluation import LEDGER, current
from rfidnav_experiments.reproduce.tables import interpreted, is_condition_source, rowless_fields
from rfidnav_experiments.reproduce.topological import (
    CAUSES,
    CROSSED_WALL,
    DRIVING,
    EVALUATION_FLOORS,
    FAR_FROM_GOAL,
    FLOOR_ORDER,
    GAVE_UP,
    HELD_AT_WALL,
    LOST,
    MISS_RATES,
    NEAR_GOAL,
    POOLED,
    RADII_M,
    RATES,
    SEEDS,
    SOURCES,
    STANDING,
    WRONG_JUNCTION,
    conditions,
    failure_cause,
    reproduce_topological,
)
from rfidnav_experiments.runners.topological import METHODS, MissionRun
from rfidnav_planning.parameters import MissionExecutorParameters
from rfidnav_scenario.metrics import GOAL_RADIUS_M
from rfidnav_sim.parameters import RobotSimParameters, SonarParameters
from rfidnav_sim.wall_tag_model import WallTagReader

pytestmark = pytest.mark.tier("slow")
WORKSPACE = Path(__file__).resolve().parents[1]
# The parameters of every node a run uses (the in-process runner builds each from its dataclass), by row prefix.
NODE_PARAMETERS = {"robot_sim": RobotSimParameters, "sonar_sim": SonarParameters,
                   "wall_follower": WallFollowerParameters, "mission_executor": MissionExecutorParameters}
# The wall-tag reader is built from the induction area and WallTagReader's arguments: the rows that state them.
READER_ROWS = {"width_m": "wall_tag_reader.induction_area_m", "depth_m": "wall_tag_reader.induction_area_m",
               "position": "wall_tag_reader.antenna", "bearing_rad": "wall_tag_reader.antenna",
               "miss_probability": "wall_tag_reader.round_miss_probability",
               "passage_miss_probability": "missions.miss_rates", "unreadable_tags": "wall_tag_reader.unreadable_tags",
               "tags": "world.floors", "area": "wall_tag_reader.induction_area_m"}


@pytest.mark.tier("unit")
def test_every_parameter_a_run_reads_has_a_row_with_a_source() -> None:
    missing = rowless_fields(SOURCES, NODE_PARAMETERS)
    assert not missing, f"parameters without a row in the conditions table: {missing}"
    for name in [field.name for field in dataclasses.fields(InductionArea)] + \
            [name for name in inspect.signature(WallTagReader).parameters]:
        assert READER_ROWS[name] in SOURCES, name
    for node in ("robot_sim", "sonar_sim", "wall_follower"):           # and every key of the shipped files
        shipped = yaml.safe_load((WORKSPACE / "config" / "params" / f"{node}.yaml").read_text())
        for key in shipped[node]["ros__parameters"]:
            assert f"{node}.{key}" in SOURCES, f"{node}.{key} has no row in the conditions table"
    rows = {row.setting: row for row in conditions(10)}
    assert set(rows) == set(SOURCES)
    assert all(is_condition_source(row.source) and row.note for row in rows.values())
    assert all(row.values.keys() == METHODS.keys() for row in rows.values())


@pytest.mark.tier("unit")
def test_the_sources_say_what_the_paper_gives_and_what_it_does_not() -> None:
    rows = {row.setting: row for row in conditions(10)}
    assert rows["missions.miss_rates"].source == "ours"                 # paper 004 never mentions read failures
    assert rows["wall_tag_reader.miss_model"].source == "ours"
    assert rows["wall_tag_reader.induction_area_m"].source == "paper"   # Fig. 3's 40 x 100 cm
    assert rows["wall_tag_reader.induction_area_m"].values["ours"] == [0.4, 1.0]
    assert rows["missions.success_radius_m"].values["ours"] == GOAL_RADIUS_M == 0.5
    assert rows["missions.reported_radii_m"].values["ours"] == [0.25, 0.5, 0.75, 1.0]
    assert rows["robot_sim.footprint_radius_m"].values["ours"] == 0.17
    assert rows["wall_follower.junction_half_width_m"].source.startswith(interpreted(""))
    weight = rows["mission_executor.weight"]
    assert weight.values == {"paper": "edges", "ours": "length"}       # the paper's robot knows no lengths
    assert weight.sources is not None and weight.sources["paper"].startswith(interpreted(""))
    assert all(is_condition_source(source.split(" (")[0]) for row in rows.values() if row.sources
               for source in row.sources.values())


@pytest.mark.tier("unit")
def test_the_evaluation_floors_are_the_ledgers_fresh_seeds_and_the_old_ones_are_development() -> None:
    fresh = current("topological")
    assert EVALUATION_FLOORS == tuple(f"generated_{seed}" for seed in fresh.seeds) and len(fresh.seeds) == 3
    assert all(SEEDS[floor] == seed for floor, seed in zip(EVALUATION_FLOORS, fresh.seeds))   # missions, same seed
    development = {entry.seeds[0] for entry in LEDGER if entry.experiment == "topological"
                   and entry.status == "development"}
    assert development == {SEEDS["building_eval"], SEEDS["building_ring"]} == {1001, 1802}
    assert all(RATES[floor] == MISS_RATES for floor in EVALUATION_FLOORS)


@pytest.mark.tier("unit")
def test_the_papers_loop_routes_by_edges_without_recovery_and_ours_by_lengths_with_it() -> None:
    assert (METHODS["paper"].weight, METHODS["paper"].recover_missed_tags) == ("edges", False)
    assert (METHODS["ours"].weight, METHODS["ours"].recover_missed_tags) == ("length", True)


def _run(**changes) -> MissionRun:
    base = MissionRun(False, "", 10.0, 10.0, 0, 0, ("A",), 100.0, (0.0, 0.0), arrived=True, goal_distance_m=0.7,
                      stopped=True, believed_node="B", nearest_node="B", still_s=3.0, goal_node="B")
    return dataclasses.replace(base, **changes)


@pytest.mark.tier("unit")
def test_each_failure_has_one_cause_from_what_the_run_recorded() -> None:
    assert failure_cause(_run(success=True, goal_distance_m=0.2)) is None
    assert failure_cause(_run()) == NEAR_GOAL
    assert failure_cause(_run(goal_distance_m=1.6)) == FAR_FROM_GOAL
    assert failure_cause(_run(nearest_node="C", goal_distance_m=8.0)) == WRONG_JUNCTION
    assert failure_cause(_run(wall_crossings=1)) == CROSSED_WALL
    assert failure_cause(_run(arrived=False)) == GAVE_UP
    timed_out = {"arrived": False, "stopped": False, "duration_s": 900.0}
    assert failure_cause(_run(**timed_out, bumped_at_end=True, still_s=500.0)) == HELD_AT_WALL
    assert failure_cause(_run(**timed_out, still_s=500.0)) == STANDING
    assert failure_cause(_run(**timed_out, believed_node="A", nearest_node="C")) == LOST
    assert failure_cause(_run(**timed_out)) == DRIVING
    assert len(set(CAUSES)) == len(CAUSES)


# The pinned configuration (~45 s on two loaded cores): one mission per evaluation floor, method and rate, and one
# per development floor. Some of its figures; a change that moves one fails here until they are written again
# (and docs/results/topological.json regenerated).
PINNED = {"missions": 1}
PINNED_FIGURES = {
    ("paper_run", "path_length_m"): 10.653518958740653,
    ("random_missions", "path_over_shortest", POOLED, "paper", 0.3): 1.8807401299574886,
    ("random_missions", "path_over_shortest", POOLED, "ours", 0.3): 1.3953824997846294,
    ("random_missions", "path_over_shortest", POOLED, "ours", 0.0): 1.071279296568384,
    ("random_missions", "mean_passages_missed", POOLED, "paper", 0.3): 7 / 3,
    ("random_missions", "success_pct", POOLED, "paper", 0.3): 100.0,
}


def _setting(row: dict) -> tuple:
    setting = row["setting"]
    return (setting.get("floor"), setting.get("method"), setting.get("miss_rate"))


def test_a_small_run_reports_every_floor_consistently_and_its_figures_are_pinned(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    reproduce_topological(out_dir=tmp_path, as_json=False, **PINNED)
    rows = json.loads((tmp_path / "topological_rows.json").read_text())
    out = capsys.readouterr().out
    assert "right at h" in out and "conditions:" in out and "target (ours, evaluation floors pooled" in out
    assert (tmp_path / "topological_missions.png").stat().st_size > 10_000
    assert sorted(path.name for path in (tmp_path / "topological_floors").iterdir()) == sorted(
        f"{floor}_{kind}.yaml" for floor in EVALUATION_FLOORS for kind in ("map", "world"))
    assert [row for row in rows if row["metric"] == "condition"]
    paper = next(row for row in rows if row["experiment"] == "paper_run")
    assert paper["success"] and paper["ours"] == pytest.approx(PINNED_FIGURES[("paper_run", "path_length_m")],
                                                               rel=1e-9)
    success = {_setting(row): row for row in rows if row["metric"] == "success_pct"}
    assert list(success) == [(floor, method, rate) for floor in (POOLED, *FLOOR_ORDER) for method in METHODS
                             for rate in (MISS_RATES if floor == POOLED else RATES[floor])]
    assert {row["setting"]["role"] for row in success.values()} == {"evaluation", "development"}
    # The pooled rows hold the evaluation floors' missions, and the success at 0.5 m is the success.
    for method in METHODS:
        for rate in MISS_RATES:
            pooled = success[(POOLED, method, rate)]
            floors = [success[(floor, method, rate)] for floor in EVALUATION_FLOORS]
            assert pooled["setting"]["missions"] == sum(row["setting"]["missions"] for row in floors)
            assert pooled["ours"] == pytest.approx(sum(row["ours"] * row["setting"]["missions"] for row in floors)
                                                   / pooled["setting"]["missions"])
    radius = {(*_setting(row), row["setting"]["radius_m"]): row["ours"] for row in rows
              if row["metric"] == "success_within_pct"}
    for key, row in success.items():
        assert radius[(*key, GOAL_RADIUS_M)] == row["ours"]
        within = [radius[(*key, r)] for r in RADII_M]
        assert within == sorted(within)
    low_high = [row["ours"] for row in rows if row["metric"] in ("success_ci95_pct", "success_within_ci95_pct")]
    assert all(low <= high for low, high in low_high)
    # Every failed evaluation mission has one cause.
    for name in ("evaluation", "building_eval", "building_ring", "building_large"):
        for method in METHODS:
            mine = [row for row in rows if row["experiment"] == "failures" and row["setting"]["set"] == name
                    and row["setting"]["method"] == method]
            by_cause = {row["setting"]["cause"]: row["ours"] for row in mine if row["metric"] == "failures"}
            total = next(row["ours"] for row in mine if row["metric"] == "failures_total")
            assert set(by_cause) == set(CAUSES) and sum(by_cause.values()) == total
            floor = POOLED if name == "evaluation" else name
            at_rates = [row for key, row in success.items() if key[:2] == (floor, method)]
            assert total == round(sum((100.0 - row["ours"]) * row["setting"]["missions"] / 100.0
                                      for row in at_rates))
            assert next(row["ours"] for row in mine if row["metric"] == "missions") == \
                sum(row["setting"]["missions"] for row in at_rates)
    floors = {row["setting"]["floor"] for row in rows if row["experiment"] == "floors"}
    assert floors == set(FLOOR_ORDER)
    assert all(row["ours"] == 0 for row in rows if row["metric"] == "wall_crossings")
    for (experiment, metric, *selectors), value in PINNED_FIGURES.items():
        if experiment == "paper_run":
            continue
        floor, method, rate = selectors
        chosen = [row for row in rows if row["experiment"] == experiment and row["metric"] == metric
                  and _setting(row) == (floor, method, rate)]
        assert len(chosen) == 1 and chosen[0]["ours"] == pytest.approx(value, rel=1e-9), (metric, selectors)


@pytest.mark.tier("unit")
def test_no_missions_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="--runs"):
        reproduce_topological(missions=0, out_dir=tmp_path, as_json=False)


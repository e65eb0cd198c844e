"""./rfidnav reproduce topological at a small size: the conditions, the paper's run, every floor kept apart, the
rows with their intervals."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from rfidnav_common.errors import ConfigError
from rfidnav_experiments.reproduce.topological import (
    FLOOR_ORDER,
    RATES,
    SOURCES,
    conditions,
    reproduce_topological,
)
from rfidnav_experiments.runners.topological import METHODS

pytestmark = pytest.mark.tier("slow")
WORKSPACE = Path(__file__).resolve().parents[1]


@pytest.mark.tier("unit")
def test_the_conditions_list_every_setting_of_the_base_sonar_and_follower_files_with_a_source() -> None:
    for node in ("robot_sim", "sonar_sim", "wall_follower"):
        shipped = yaml.safe_load((WORKSPACE / "config" / "params" / f"{node}.yaml").read_text())
        for key in shipped[node]["ros__parameters"]:
            assert f"{node}.{key}" in SOURCES, f"{node}.{key} has no row in the conditions table"
    rows = conditions(10)
    assert {row.source for row in rows} <= {"paper", "calibrated", "ours"}
    assert all(row.note for row in rows)
    weight = next(row for row in rows if row.setting == "mission_executor.weight")
    assert weight.values == {"paper": "edges", "ours": "length"}       # the paper's robot knows no lengths


@pytest.mark.tier("unit")
def test_the_papers_loop_routes_by_edges_without_recovery_and_ours_by_lengths_with_it() -> None:
    assert (METHODS["paper"].weight, METHODS["paper"].recover_missed_tags) == ("edges", False)
    assert (METHODS["ours"].weight, METHODS["ours"].recover_missed_tags) == ("length", True)


def test_the_paper_run_and_every_floor_are_reported_with_intervals(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture) -> None:
    reproduce_topological(missions=2, out_dir=tmp_path, as_json=False)
    rows = json.loads((tmp_path / "topological_rows.json").read_text())
    assert [row for row in rows if row["metric"] == "condition"]
    paper = next(row for row in rows if row["experiment"] == "paper_run")
    assert paper["success"] and 8.0 <= paper["ours"] <= 12.0          # a right turn at h, then ~8 m to tag 19
    success = [row for row in rows if row["metric"] == "success_pct"]
    assert [(row["setting"]["floor"], row["setting"]["method"], row["setting"]["miss_rate"]) for row in success] == [
        (floor, method, rate) for floor in FLOOR_ORDER for method in ("paper", "ours")
        for rate in RATES[floor]]
    assert {row["setting"]["role"] for row in success} == {"evaluation", "development", "new layout"}
    bounds = [row["ours"] for row in rows if row["metric"] == "success_ci95_pct"]
    assert all(low <= high for low, high in bounds)
    assert any(row["metric"] == "paired_success_difference" for row in rows)
    assert (tmp_path / "topological_missions.png").stat().st_size > 10_000
    out = capsys.readouterr().out
    assert "right at h" in out and "conditions:" in out and "target (ours, building_eval" in out


@pytest.mark.tier("unit")
def test_no_missions_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="--runs"):
        reproduce_topological(missions=0, out_dir=tmp_path, as_json=False)

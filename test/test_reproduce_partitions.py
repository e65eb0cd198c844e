"""``./rfidnav reproduce partitions`` on a reduced grid: rows, tables, plots and the settings it shares with
the nodes' parameter files."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from rfidnav_experiments.reproduce import partitions as rp
from rfidnav_localization.partition import LocalizerSettings

pytestmark = pytest.mark.tier("unit")


def test_experiments_use_the_nodes_parameter_files() -> None:
    paper, ours = rp.localizer_settings("paper"), rp.localizer_settings("filter")
    # The paper file is the defaults; the tagged area is the robot map's (partition_field's 5 x 5 m).
    assert paper == LocalizerSettings(deployment_area=(0.0, 0.0, 5.0, 5.0))
    assert ours.method == "filter" and ours.antenna_offset_m == pytest.approx(0.25)
    assert rp.navigator_settings("paper", 3).approximation_level == 3
    assert rp.navigator_settings("paper", 3).deviation_check == "partition"
    assert rp.navigator_settings("filter", 5).spin_quarter_turns > 0


def test_every_level_and_method_faces_the_same_tasks() -> None:
    jobs = rp.navigation_jobs(10, ranges=(0.2,), levels=(1, 8))
    assert len(jobs) == 2 * 2 * 10
    by_task: dict[int, set[float]] = {}
    for job in jobs:
        by_task.setdefault(job.index, set()).add(job.distance_m)
    assert all(len(distances) == 1 for distances in by_task.values())
    assert sorted({job.distance_m for job in jobs}) == list(rp.DISTANCES_M)
    # Same (r, index): the same start and goal, whatever the method and level; other indices differ.
    tasks = {job.index: set() for job in jobs}
    for job in jobs:
        tasks[job.index].add(rp.task_of(job))
    assert all(len(task) == 1 for task in tasks.values())
    assert len({next(iter(task)) for task in tasks.values()}) == len(tasks)
    for job in jobs:
        (sx, sy, _), goal = rp.task_of(job)
        assert math.dist((sx, sy), goal) == pytest.approx(job.distance_m)
    results = [rp.run_navigation_job(job) for job in jobs if job.index == 3]
    assert all(r.success for r in results), [r.message for r in results]


def test_tag_counts_report_what_the_lattices_give() -> None:
    counts = rp.tag_counts()
    assert rp.saved_pct(counts, "triangular") == pytest.approx(22.3, abs=1.5)
    assert rp.saved_pct(counts, "compressed") < 0.0     # more tags than the grid, unlike the paper's 9 % fewer
    lines = "\n".join(rp.count_lines(counts))
    assert "paper: 31 %" in lines and "paper: 9 %" in lines


def test_deployment_accuracy_orders_the_layouts_as_the_paper_does() -> None:
    accuracy = {layout: rp.deployment_accuracy(layout, 0.2, 200) for layout in ("grid", "triangular", "compressed")}
    assert accuracy["grid"].location_cm < accuracy["triangular"].location_cm            # Fig. 16
    assert accuracy["compressed"].location_cm < accuracy["triangular"].location_cm      # Fig. 19
    assert accuracy["triangular"].orientation_deg < accuracy["grid"].orientation_deg    # Fig. 17
    assert all(0.0 < a.location_cm < 20.0 for a in accuracy.values())


@pytest.mark.tier("slow")
def test_reduced_reproduction_writes_rows_tables_and_plots(tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.setattr(rp, "NAVIGATION_RANGES_M", (0.2, 0.5))
    monkeypatch.setattr(rp, "LEVELS", (2, 4))
    monkeypatch.setattr(rp, "FIG11_RUNS", 10)
    monkeypatch.setattr(rp, "ACCURACY_SAMPLES", 20)
    monkeypatch.setattr(rp, "ACCURACY_RANGES_M", (0.2,))
    code = rp.reproduce_partitions(runs=5, out_dir=tmp_path, as_json=True)
    out = capsys.readouterr().out
    rows = json.loads(out)
    assert rows == json.loads((tmp_path / "partitions_rows.json").read_text())
    assert code == 0
    assert {row["experiment"] for row in rows} == {"partitions.fig11", "partitions.fig12_14", "partitions.levels_ge_4",
                                                  "partitions.fig15_18", "partitions.fig16_20"}
    assert all(set(row) == {"experiment", "setting", "metric", "ours", "paper"} for row in rows)
    costs = [row for row in rows if row["metric"] == "extra_cost_pct" and row["experiment"] == "partitions.fig12_14"]
    assert len(costs) == 2 * 2 * 2 * len(rp.DISTANCES_M)
    assert all(row["ours"] is None or math.isfinite(row["ours"]) for row in costs)
    saved = {row["setting"]["layout"]: row for row in rows if row["metric"] == "saved_vs_grid_pct"}
    assert saved["triangular"]["paper"] == 31.0 and saved["compressed"]["paper"] == 9.0
    for name in ("partitions_fig11_orientation.png", "partitions_fig12_14_cost.png",
                 "partitions_fig15_20_deployments.png"):
        assert (tmp_path / name).stat().st_size > 10_000


def test_too_few_runs_is_a_clear_error(tmp_path: Path) -> None:
    from rfidnav_common.errors import ConfigError
    with pytest.raises(ConfigError, match="--runs"):
        rp.reproduce_partitions(runs=2, out_dir=tmp_path, as_json=False)

"""Published figures stay true: every figure the README and docs/ quote equals its results file, no results file is
older than the inputs it recorded, the evaluation ledger's page is current, and each reproduction's pinned subset
gives exactly the rows its results file holds (the runs are deterministic: a change that moves a figure fails here
until ``./rfidnav reproduce NAME --publish`` or ``reproduce all`` rewrites the file in the same commit)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rfidnav_experiments import evaluation, results

pytestmark = pytest.mark.tier("unit")

ROWS = {"format": results.FORMAT, "rows": [
    {"experiment": "x", "setting": {"scenario": "line", "params": "a"}, "metric": "rmse_m", "ours": 0.05372,
     "paper": 0.034},
    {"experiment": "x", "setting": {"scenario": "line", "params": "b"}, "metric": "rmse_m", "ours": -0.0248,
     "paper": None},
    {"experiment": "x", "setting": {"scenario": "line", "params": "b"}, "metric": "ok", "ours": True, "paper": None},
]}
BENCH = {"format": results.FORMAT, "figures": {"speedup": 7012.4, "rows": [{"speed": 8.71}]}}


def rerun_hint(name: str) -> str:
    if name in results.COMMANDS:
        return f"./rfidnav reproduce all --only {name}"
    return f"./rfidnav reproduce {name} --publish"


def test_a_quote_names_one_row_by_metric_and_setting_scaled_and_rounded_as_shown() -> None:
    documents = {"x": ROWS, "bench_y": BENCH}
    assert results.shown(results.quoted_value("x rmse_m params=a x100", documents, "here"), "5.37") == "5.37"
    assert results.shown(results.quoted_value("x rmse_m params=a x100 paper", documents, "here"), "3.4") == "3.4"
    assert results.shown(results.quoted_value("x rmse_m params=b x100", documents, "here"), "−2.5") == "−2.5"
    assert results.shown(results.quoted_value("x rmse_m experiment=x !params", {"x": {"rows": [
        *ROWS["rows"], {"experiment": "x", "setting": {"scenario": "line"}, "metric": "rmse_m", "ours": 0.07,
                        "paper": None}]}}, "here"), "0.07") == "0.07"
    assert results.shown(results.quoted_value("x ok params=b", documents, "here"), "0") == "1"
    assert results.quoted_value("x @wall_s x0.5", {"x": {**ROWS, "wall_s": 60.0}}, "here") == 30.0
    assert results.shown(results.quoted_value("bench_y speedup", documents, "here"), "7000") == "7012"
    assert results.shown(results.quoted_value("bench_y rows.0.speed", documents, "here"), "8.7") == "8.7"
    listed = {"bench_z": {"figures": [{"scenario": "a", "rmse_m": 0.1}, {"scenario": "b", "rmse_m": 0.2}]}}
    assert results.quoted_value("bench_z rmse_m scenario=b", listed, "here") == 0.2
    with pytest.raises(results.ResultsError, match="selects 2 rows"):
        results.quoted_value("bench_z rmse_m", listed, "here")


@pytest.mark.parametrize("spec, problem", [
    ("x rmse_m", "selects 2 rows"),
    ("x rmse_m params=c", "selects 0 rows"),
    ("x rmse_m params=b paper", "not a number"),
    ("nothing rmse_m", "no results file"),
    ("bench_y rows.3.speed", "no '3'"),
    ("x params=a", "name a metric"),
])
def test_a_quote_that_cannot_be_read_from_its_file_says_where_and_why(spec: str, problem: str) -> None:
    with pytest.raises(results.ResultsError, match=problem) as raised:
        results.quoted_value(spec, {"x": ROWS, "bench_y": BENCH}, "README.md:12")
    assert "README.md:12" in str(raised.value)


def test_a_stale_quote_is_found_and_rendering_rewrites_it_from_its_file(tmp_path: Path) -> None:
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "x.json").write_text(json.dumps(ROWS))
    page = tmp_path / "README.md"
    page.write_text("RMSE 5.41<!--fig x rmse_m params=a x100--> cm, paired +1.0<!--fig x rmse_m params=b x100-->\n")
    problems = results.quote_problems(tmp_path, tmp_path / "results")
    assert problems == ["README.md:1: 5.41 but x.json gives 5.37 (x rmse_m params=a x100)",
                        "README.md:1: +1.0 but x.json gives -2.5 (x rmse_m params=b x100)"]
    assert results.render_quotes(tmp_path, tmp_path / "results") == []
    assert page.read_text() == ("RMSE 5.37<!--fig x rmse_m params=a x100--> cm, paired "
                                "-2.5<!--fig x rmse_m params=b x100-->\n")
    assert results.quote_problems(tmp_path, tmp_path / "results") == []


def test_every_figure_the_readme_and_docs_quote_equals_its_results_file() -> None:
    assert results.quotes(), "no quoted figure found: the docs quote their figures with <!--fig ...-->"
    assert results.quote_problems() == []


def test_every_reproduction_and_quoted_benchmark_has_a_results_file_no_older_than_its_inputs() -> None:
    stale = {}
    for name in [*results.REPRODUCTIONS, *results.COMMANDS]:
        path = results.RESULTS_DIR / f"{name}.json"
        assert path.is_file(), f"{path} missing: run {rerun_hint(name)}"
        document = results.read_results(path)
        assert document["name"] == name and document["command"].startswith("./rfidnav ")
        if name in results.REPRODUCTIONS:
            assert document["inputs"], f"{path} recorded no inputs"
            assert document["evaluation_set"] == evaluation.evaluation_set_dict(name)
        changed = results.stale_inputs(document)
        if changed:
            stale[name] = f"{', '.join(changed[:5])}{' ...' if len(changed) > 5 else ''}: rerun {rerun_hint(name)}"
    assert stale == {}


def test_a_results_file_is_stale_once_an_input_it_recorded_changes(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(results, "REPOSITORY", tmp_path)
    (tmp_path / "config").mkdir()
    source = tmp_path / "config" / "robot.yaml"
    source.write_text("a: 1\n")
    with results.recorded_inputs() as opened:
        source.read_text()
    assert opened == {source}
    document = {"inputs": results.input_hashes(opened)}
    assert results.stale_inputs(document) == []
    source.write_text("a: 2\n")
    assert results.stale_inputs(document) == ["config/robot.yaml"]
    source.unlink()
    assert results.stale_inputs(document) == ["config/robot.yaml (gone)"]


def test_a_pinned_mismatch_names_the_vector_instructions_of_the_publishing_machine_and_this_one(tmp_path: Path) \
        -> None:
    cpuinfo = tmp_path / "cpuinfo"
    cpuinfo.write_text("processor\t: 0\nflags\t\t: fpu sse2 avx avx2 fma avx512f\n")
    assert results.vector_instructions(cpuinfo) == ["avx", "avx2", "fma", "avx512f"]
    here = {"machine": {"vector_instructions": results.vector_instructions()}}
    assert results.numerics_differ(here) == ""
    assert "an unrecorded set" in results.numerics_differ({"machine": {"cores": 2}})
    other = {"machine": {"vector_instructions": ["avx512f", *results.vector_instructions()]}}
    assert "avx512f" in results.numerics_differ(other) and "reproduce all" in results.numerics_differ(other)


def test_the_evaluation_ledgers_page_is_current() -> None:
    assert results.LEDGER_PAGE.read_text() == evaluation.ledger_markdown(), \
        "docs/results/evaluation-ledger.md differs from rfidnav_experiments/evaluation.py: run ./rfidnav reproduce docs"


def test_each_experiment_has_one_evaluation_set_and_every_retired_set_names_its_successor() -> None:
    experiments = {entry.experiment for entry in evaluation.LEDGER}
    assert experiments == set(results.REPRODUCTIONS)
    names = {entry.name for entry in evaluation.LEDGER}
    for experiment in experiments:
        assert evaluation.current(experiment).status == "evaluation"
    by_name = {entry.name: entry for entry in evaluation.LEDGER}
    for entry in evaluation.LEDGER:
        if entry.status == "development":
            assert entry.looked_at_then_changed and entry.replaced_by in names, entry
            successor = by_name[entry.replaced_by]           # retired in turn, it names its own successor
            while successor.status == "development":
                successor = by_name[successor.replaced_by]
            assert successor.experiment == entry.experiment
            assert evaluation.current(entry.experiment) == successor


def test_drawn_seeds_follow_the_recorded_rule_and_miss_the_hand_chosen_ones() -> None:
    for entry in evaluation.LEDGER:
        if entry.drawn_by.startswith("drawn_seed"):
            count = len(entry.seeds)
            names = [f"{entry.name}#{k}" for k in range(count)] if count > 1 else [entry.name]
            assert entry.seeds == tuple(evaluation.drawn_seed(entry.experiment, name, entry.drawn_on)
                                        for name in names)
            assert all(evaluation.SEED_RANGE[0] <= seed < evaluation.SEED_RANGE[1] for seed in entry.seeds)
    assert evaluation.drawn_seed("flc", "a", "2026-12-04") != evaluation.drawn_seed("flc", "a", "2026-12-05")


@pytest.mark.tier("slow")
@pytest.mark.parametrize("name", list(results.REPRODUCTIONS))
def test_each_reproductions_pinned_subset_gives_exactly_the_rows_of_its_results_file(name: str) -> None:
    document = results.read_results(results.RESULTS_DIR / f"{name}.json")
    assert document["pinned"]["arguments"] == results.REPRODUCTIONS[name].pinned
    assert json.dumps(results.pinned_rows(name), sort_keys=True) == \
        json.dumps(document["pinned"]["rows"], sort_keys=True), \
        f"reproduce {name}'s pinned figures moved: rerun ./rfidnav reproduce {name} --publish and commit the file" \
        + results.numerics_differ(document)

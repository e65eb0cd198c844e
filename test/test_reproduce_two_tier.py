"""./rfidnav reproduce two_tier at a small size: every figure is produced, and the comparisons the paper
makes come out its way (two-tier fixes at centimetres, fingerprinting at metres, indirect beats direct)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from rfidnav_common.errors import ConfigError
from rfidnav_experiments.reproduce.two_tier import reproduce_two_tier
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("slow")   # the rows come from one reduced reproduction (~12 s)


@pytest.fixture(scope="module")
def rows(tmp_path_factory: pytest.TempPathFactory) -> list[dict]:
    out = tmp_path_factory.mktemp("two_tier")
    code = reproduce_two_tier(runs=2, out_dir=out, as_json=False, fig10_runs=10)
    assert code == 0
    assert (out / "two_tier_figs10_12.png").stat().st_size > 10_000
    return json.loads((out / "two_tier_rows.json").read_text())


def values(rows: list[dict], experiment: str, **setting) -> list[float]:
    return [r["ours"] for r in rows if r["experiment"] == experiment
            and all(r["setting"].get(k) == v for k, v in setting.items())]


def test_fig10_searches_grow_with_the_distance_and_the_wider_spiral_is_shorter_far_out(rows: list[dict]) -> None:
    paper_d = values(rows, "fig10_spiral", spiral="paper d")
    ours = values(rows, "fig10_spiral", spiral="ours")
    assert len(paper_d) == len(ours) == 11 and paper_d[0] == 0.0
    assert paper_d[-1] > paper_d[5] > paper_d[2]
    assert ours[-1] < paper_d[-1]


def test_fig11_and_fig12_come_out_the_papers_way(rows: list[dict]) -> None:
    direct, = values(rows, "fig11_moving", moving="direct")
    indirect, = values(rows, "fig11_moving", moving="indirect")
    assert indirect < direct
    fingerprinting = values(rows, "fig12_turning_points", method="fingerprinting")
    two_tier = values(rows, "fig12_turning_points", method="two_tier")
    assert len(two_tier) == 8 and max(two_tier) < 0.05 and min(fingerprinting) > 0.1
    grid, = values(rows, "radio_map", map="grid")
    survey, = values(rows, "radio_map", map="survey")
    assert 0.1 < grid < 3.0 and 0.1 < survey < 3.0


def test_theorem1_rows_carry_the_printed_and_the_rayleigh_expectation(rows: list[dict]) -> None:
    theorem = [r for r in rows if r["experiment"] == "theorem1"]
    assert [r["setting"]["sigma_m"] for r in theorem] == [0.25, 0.5, 1.0]
    for row in theorem:
        assert row["rayleigh_m"] > row["paper"] > 0.0 and row["ours"] > 0.0


@pytest.mark.tier("graph")
def test_a_bad_run_count_is_one_clear_error_from_the_command(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="--runs"):
        reproduce_two_tier(runs=0, out_dir=tmp_path, as_json=False)
    result = subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", "reproduce", "two_tier", "--runs", "-1",
                             "--out", str(tmp_path)], capture_output=True, text=True, cwd=WORKSPACE, timeout=300)
    assert result.returncode != 0 and "--runs" in result.stderr

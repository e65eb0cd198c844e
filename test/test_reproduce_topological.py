"""./rfidnav reproduce topological at a small size: the paper's run, the table at every miss rate, the rows."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rfidnav_common.errors import ConfigError
from rfidnav_experiments.reproduce.topological import MISS_RATES, reproduce_topological

pytestmark = pytest.mark.tier("slow")


def test_the_paper_run_and_the_missions_are_reported_at_every_miss_rate(tmp_path: Path,
                                                                         capsys: pytest.CaptureFixture) -> None:
    reproduce_topological(missions=2, out_dir=tmp_path, as_json=False)
    rows = json.loads((tmp_path / "topological_rows.json").read_text())
    paper = next(row for row in rows if row["experiment"] == "paper_run")
    assert paper["success"] and 8.0 <= paper["ours"] <= 12.0          # a right turn at h, then ~8 m to tag 19
    success = [row for row in rows if row["metric"] == "success_pct"]
    assert [(row["setting"]["method"], row["setting"]["miss_rate"]) for row in success] == [
        (method, rate) for method in ("paper", "ours") for rate in MISS_RATES]
    assert all(0.0 <= row["ours"] <= 100.0 for row in success)
    assert (tmp_path / "topological_missions.png").stat().st_size > 10_000
    assert "right at h" in capsys.readouterr().out


@pytest.mark.tier("unit")
def test_no_missions_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="--runs"):
        reproduce_topological(missions=0, out_dir=tmp_path, as_json=False)

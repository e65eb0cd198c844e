"""./rfidnav reproduce fused: the fused localizer beside paper 003's own on the same seeded runs, and what its
estimate means for tf (map -> odom composed with odom -> base_link is the estimated pose)."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from rfidnav_experiments.reproduce.fused import DEVELOPMENT_SEED, HOMES, METRICS, home_run
from rfidnav_localization.fused.filter import PoseEstimate, Update
from rfidnav_localization.fused.localizer import FusedEstimate
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("slow")


@pytest.mark.parametrize("world", ["two_tier_flat", "two_tier_corridor"])
def test_beside_the_two_tier_navigator_the_fused_localizer_tracks_within_half_a_metre_and_consistently(
        world: str) -> None:
    run = home_run((world, 0, DEVELOPMENT_SEED))
    assert run.success
    assert run.fused.fix_rate == 1.0 and run.paper.fix_rate == 1.0
    assert run.fused.position_rmse_m is not None and run.fused.position_rmse_m < 0.6
    assert run.fused.heading_rmse_deg is not None and run.fused.heading_rmse_deg < 5.0
    assert run.fused.consistent is not None and run.fused.consistent > 0.8


def test_map_to_odom_composed_with_the_odometry_pose_is_the_estimated_pose() -> None:
    estimate = FusedEstimate(PoseEstimate(3.0, -1.0, 2.5, np.eye(3)), (0.7, 1.9, -0.4), Update((), (), 0.0, 0))
    tx, ty, tyaw = estimate.map_to_odom()
    ox, oy, oyaw = estimate.odom
    x = tx + math.cos(tyaw) * ox - math.sin(tyaw) * oy
    y = ty + math.sin(tyaw) * ox + math.cos(tyaw) * oy
    assert (x, y) == pytest.approx((3.0, -1.0), abs=1e-12)
    assert math.remainder(tyaw + oyaw - 2.5, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


def test_the_command_prints_every_metric_for_every_world_with_both_localizers_and_the_paired_difference(
        tmp_path) -> None:
    result = subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", "reproduce", "fused", "--runs", "2",
                             "--workers", "2", "--json", "--out", str(tmp_path)], cwd=WORKSPACE,
                            capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr
    rows = json.loads(result.stdout)
    assert {(row["setting"].split()[0], row["metric"]) for row in rows} == {(w, m) for w in HOMES for m in METRICS}
    for row in rows:
        assert row["ours"]["n"] == 2 and row["paper"]["n"] == 2 and row["difference"]["n"] == 2
    assert json.loads((tmp_path / "fused_rows.json").read_text()) == rows

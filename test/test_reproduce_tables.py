"""The figures' shared arithmetic: intervals, paired differences, the conditions table."""

from __future__ import annotations

import pytest

from rfidnav_experiments.reproduce.tables import (
    Condition,
    Interval,
    condition_json_rows,
    condition_lines,
    paired_interval,
)

pytestmark = pytest.mark.tier("unit")


def test_an_interval_is_the_mean_with_the_t_quantile_times_the_standard_error() -> None:
    interval = Interval.of([1.0, 2.0, 3.0])
    # stdev 1, n 3: t(0.975, 2) = 4.303
    assert interval.mean == pytest.approx(2.0)
    assert interval.half_width == pytest.approx(4.302653 / 3 ** 0.5, rel=1e-5)
    assert interval.n == 3
    assert Interval.of([5.0]).half_width is None
    assert Interval.of([]).text() == "no success"


def test_a_success_rate_of_all_runs_still_has_an_interval_below_one_hundred_percent() -> None:
    rate = Interval.of_proportion(20, 20)
    assert rate.mean == pytest.approx(100.0)
    assert rate.bounds == pytest.approx((83.89, 100.0), abs=0.01)    # Wilson, z = 1.96
    assert "[83.9, 100.0]" in rate.text(1.0, 1)
    assert Interval.of_proportion(10, 20).bounds == pytest.approx((29.93, 70.07), abs=0.01)


def test_a_paired_difference_uses_only_the_seeds_both_sides_completed() -> None:
    difference = paired_interval({1: 1.0, 2: 2.0, 3: None, 4: 4.0}, {1: 0.5, 2: 1.0, 3: 3.0})
    assert difference.n == 2
    assert difference.mean == pytest.approx(0.75)


def test_the_conditions_table_writes_same_where_a_method_shares_the_first_ones_value() -> None:
    rows = [Condition("reader.delay_s", {"paper": 0.5, "ours": 0.5}, "paper", "sec. 5"),
            Condition("reader.range_m", {"paper": 0.05, "ours": 0.1}, "ours", "why")]
    lines = condition_lines(rows, ("paper", "ours"))
    assert "same" in lines[3] and "0.5" in lines[3]
    assert "0.1" in lines[4] and "same" not in lines[4]
    json_rows = condition_json_rows("x", rows)
    assert [row["metric"] for row in json_rows] == ["condition", "condition"]
    assert json_rows[1]["ours"] == {"paper": 0.05, "ours": 0.1}

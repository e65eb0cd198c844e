"""The robot's own survey (paper 003's automatic radio map construction), its pure core: the legs from the dock
to each landmark and when a scan is due (rfidnav_planning.two_tier_survey), which the in-process runner and
two_tier_navigator's /survey action both use."""

from __future__ import annotations

import pytest

from rfidnav_common.tag_groups import TagGroup
from rfidnav_localization.dead_reckoning import TIER_TAG, TIER_WIFI, DeadReckoningEstimate, Fix
from rfidnav_planning.two_tier_survey import SURVEY_FRESH_M, RobotSurvey, SurveyRule

pytestmark = pytest.mark.tier("unit")

GROUPS = [TagGroup("T1", "cross", (3.0, 1.5)), TagGroup("T2", "cross", (6.0, 3.6)),
          TagGroup("R1", "cross", (1.2, 3.5))]


def estimate(position: tuple[float, float] | None, fix: Fix | None, since_fix_m: float) -> DeadReckoningEstimate:
    return DeadReckoningEstimate(position, 0.0, 0.1, fix, since_fix_m)


def test_the_survey_starts_docked_on_the_first_landmark_and_visits_the_others_in_the_maps_order() -> None:
    survey = RobotSurvey(GROUPS)
    first = survey.first_leg()
    assert (first.index, first.landmark, first.target) == (0, "T2", (6.0, 3.6))
    assert first.known_start is not None and first.known_start.position == (3.0, 1.5)
    assert first.known_start.tier == TIER_TAG
    second = survey.leg_ended(reached=True)
    assert second is not None and (second.landmark, second.known_start.position) == ("R1", (6.0, 3.6))
    assert survey.leg_ended(reached=True) is None and survey.complete and survey.reached == ["T2", "R1"]


def test_after_a_leg_that_did_not_reach_its_landmark_the_next_starts_from_tier_one_and_the_survey_is_incomplete():
    survey = RobotSurvey(GROUPS, dock="R1", landmarks=["T2", "T1"])
    assert survey.first_leg().landmark == "T2"
    following = survey.leg_ended(reached=False)
    assert following is not None and following.landmark == "T1" and following.known_start is None
    assert survey.leg_ended(reached=True) is None
    assert not survey.complete and survey.reached == ["T1"] and len(survey.legs) == 2


@pytest.mark.parametrize("dock, landmarks, words", [
    ("X9", [], "no tag group 'X9' in the map (known: T1, T2, R1)"),
    ("", ["T2", "Z"], "no tag group 'Z'"),
])
def test_an_unknown_dock_or_landmark_is_named(dock: str, landmarks: list[str], words: str) -> None:
    with pytest.raises(ValueError, match=words.replace("(", r"\(").replace(")", r"\)")):
        RobotSurvey(GROUPS, dock, landmarks)


def test_a_map_with_no_landmark_but_the_dock_has_nothing_to_survey() -> None:
    with pytest.raises(ValueError, match="nothing to survey"):
        RobotSurvey(GROUPS[:1])
    with pytest.raises(ValueError, match="has none"):
        RobotSurvey([])


def test_a_scan_is_due_every_spacing_while_fresh_from_a_tag_fix_and_is_recorded_where_the_robot_believes() -> None:
    rule = SurveyRule(spacing_m=0.5)
    tag_fix = Fix((3.0, 1.5), 0.05, TIER_TAG, "T1-00")
    believed = (3.4, 1.5)
    assert rule.due(estimate(believed, tag_fix, 0.4), travelled_m=10.0) == believed
    assert rule.due(estimate(believed, tag_fix, 0.6), travelled_m=10.4) is None          # 0.4 m since the last
    assert rule.due(estimate((3.9, 1.5), tag_fix, 0.9), travelled_m=10.5) == (3.9, 1.5)
    stale = estimate((5.0, 1.5), tag_fix, SURVEY_FRESH_M + 0.01)
    assert rule.due(stale, travelled_m=12.0) is None                                      # too far from the fix
    wifi_fix = Fix((5.0, 1.5), 1.5, TIER_WIFI)
    assert rule.due(estimate((5.0, 1.5), wifi_fix, 0.0), travelled_m=13.0) is None      # tier one is no tag fix
    assert rule.due(estimate(None, None, 0.0), travelled_m=14.0) is None


def test_a_spacing_that_is_not_a_positive_distance_is_refused() -> None:
    for spacing in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="spacing_m"):
            SurveyRule(spacing)

"""Wall tag reader of paper 004 (section 2, Fig. 3): the 40 x 100 cm induction area to the robot's left, tags
facing the antenna, read misses.

Pure-module tests: no ROS. The robot follows a left wall at y = 0.8 m; positions are worked out by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_common.wall_tags import InductionArea, WallTag
from rfidnav_sim.wall_tag_model import WallTagReader
from support.reference_cores import ReferenceReader

pytestmark = pytest.mark.tier("unit")

INTO_HALLWAY = (0.0, -1.0)      # the normal of a plate on the left wall y = 0.8, robot below it


def reads(tags: list[WallTag], x: float = 0.0, y: float = 0.0, yaw: float = 0.0,
          area: InductionArea = InductionArea()) -> list[str]:
    return WallTagReader(area, tags).read(x, y, yaw, np.random.default_rng(0))


def test_a_tag_on_the_left_wall_0_8_m_away_inside_the_band_is_read() -> None:
    assert reads([WallTag("T1", (0.0, 0.8), INTO_HALLWAY)]) == ["T1"]
    assert reads([WallTag("T1", (0.15, 0.8), INTO_HALLWAY)]) == ["T1"]        # within the +-0.20 m band


def test_a_tag_0_3_m_ahead_of_the_band_is_not_read() -> None:
    assert reads([WallTag("T1", (0.5, 0.8), INTO_HALLWAY)]) == []              # band ends at x = 0.20
    assert reads([WallTag("T1", (-0.5, 0.8), INTO_HALLWAY)]) == []             # and behind it at x = -0.20


def test_a_tag_facing_away_from_the_antenna_is_not_read() -> None:
    # A plate on the far side of the wall: same place, normal pointing out of the hallway.
    assert reads([WallTag("T1", (0.0, 0.8), (0.0, 1.0))]) == []


def test_a_tag_1_2_m_away_or_on_the_right_is_not_read() -> None:
    assert reads([WallTag("T1", (0.0, 1.2), INTO_HALLWAY)]) == []              # depth 1.0 m from the antenna
    assert reads([WallTag("T1", (0.0, -0.8), (0.0, 1.0))]) == []               # right wall, facing the robot


def test_the_rectangle_edges_belong_to_the_area() -> None:
    assert reads([WallTag("T1", (0.0, 1.0), INTO_HALLWAY), WallTag("T2", (0.2, 0.8), INTO_HALLWAY)]) == ["T1", "T2"]


def test_the_area_turns_with_the_robot() -> None:
    # Facing -x from (5, 5), the robot's left is -y: a plate on the wall y = 4.2 facing +y is read.
    assert reads([WallTag("T1", (5.0, 4.2), (0.0, 1.0))], 5.0, 5.0, math.pi) == ["T1"]
    assert reads([WallTag("T1", (5.0, 5.8), INTO_HALLWAY)], 5.0, 5.0, math.pi) == []


def test_the_area_starts_at_the_antenna() -> None:
    # Antenna on the left edge of a 35 cm robot: the area reaches 0.175 + 1.0 = 1.175 m from the centre.
    area = InductionArea(position=(0.0, 0.175))
    assert reads([WallTag("T1", (0.0, 1.1), INTO_HALLWAY)], area=area) == ["T1"]
    assert reads([WallTag("T1", (0.0, 1.2), INTO_HALLWAY)], area=area) == []


def test_only_the_tags_in_reach_are_listed_in_tag_order() -> None:
    tags = [WallTag("far", (0.0, 1.2), INTO_HALLWAY), WallTag("B", (0.1, 0.8), INTO_HALLWAY),
            WallTag("ahead", (0.5, 0.8), INTO_HALLWAY), WallTag("A", (-0.1, 0.8), INTO_HALLWAY)]
    assert reads(tags) == ["B", "A"]
    assert reads([]) == []


def test_miss_probability_one_reads_nothing() -> None:
    reader = WallTagReader(InductionArea(), [WallTag("T1", (0.0, 0.8), INTO_HALLWAY)], miss_probability=1.0)
    rng = np.random.default_rng(1)
    assert all(reader.read(0.0, 0.0, 0.0, rng) == [] for _ in range(200))


def test_miss_probability_0_3_reads_about_70_percent_independently_per_tag() -> None:
    tags = [WallTag("A", (-0.1, 0.8), INTO_HALLWAY), WallTag("B", (0.1, 0.8), INTO_HALLWAY)]
    reader = WallTagReader(InductionArea(), tags, miss_probability=0.3)
    rng = np.random.default_rng(2)
    rounds = [reader.read(0.0, 0.0, 0.0, rng) for _ in range(4000)]
    # Binomial sd of a fraction over 4000 rounds: sqrt(0.21 / 4000) = 0.007.
    assert np.mean([("A" in r) for r in rounds]) == pytest.approx(0.7, abs=0.025)
    assert np.mean([("B" in r) for r in rounds]) == pytest.approx(0.7, abs=0.025)
    assert np.mean([len(r) == 2 for r in rounds]) == pytest.approx(0.49, abs=0.025)      # independent: 0.7^2


def test_bad_tags_areas_and_readers_name_the_field() -> None:
    with pytest.raises(ValueError, match="normal"):
        WallTag("T1", (0.0, 0.8), (0.0, -2.0))
    with pytest.raises(ValueError, match="^width_m:"):
        InductionArea(width_m=0.0)
    with pytest.raises(ValueError, match="^miss_probability:"):
        WallTagReader(InductionArea(), [], miss_probability=1.5)
    with pytest.raises(ValueError, match="unique"):
        WallTagReader(InductionArea(), [WallTag("T1", (0.0, 0.8), INTO_HALLWAY)] * 2)
    with pytest.raises(ValueError, match="^passage_miss_probability:"):
        WallTagReader(InductionArea(), [], passage_miss_probability=-0.1)
    with pytest.raises(ValueError, match="^unreadable_tags: T9 not among"):
        WallTagReader(InductionArea(), [WallTag("T1", (0.0, 0.8), INTO_HALLWAY)], unreadable_tags=["T9"])


def passages(reader: WallTagReader, rng: np.random.Generator, count: int) -> list[bool]:
    """Drive past the tag at x = 0 ``count`` times (0.02 m per round, -1 to 1 m): whether each passage read it
    at all, and that a passage reads it in every round in reach or in none."""
    read = []
    for _ in range(count):
        rounds = [bool(reader.read(x, 0.0, 0.0, rng)) for x in np.arange(-1.0, 1.0, 0.02)]
        in_reach = [bool(reader.in_reach(x, 0.0, 0.0)[0]) for x in np.arange(-1.0, 1.0, 0.02)]
        assert all(r == rounds[in_reach.index(True)] for r, reach in zip(rounds, in_reach) if reach)
        read.append(any(rounds))
    return read


@pytest.mark.tier("slow")
def test_a_passage_miss_holds_for_the_whole_passage_and_is_drawn_anew_for_the_next() -> None:
    reader = WallTagReader(InductionArea(), [WallTag("T1", (0.0, 0.8), INTO_HALLWAY)], passage_miss_probability=0.3)
    read = passages(reader, np.random.default_rng(3), 1000)
    assert np.mean(read) == pytest.approx(0.7, abs=0.05)      # binomial sd 0.015


def test_an_unreadable_tag_is_never_read_and_the_others_are() -> None:
    tags = [WallTag("A", (-0.1, 0.8), INTO_HALLWAY), WallTag("B", (0.1, 0.8), INTO_HALLWAY)]
    reader = WallTagReader(InductionArea(), tags, unreadable_tags=["B"])
    assert reader.read(0.0, 0.0, 0.0, np.random.default_rng(4)) == ["A"]


@pytest.mark.parametrize("floor", ["building_large", "building_fig5", "building_eval", "building_ring"])
def test_reads_along_a_floor_equal_those_of_the_reader_that_tests_every_tag(floor: str) -> None:
    # The reference is the reader of commit 249c210 (numpy arrays over every tag). A random walk past the floor's
    # tags and off the floor, miss probabilities of both kinds and an unreadable tag, one noise stream each:
    # the same reads, round by round, and the same draws consumed.
    from rfidnav_scenario.scenario import CONFIG_DIR
    from rfidnav_sim.world import load_world

    tags = load_world(CONFIG_DIR / "worlds" / f"{floor}.yaml").wall_tags
    settings = {"miss_probability": 0.2, "passage_miss_probability": 0.3, "unreadable_tags": [tags[0].tag_id]}
    new, old = WallTagReader(InductionArea(), tags, **settings), ReferenceReader(InductionArea(), tags, **settings)
    walk = np.random.default_rng(11)
    new_rng, old_rng = np.random.default_rng(5), np.random.default_rng(5)
    reads = 0
    for tag in tags:
        # Along the tag's wall, 0.6-1.0 m out, both ways, then a jump anywhere near it.
        heading = math.atan2(tag.normal[1], tag.normal[0]) + math.pi / 2.0
        for direction in (1.0, -1.0):
            out = walk.uniform(0.6, 1.0)
            for along in np.arange(-1.5, 1.5, 0.05) * direction:
                x = tag.position[0] + out * tag.normal[0] + along * math.cos(heading)
                y = tag.position[1] + out * tag.normal[1] + along * math.sin(heading)
                yaw = heading + (0.0 if direction > 0 else math.pi) + walk.normal(0.0, 0.1)
                assert new.read(x, y, yaw, new_rng) == old.read(x, y, yaw, old_rng)
                reads += bool(old.in_reach(x, y, yaw).any())
                assert new.in_reach(x, y, yaw).tolist() == old.in_reach(x, y, yaw).tolist()
        x, y = np.array(tag.position) + walk.uniform(-40.0, 40.0, 2)
        assert new.read(x, y, 0.0, new_rng) == old.read(x, y, 0.0, old_rng)
    assert new_rng.random() == old_rng.random()
    assert reads > len(tags)                                          # the walk did pass the tags

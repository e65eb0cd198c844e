"""The polled reader (paper 003 sec. 4.1: a reply every 500-600 ms, some polls failing): when rounds come, that a
tag the robot passes between two polls is never read, that polls fail at the given rate, and that the regular
readers of the other papers keep their grid and draw nothing. The same reader serves the rfid_reader_sim node and
the in-process runners (rfidnav_sim.parameters.ReaderParameters.simulated_reader)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_common.config import parameters_from_mapping
from rfidnav_common.errors import ConfigError
from rfidnav_common.polling import PollClock, Polling, next_on_grid
from rfidnav_common.seeding import rng_for
from rfidnav_experiments.runners.shipped import file_parameters
from rfidnav_scenario.scenario import CONFIG_DIR
from rfidnav_sim.parameters import ReaderParameters
from rfidnav_sim.schedule import GroundTruthSchedule
from rfidnav_sim.world import Tag, World

pytestmark = pytest.mark.tier("unit")

HF_FILE = CONFIG_DIR / "params" / "reader_hf_floor.yaml"
SPEED_MPS = 0.2
STEP_S = 0.01


def hf_reader(**changes: float) -> ReaderParameters:
    return file_parameters(ReaderParameters, HF_FILE, "rfid_reader_sim", world_file="unused", **changes)


def one_floor_tag() -> World:
    return World("one tag", "map", (Tag("F1", (0.0, 0.0, 0.0), "floor"),), ())


def poll_times(clock: PollClock, until_s: float) -> list[float]:
    times = []
    for step in range(int(until_s / STEP_S) + 1):
        if clock.due(step * STEP_S):
            times.append(step * STEP_S)
    return times


def passage_read(parameters: ReaderParameters, reader_seed: int, lateral_m: float) -> bool:
    """The robot drives along y = lateral_m at 0.2 m/s over a floor tag at the origin: read on the way?"""
    reader = parameters.simulated_reader(one_floor_tag(), reader_seed)
    for step in range(int(0.6 / SPEED_MPS / STEP_S) + 1):
        time_s = step * STEP_S
        reads = reader.sample((-0.3 + SPEED_MPS * time_s, lateral_m, 0.0), time_s)
        if reads:
            return True
    return False


def test_the_shipped_hf_reader_polls_every_500_to_600_ms() -> None:
    clock = PollClock(hf_reader().polling(), rng_for(1, "polls"))
    intervals = np.diff(poll_times(clock, 120.0))
    assert len(intervals) > 150
    assert intervals.min() >= 0.5 - 1e-9 and intervals.max() <= 0.6 + STEP_S + 1e-9   # a poll falls on a step
    assert 0.54 < intervals.mean() < 0.57


def test_a_tag_passed_between_two_polls_is_never_read() -> None:
    # 3 cm to the side the 5 cm reader reads the tag over 8 cm of the way, 0.4 s: less than one poll interval. A
    # poll just before the robot comes within range puts the next one after it has left.
    reader = hf_reader(round_failure_probability=0.0).simulated_reader(one_floor_tag(), 7)
    enter_s = (0.3 - math.sqrt(0.05 ** 2 - 0.005 ** 2 - 0.03 ** 2)) / SPEED_MPS
    reader.clock.next_poll_s = enter_s - 0.02
    rounds = []
    for step in range(int(0.6 / SPEED_MPS / STEP_S) + 1):
        time_s = step * STEP_S
        reads = reader.sample((-0.3 + SPEED_MPS * time_s, 0.03, 0.0), time_s)
        if reads is not None:
            rounds.append(reads)
    assert len(rounds) >= 4 and not any(rounds)                   # polls came, before and after


def test_a_tag_passed_at_a_random_poll_phase_is_read_as_often_as_a_poll_falls_in_its_window() -> None:
    # 8 cm within range at 0.2 m/s is a 0.4 s window; polls 0.5-0.6 s apart (mean 0.55 s) at a random phase
    # fall in it with probability 0.4 / 0.55, and one in ten of those fails.
    window_s = 2.0 * math.sqrt(0.05 ** 2 - 0.005 ** 2 - 0.03 ** 2) / SPEED_MPS
    parameters = hf_reader()
    expected = window_s / 0.55 * (1.0 - parameters.round_failure_probability)
    read = np.mean([passage_read(parameters, seed, 0.03) for seed in range(600)])
    assert read == pytest.approx(expected, abs=0.07)
    assert read < 0.9


@pytest.mark.parametrize("failure", [0.1, 0.3])
def test_polls_fail_at_the_given_rate(failure: float) -> None:
    clock = PollClock(Polling(0.5, 0.1, failure), rng_for(3, "polls"))
    outcomes = [clock.reads() for _ in range(4000)]
    assert 1.0 - np.mean(outcomes) == pytest.approx(failure, abs=0.025)


def test_a_failed_poll_reads_nothing_even_over_a_tag() -> None:
    reader = hf_reader(round_failure_probability=0.5).simulated_reader(one_floor_tag(), 2)
    rounds = [reader.sample((0.0, 0.0, 0.0), k * 0.6) for k in range(1, 401)]   # each 0.6 s: a poll due
    assert all(reads is not None for reads in rounds)
    read = [bool(reads) for reads in rounds]
    assert 0.4 < np.mean(read) < 0.6                              # the tag is under the antenna every time


def test_a_reader_without_jitter_keeps_its_grid_and_draws_nothing() -> None:
    clock, schedule = PollClock(Polling(0.04)), GroundTruthSchedule(0.04)
    assert poll_times(clock, 2.0) == poll_times(schedule, 2.0)
    assert poll_times(PollClock(Polling(0.04)), 0.2) == pytest.approx([0.0, 0.04, 0.08, 0.12, 0.16, 0.2])
    assert next_on_grid(0.05, 0.04) == pytest.approx(0.08)
    with pytest.raises(ValueError, match="random generator"):
        PollClock(Polling(0.5, 0.1))


@pytest.mark.parametrize(("field", "value"), [("round_jitter_s", -0.1), ("round_jitter_s", math.nan),
                                              ("round_failure_probability", 1.0),
                                              ("round_failure_probability", -0.1)])
def test_bad_polling_parameters_are_refused_naming_the_parameter(field: str, value: float) -> None:
    with pytest.raises(ConfigError, match=field):
        parameters_from_mapping(ReaderParameters, {"world_file": "w.yaml", field: value}, "reader.yaml")

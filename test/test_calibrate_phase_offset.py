"""``./rfidnav calibrate phase-offset``: heading_controller's phase_difference_offset_rad from /rfid/reads, the robot
standing still in front of a tag. The estimate (same-channel pairs only, the circular mean per channel and over
the channels, refusal with too few pairs) and the parameter file it writes, in pure code; then the command over DDS
against the reader simulator with a known offset injected between the left and the right antenna ports."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml

from rfidnav_common.config import node_parameter_values
from rfidnav_control.parameters import HeadingControllerParameters
from rfidnav_control.tag_route import TagObservation
from rfidnav_experiments.calibrate.phase_offset import CalibrationError, estimate_offset, with_offset, write_offset
from support.runs import WORKSPACE

CHANNELS_HZ = (902.75e6, 915.25e6, 927.25e6)


def rounds_with_offset(offset: float, count: int, noise: float = 0.1, tag: str = "CAL", seed: int = 1,
                       channels: tuple[float, ...] = CHANNELS_HZ) -> list[list[TagObservation]]:
    """``count`` rounds of one left and one right read of ``tag`` whose difference is ``offset`` plus noise, the
    channel hopping every 5 rounds, at a random common phase."""
    rng = np.random.default_rng(seed)
    rounds = []
    for index in range(count):
        frequency = channels[(index // 5) % len(channels)]
        common = rng.uniform(0.0, 2.0 * math.pi)
        left = (common + offset + rng.normal(0.0, noise)) % (2.0 * math.pi)
        rounds.append([TagObservation(tag, 1, left, -55.0, frequency),
                       TagObservation(tag, 2, common, -55.0, frequency)])
    return rounds


@pytest.mark.tier("unit")
def test_the_offset_is_the_circular_mean_of_same_channel_differences_and_cross_channel_rounds_are_dropped() -> None:
    rounds = rounds_with_offset(0.7, 300)
    # Rounds across a hop: left on one channel, right on another, 2 rad apart. Used, they would pull the mean.
    rounds += [[TagObservation("CAL", 1, 2.5, -55.0, CHANNELS_HZ[0]),
                TagObservation("CAL", 2, 0.5, -55.0, CHANNELS_HZ[1])]] * 40
    estimate = estimate_offset(rounds, left_antenna=1, right_antenna=2, tag_id="CAL")
    assert estimate.offset_rad == pytest.approx(0.7, abs=0.02)
    assert (estimate.pairs, estimate.cross_channel_rounds, estimate.rounds) == (300, 40, 340)
    assert [c.frequency_hz for c in estimate.channels] == list(CHANNELS_HZ)
    assert all(c.offset_rad == pytest.approx(0.7, abs=0.04) and c.spread_rad == pytest.approx(0.1, rel=0.25)
               for c in estimate.channels)
    assert estimate.spread_rad == pytest.approx(0.1, rel=0.15)
    assert estimate.standard_error_rad == pytest.approx(0.1 / math.sqrt(300), rel=0.2)
    assert estimate.channel_spread_rad < 0.04


@pytest.mark.tier("unit")
def test_an_offset_near_pi_is_not_averaged_to_zero() -> None:
    estimate = estimate_offset(rounds_with_offset(3.1, 200, noise=0.15), 1, 2, "CAL")
    assert abs(math.remainder(estimate.offset_rad - 3.1, 2.0 * math.pi)) < 0.05


@pytest.mark.tier("unit")
def test_a_channel_dependent_offset_is_given_per_channel_with_its_spread() -> None:
    # A cable 10 cm longer on the left (v = 0.66 c, 0.505 ns): 2*pi*f*0.505 ns, 0.078 rad more at 927.25 MHz than
    # at 902.75 MHz.
    true = [0.5 + 2 * math.pi * (f - CHANNELS_HZ[0]) * 0.505e-9 for f in CHANNELS_HZ]
    rounds = [r for index, (f, offset) in enumerate(zip(CHANNELS_HZ, true))
              for r in rounds_with_offset(offset, 100, noise=0.02, seed=index, channels=(f,))]
    estimate = estimate_offset(rounds, 1, 2, "CAL")
    offsets = [c.offset_rad for c in estimate.channels]
    assert offsets == pytest.approx(true, abs=0.01) and true[-1] - true[0] == pytest.approx(0.0777, abs=1e-4)
    assert estimate.offset_rad == pytest.approx(sum(offsets) / 3, abs=1e-3)
    assert estimate.channel_spread_rad == pytest.approx((true[-1] - true[0]) / 2, abs=0.01)


@pytest.mark.tier("unit")
def test_too_few_same_channel_pairs_are_refused_with_the_counts() -> None:
    rounds = rounds_with_offset(0.7, 20)
    rounds += [[TagObservation("CAL", 1, 2.5, -55.0, CHANNELS_HZ[0]),
                TagObservation("CAL", 2, 0.5, -55.0, CHANNELS_HZ[1])]] * 100
    with pytest.raises(CalibrationError, match=r"tag CAL: 20 same-channel pairs .* 100 rounds with its left and "
                                               r"right reads on different channels only, 120 rounds heard\); at "
                                               r"least 50 are needed"):
        estimate_offset(rounds, 1, 2, "CAL")
    # A channel with fewer than 3 pairs is left out of the mean, and so of the count.
    sparse = rounds_with_offset(0.7, 60, channels=(CHANNELS_HZ[0],)) + rounds_with_offset(
        -2.0, 2, channels=(CHANNELS_HZ[1],))
    estimate = estimate_offset(sparse, 1, 2, "CAL")
    assert estimate.pairs == 60 and [c.pairs for c in estimate.sparse_channels] == [2]
    assert estimate.offset_rad == pytest.approx(0.7, abs=0.04)


@pytest.mark.tier("unit")
def test_without_a_tag_id_the_tag_with_the_most_pairs_is_taken_and_none_at_all_is_an_error() -> None:
    rounds = [a + b for a, b in zip(rounds_with_offset(0.7, 100), rounds_with_offset(-1.0, 100, tag="OTHER"))]
    rounds += rounds_with_offset(0.7, 10)
    assert estimate_offset(rounds, 1, 2).tag_id == "CAL"
    one_side = [[TagObservation("CAL", 1, 1.0, -55.0, CHANNELS_HZ[0])]] * 80
    with pytest.raises(CalibrationError, match=r"no tag was read by both antennas 1 \(left\) and 2 \(right\) on one "
                                               r"channel in 80 rounds \(tags heard: CAL\)"):
        estimate_offset(one_side, 1, 2)


@pytest.mark.tier("unit")
def test_the_offset_is_written_into_the_controllers_file_keeping_everything_else(tmp_path: Path) -> None:
    shipped = WORKSPACE / "config/params/flc_tuned.yaml"
    out = tmp_path / "flc_robot.yaml"
    assert write_offset(shipped, out, 0.71234) == 0.0
    before, after = shipped.read_text().splitlines(), out.read_text().splitlines()
    changed = [(old, new) for old, new in zip(before, after) if old != new]
    assert len(before) == len(after) and changed == [("    phase_difference_offset_rad: 0.0",
                                                      "    phase_difference_offset_rad: 0.7123")]
    values = node_parameter_values(HeadingControllerParameters, out, "heading_controller")
    assert values["phase_difference_offset_rad"] == 0.7123
    # A comment after the value stays in its column; a file without the key gets it as its first parameter.
    commented = "heading_controller:\n  ros__parameters:\n    phase_difference_offset_rad: 0.0   # measured\n"
    assert with_offset(commented, -1.5) == ("heading_controller:\n  ros__parameters:\n"
                                            "    phase_difference_offset_rad: -1.5000 # measured\n")
    bare = "heading_controller:\n  ros__parameters:\n    filter_rounds: 5\n"
    assert with_offset(bare, 0.25) == ("heading_controller:\n  ros__parameters:\n"
                                       "    phase_difference_offset_rad: 0.2500\n    filter_rounds: 5\n")


# ------------------------------------------------------------------------------------- over DDS, the simulator

INJECTED_RAD = 0.7                  # port 1's cable and port delay minus port 2's
LEFT_RIGHT_OFFSETS = [0.9, 0.2, 0.0]
TOLERANCE_RAD = 0.05                # one difference spreads ~0.1 rad at 3.6 m; >= 50 pairs: standard error <= 0.015


def environment(domain: int) -> dict[str, str]:
    return {**os.environ, "ROS_DOMAIN_ID": str(domain)}


@pytest.fixture(scope="module")
def simulator(tmp_path_factory) -> Iterator[tuple[int, Path]]:
    """robot_sim and rfid_reader_sim in one process (the simulator of every scenario) on a leased domain: the robot
    standing still at the origin heading +x, tag CAL 2 m ahead and 3 m up on its centre line, tag OTHER off to the
    side; the reader hopping over three channels with INJECTED_RAD between the left and right antenna ports."""
    from rfidnav_bringup.processes import DomainLease

    folder = tmp_path_factory.mktemp("calibrate")
    world = folder / "world.yaml"
    world.write_text("name: calibration\ntags:\n  - {id: CAL, position: [2.0, 0.0, 3.0]}\n"
                     "  - {id: OTHER, position: [-1.0, 2.5, 3.0]}\n")
    robot = yaml.safe_load((WORKSPACE / "config/params/robot_sim.yaml").read_text())
    robot["robot_sim"]["ros__parameters"].update(world_file=str(world), rtf=1.0)
    reader = yaml.safe_load((WORKSPACE / "config/params/reader_uhf_2ant.yaml").read_text())
    reader["rfid_reader_sim"]["ros__parameters"].update(
        world_file=str(world), antenna_phase_offset_rad=LEFT_RIGHT_OFFSETS,
        channels_mhz=[f / 1e6 for f in CHANNELS_HZ], hop_dwell_s=0.2)
    files = []
    for name, document in (("robot_sim", robot), ("rfid_reader_sim", reader)):
        files += ["--params-file", str(folder / f"{name}.yaml")]
        (folder / f"{name}.yaml").write_text(yaml.safe_dump(document))
    lease = DomainLease()
    process = subprocess.Popen([sys.executable, "-m", "rfidnav_bringup.container", "--node", "rfidnav_sim:robot_sim",
                                "--node", "rfidnav_sim:rfid_reader_sim", "--ros-args", *files],
                               env=environment(lease.domain_id), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               text=True)
    try:
        yield lease.domain_id, folder
    finally:
        process.send_signal(signal.SIGINT)
        try:
            output, _ = process.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            output, _ = process.communicate()
        (folder / "simulator.log").write_text(output)
        lease.close()


def calibrate(domain: int, *options: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", "calibrate", "phase-offset", *options],
                          capture_output=True, text=True, timeout=120, cwd=WORKSPACE, env=environment(domain))


@pytest.mark.tier("graph")
def test_the_command_measures_the_injected_offset_over_dds_and_writes_it(simulator: tuple[int, Path]) -> None:
    domain, folder = simulator
    out = folder / "flc_robot.yaml"
    result = calibrate(domain, "--tag", "CAL", "--duration", "6", "--wait", "30", "--json", "--out", str(out))
    assert result.returncode == 0, result.stdout + result.stderr
    figures = json.loads(result.stdout)
    print(f"measured {figures['offset_rad']:.4f} rad, injected {INJECTED_RAD} rad, {figures['pairs']} pairs, "
          f"standard error {figures['standard_error_rad']:.4f} rad")
    assert figures["offset_rad"] == pytest.approx(INJECTED_RAD, abs=TOLERANCE_RAD)
    assert [c["frequency_hz"] for c in figures["channels"]] == list(CHANNELS_HZ)
    assert figures["pairs"] >= 50 and figures["cross_channel_rounds"] == 0   # the simulator hops between rounds
    written = node_parameter_values(HeadingControllerParameters, out, "heading_controller")
    assert written["phase_difference_offset_rad"] == pytest.approx(figures["offset_rad"], abs=1e-4)


@pytest.mark.tier("graph")
def test_a_tag_not_read_on_both_antennas_is_refused_with_exit_2(simulator: tuple[int, Path]) -> None:
    domain, _ = simulator
    result = calibrate(domain, "--tag", "E2801160600002", "--duration", "1", "--wait", "30")
    assert result.returncode == 2 and result.stdout == ""
    assert ("tag E2801160600002: 0 same-channel pairs" in result.stderr
            and "(not heard at all; tags heard: CAL, OTHER)" in result.stderr), result.stderr

"""reproduce flc: where every setting a run reads comes from, the conditions table read from the parameters the runs
use, and what calibrate flc recorded beside the calibrated file."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from rfidnav_experiments.calibrate.flc import CALIBRATED_FILE, TIMEOUT_S, calibrated_reader, record_path, timeout_s
from rfidnav_experiments.reproduce.flc.conditions import (
    BASELINE,
    HEADING_UPDATE,
    PARAM_FILES,
    PARAM_SETS,
    SCENARIOS,
    TIME_SCENARIO,
    evaluation_seeds,
    scenario_named,
)
from rfidnav_experiments.reproduce.tables import INTERPRETED, Condition
from rfidnav_experiments.runners.tag_route import (
    controller_parameters,
    floor_read_radius_m,
    role_parameters,
    tag_points,
)

# Where every setting a run reads comes from: every field of the reader's, the base's and the controller's
# parameter classes (test_calibrate_flc checks that none is missing), and what the scenario and the runner fix. A
# source is one for both parameter sets, or one per set (a dict) where they differ; "paper, interpreted" where the
# paper says something we had to read as a number or a rule.
Source = str | dict[str, str]
PER_SET_OURS = {"flc_paper": "paper", "flc_tuned": "ours"}
SOURCES: dict[str, tuple[Source, str]] = {
    "rfid_reader_sim.world_file": ("ours", "the scenario's world (ground truth); no effect beyond the tags"),
    "rfid_reader_sim.seed": ("ours", "the run's seed: the evaluation seeds, never the calibration's"),
    "rfid_reader_sim.rate_hz": ("ours", "25 inventory rounds per second, one control step each: the paper gives no "
                                        "reader rate nor control period (calibrate flc sweeps it: an open setting)"),
    "rfid_reader_sim.round_jitter_s": ("ours", "rounds on the 1/rate_hz grid"),
    "rfid_reader_sim.round_failure_probability": ("ours", "no failed rounds: the paper models none"),
    "rfid_reader_sim.frame_id": ("ours", "the robot's frame; no effect on the figures"),
    "rfid_reader_sim.antenna_frame_prefix": ("ours", "the antennas' frames on /tf_static; no effect on the figures"),
    "rfid_reader_sim.antenna_positions": ("ours", "receiving antennas 6 cm apart (below lambda/4: the tag's side "
                                                  "is unambiguous) 30 cm up, the floor antenna 5 cm up; the paper "
                                                  "gives no geometry"),
    "rfid_reader_sim.antenna_facing": ("paper", "sec. III-IV: two receiving antennas for the ceiling tags, a "
                                                "short-range one for the floor tag under each"),
    "rfid_reader_sim.antenna_max_range_m": ("ours", "a cap that never binds for the ceiling tags (the link budget "
                                                    "reaches 9.09 m at 3 m); the floor antenna's 10 cm: floor tags "
                                                    "read within 8.66 cm, the read area that starts and ends the "
                                                    "scored stretch (calibrate flc sweeps it: an open setting)"),
    "rfid_reader_sim.antenna_half_angle_deg": ("ours", "wide upward beams; the floor antenna's 60 degrees"),
    "rfid_reader_sim.antenna_phase_offset_rad": ("ours", "matched antennas and cables"),
    "rfid_reader_sim.channels_mhz": ("ours", "one UHF channel, 915.25 MHz: the paper gives no frequency"),
    "rfid_reader_sim.hop_dwell_s": ("ours", "unused with one channel"),
    "rfid_reader_sim.phase_noise_rad_per_m": ("calibrated", "./rfidnav calibrate flc to Figs. 8/9 (the line "
                                                            "experiments); proportional to distance: sec. V"),
    "rfid_reader_sim.miss_probability": ("ours", "no missed reads: the paper models none"),
    "rfid_reader_sim.rssi_at_1m_dbm": ("ours", "only decides what is heard: every paper route's tag is"),
    "rfid_reader_sim.sensitivity_dbm": ("ours", "an Impinj-class reader"),
    "rfid_reader_sim.max_rssi_dbm": ("ours", "a receiver saturates; nothing reads the RSSI"),
    "rfid_reader_sim.pattern_exponent": ("ours", "a cosine pattern"),
    "rfid_reader_sim.side_area_width_m": ("ours", "side antennas only (paper 004): none here"),
    "rfid_reader_sim.passage_miss_probability": ("ours", "side antennas only: none here"),
    "rfid_reader_sim.unreadable_tags": ("ours", "side antennas only: none here"),
    "robot_sim.world_file": ("ours", "the scenario's world: its walls (the hallway's) stop the base"),
    "robot_sim.seed": ("ours", "the run's seed"),
    "robot_sim.start_x": ("paper", "sec. V-A..C through the scenario's start (scenario.start)"),
    "robot_sim.start_y": ("paper", "as start_x"),
    "robot_sim.start_yaw_deg": ("paper", "as start_x"),
    "robot_sim.rtf": ("ours", "in-process: no pacing; no effect on the figures"),
    "robot_sim.step_participants": ("ours", "the stepped clock over DDS; in-process the loop is lockstep"),
    "robot_sim.start_paused": ("ours", "over DDS only; no effect on the figures"),
    "robot_sim.robots": ("ours", "one robot; several in one world are scenarios over DDS only"),
    "robot_sim.robot_starts": ("ours", "as robots"),
    "robot_sim.map_to_odom_at_start": ("ours", "no localizer; the follower keeps no pose"),
    "robot_sim.step_s": ("ours", "10 ms physics step"),
    "robot_sim.odom_rate_hz": ("ours", "the ground truth sampled at 50 Hz for the metrics"),
    "robot_sim.track_width_m": ("ours", "a small differential-drive base"),
    "robot_sim.max_wheel_speed_mps": ("ours", "above every commanded speed"),
    "robot_sim.max_wheel_accel_mps2": ("ours", "a small base's"),
    "robot_sim.command_timeout_s": ("ours", "never reached: a command every round"),
    "robot_sim.odom_left_scale_error": ("ours", "odometry drift; unused by the controller (it steers by phase)"),
    "robot_sim.odom_right_scale_error": ("ours", "as above"),
    "robot_sim.odom_track_scale_error": ("ours", "as above"),
    "robot_sim.odom_slip_std": ("ours", "as above"),
    "robot_sim.footprint_radius_m": ("ours", "the footprint: a round base of 0.17 m radius (34 cm across); the "
                                             "hallway's walls stop it and press its bumper"),
    "robot_sim.walls_stop_base": ("ours", "walls are obstacles"),
    "heading_controller.map_file": ("paper", "sec. IV-C step 8: the floor tag under each ceiling tag marks arrival"),
    "heading_controller.forward_speed_mps": ("paper", "sec. V: fixed to 0.2 m/s"),
    "heading_controller.left_antenna": ("ours", "reader ports 1 and 2: phi1 and phi2 of eq. 2"),
    "heading_controller.right_antenna": ("ours", "as left_antenna"),
    "heading_controller.floor_antenna": ("ours", "reader port 3, downward"),
    "heading_controller.phase_difference_offset_rad": ("ours", "matched antennas: no offset to calibrate"),
    "heading_controller.turn_speed_fraction": (PER_SET_OURS, "flc_paper: constant speed (sec. V); flc_tuned: "
                                                             "slows while turning at the limit"),
    "heading_controller.approach_speed_fraction": (PER_SET_OURS, "flc_paper: constant speed (sec. V); flc_tuned: "
                                                                 "slows over the floor tag"),
    "heading_controller.output_range_rad": ({"flc_paper": "calibrated", "flc_tuned": "ours"},
                                            "flc_paper: ./rfidnav calibrate flc to Figs. 8/9 (Fig. 5 gives no "
                                            "numbers); flc_tuned: ours"),
    "heading_controller.max_yaw_rate_radps": ("ours", "the base's turn-rate limit, the same for both: the paper "
                                                      "gives none (calibrate flc sweeps it: an open setting)"),
    "heading_controller.nominal_round_s": ("ours", "one reader round, 40 ms: the control period"),
    "heading_controller.unheard_timeout_s": ("ours", "stop when no round arrives for 10 s; never reached here"),
    "heading_controller.arrival": ({"flc_paper": INTERPRETED, "flc_tuned": "ours"},
                                   "flc_paper: sec. IV-C step 8, \"detects the signal sent by the short-range tag\", "
                                   "read as the floor tag's first read; flc_tuned: its closest approach"),
    "heading_controller.filter_rounds": ({"flc_paper": INTERPRETED, "flc_tuned": "ours"},
                                         "flc_paper: sec. IV-C steps 3-5, the phases \"at that time instant\", read "
                                         "as the latest phase difference only; flc_tuned: the mean of the last 5"),
    "heading_controller.receding_detection": (PER_SET_OURS, "flc_paper: none (the paper has no such guard); "
                                                            "flc_tuned: on"),
    "heading_controller.receding_rate_mps": ("ours", "flc_tuned's guard threshold; unused by flc_paper"),
    "heading_controller.range_rate_smoothing": ("ours", "flc_tuned's guard smoothing; unused by flc_paper"),
    "heading_controller.unheard_search": ("ours", "both: the search for an unheard target, which never acts on the "
                                                  "paper's routes (every tag heard); on the random routes' legs "
                                                  "beyond the reach it does"),
    "heading_controller.search_after_s": ("ours", "the search's settings, the same for both"),
    "heading_controller.search_turn_rate_radps": ("ours", "as search_after_s"),
    "heading_controller.search_spacing_m": ("ours", "as search_after_s"),
    "heading_controller.search_radius_m": ("ours", "as search_after_s"),
    "heading_controller.input_range_rad": (INTERPRETED, "the input universe: dphi of eq. 2 wrapped to (-pi, pi] "
                                                        "(Fig. 5a's axis has no numbers)"),
    "heading_controller.input_set_names": ("paper", "sec. IV-B: Neg, Zero, Pos"),
    "heading_controller.input_set_points": ("ours", "the input breakpoints: Neg a trapezoid to -0.6 rad falling to "
                                                    "0, Zero a triangle -0.6..0..0.6, Pos mirrored; Fig. 5a's shapes, "
                                                    "its numbers ours (the paper gives none)"),
    "heading_controller.output_set_names": ("paper", "sec. IV-B: CW, Zero, CCW"),
    "heading_controller.output_set_points": ({"flc_paper": "calibrated", "flc_tuned": "ours"},
                                             "the output shapes: CW a trapezoid at -r rising to 0, Zero a triangle "
                                             "-r/2..0..r/2, CCW mirrored (Fig. 5b's shapes, \"not to scale\"); r "
                                             "scales with output_range_rad"),
    "heading_controller.rules": ("paper", "sec. IV-B: Neg->CCW, Zero->Zero, Pos->CW (min/max, centre of area)"),
    "heading_controller.resolution": ("ours", "the scikit-fuzzy reference's sampling; the runtime's table is exact"),
    "world.ceiling_m": ("paper", "sec. V: tags on a 3 m ceiling"),
    "scenario.start": ("paper", "sec. V-A..C: (-5, -5) at 90 or 0 degrees; (0, 3) at 270; the hallway's first tag"),
    "scenario.geometry": ({"flc_paper": INTERPRETED, "flc_tuned": INTERPRETED},
                          "the lines' tags from sec. V-A's text; the acute path's and the hallway's only in Figs. "
                          "10/12, which the paper's text does not give: their geometry is ours, with sec. V-B/C's "
                          "start, tag count and ceiling"),
    "scenario.timeout_s": ("ours", f"at least {TIMEOUT_S:.0f} s: a slowly turning robot may take the paper's "
                                   "110 s and more to the line"),
    "runner.heading_update": (INTERPRETED, "eq. 3, theta_new = theta_old + dtheta, read as the yaw rate that turns "
                                           "by dtheta over the round (the node's rule; calibrate flc sweeps the "
                                           "alternative, a heading reference)"),
    "metrics.scored_stretch": (INTERPRETED, "eq. 4 over sec. V-A's \"tracking error of this phase\": from the "
                                            "robot's entry into the first tag's read area to its entry into the "
                                            "last one's (ground truth), the same stretch for both"),
}


def row_source(source: Source) -> tuple[str, dict[str, str] | None]:
    """The row's one source, or the first set's with every set's beside it where they differ."""
    if isinstance(source, str):
        return source, None
    if len(set(source.values())) == 1:
        return next(iter(source.values())), None
    return source[BASELINE], dict(source)


def conditions() -> list[Condition]:
    """The table's rows, their values read from the parameters the runs use (the first evaluation seed's)."""
    seed = evaluation_seeds(1)[0]
    line = scenario_named(TIME_SCENARIO)
    reader = calibrated_reader(line, seed)
    robot = role_parameters(line, "robot_sim", seed)
    controllers = {params: controller_parameters(line, PARAM_FILES[params], seed) for params in PARAM_SETS}
    rows = []
    for key, (source, note) in SOURCES.items():
        node, field = key.split(".", 1)
        if node == "heading_controller":
            values = {params: getattr(controllers[params], field) for params in PARAM_SETS}
        elif node == "world":
            values = dict.fromkeys(PARAM_SETS, sorted({round(tag.position[2], 3) for tag in line.world.tags
                                                        if tag.position[2] > 1.0}))
        elif node == "scenario":
            values = dict.fromkeys(PARAM_SETS, {
                "start": lambda: {name: scenario_named(name).robot for name in SCENARIOS},
                "geometry": lambda: {name: [tuple(round(float(v), 2) for v in point)
                                            for point in tag_points(scenario_named(name),
                                                                    scenario_named(name).mission.goal["tag_ids"])]
                                     for name in SCENARIOS},
                "timeout_s": lambda: {name: timeout_s(scenario_named(name)) for name in SCENARIOS}}[field]())
        elif node == "runner":
            values = dict.fromkeys(PARAM_SETS, HEADING_UPDATE)
        elif node == "metrics":
            values = {params: f"read areas of {floor_read_radius_m(reader, controllers[params]) * 100:.2f} cm"
                      for params in PARAM_SETS}
        else:
            values = dict.fromkeys(PARAM_SETS, getattr(reader if node == "rfid_reader_sim" else robot, field))
        summary, per_set = row_source(source)
        rows.append(Condition(key, values, summary, note, per_set))
    return rows


def calibration_record(path: Path | None = None) -> dict[str, Any]:
    """What calibrate flc recorded beside the calibrated file ({} when it has not been run with this version)."""
    sidecar = path or record_path(CALIBRATED_FILE)
    return json.loads(sidecar.read_text()) if sidecar.exists() else {}

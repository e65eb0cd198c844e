"""``./rfidnav report RUN``: metrics recomputed from a run's bag, and plots like paper 001 Figs. 9, 11, 13
(tag routes) or the trajectory against the shortest path (partition navigation, paper 000).

The run folder holds the bag, the resolved scenario and copies of its world and map, so a report
needs nothing else. From the bag: ground truth (/sim/ground_truth), the mission start and end (the
action's status topic: accepted, then succeeded/aborted/canceled) and the arrivals at route tags
(the feedback's target index stepping on). A run on a real robot has no ground truth: its report is the
odometry (/odom, in the odom frame) and the distance driven by it (``odom_path_length_m``); the metric groups,
which compare against the truth, are not computed. Every run with ground truth counts ``wall_crossings``: how often
its whole track crossed one of the world's walls (0 in a world without walls).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np
import yaml

from rfidnav_bag.bags import bag_info, is_bag_directory, read_messages
from rfidnav_bag.errors import BagError
from rfidnav_common.topological_map import (
    UNKNOWN,
    TopologicalMap,
    load_topological_map,
    parse_hallway_text,
)
from rfidnav_control.tag_route import SEARCH_MODES
from rfidnav_scenario.metrics import (
    Fix,
    Trajectory,
    flagged_spans,
    partition_metrics,
    success_verdict,
    topological_metrics,
    tracking_error,
    tracking_metrics,
    two_tier_metrics,
    wall_crossings,
)
from rfidnav_scenario.scenario import robot_action
from rfidnav_sim.world import World, load_world

STATUS_ACCEPTED, STATUS_EXECUTING = 1, 2
STATUS_FINAL = {4: "succeeded", 5: "canceled", 6: "aborted"}


@dataclass(frozen=True)
class RunRecord:
    run_dir: Path
    bag: Path
    world: World
    route: list[str]
    ground_truth: Trajectory
    mission_start_s: float
    mission_end_s: float
    final_status: str | None
    arrival_times_s: list[float]
    metric_groups: list[str]
    goal: dict
    last_feedback: object | None             # the mission's last feedback before it ended
    action: str                              # the mission's action name, without a trailing slash
    trajectory_source: str = "ground_truth"  # or "odom": a run on a real robot (no simulator)
    searching: tuple[tuple[float, float], ...] = ()   # (start, end) of each search its feedback reported
    success_within_m: float | None = None    # the scenario's success criterion (None: a run from before it had one)
    robot: str | None = None                 # a run of several robots: whose record this is (its namespace)
    namespace: str = ""                      # its topics' prefix: /r1 (/r1/sim/ground_truth), '' for one robot


def locate_run(path: Path) -> tuple[Path, Path]:
    """(run folder, bag folder) for a run folder or its bag folder, the bag finalised or not."""
    path = Path(path)
    if not path.exists():
        raise BagError(f"{path}: not a run folder nor a rosbag2 folder (the path does not exist)")
    if is_bag_directory(path / "bag"):
        return path, path / "bag"
    if is_bag_directory(path):
        return path.parent, path
    raise BagError(f"{path}: not a run folder nor a rosbag2 folder (no metadata.yaml, no .mcap file)")


def robots_of(path: Path) -> list[str]:
    """The robots of a run of several (its scenario.yaml's robots), in their order; [] for a run of one."""
    run_dir, _ = locate_run(path)
    scenario_file = run_dir / "scenario.yaml"
    if not scenario_file.exists():
        return []
    return [robot["name"] for robot in yaml.safe_load(scenario_file.read_text()).get("robots", [])]


def load_run(path: Path, robot: str | None = None) -> RunRecord:
    """The record of a run (of ``robot``'s part in a run of several: its mission, its topics)."""
    run_dir, bag = locate_run(path)
    # An unreadable bag is named first, before anything that depends on it; one that was not finalised is read
    # as far as it goes, and what was lost said once.
    for note in bag_info(bag).notes:
        print(f"{bag}: {note}", file=sys.stderr)
    scenario_file = run_dir / "scenario.yaml"
    if not scenario_file.exists():
        raise BagError(f"{run_dir}: no scenario.yaml beside the bag; report needs the run folder ./rfidnav run wrote")
    scenario = yaml.safe_load(scenario_file.read_text())
    world = load_world(run_dir / "world.yaml")
    mission, namespace = scenario["mission"], ""
    if robot is not None:
        entries = {entry["name"]: entry for entry in scenario.get("robots", [])}
        if robot not in entries:
            raise BagError(f"{run_dir}: no robot '{robot}' in its scenario (robots: {', '.join(entries) or 'none'})")
        mission, namespace = entries[robot]["mission"], f"/{robot}"
    route = list(mission["goal"].get("tag_ids", []))
    action = robot_action(robot, mission["action"]).rstrip("/")
    status_topic, feedback_topic = f"{action}/_action/status", f"{action}/_action/feedback"
    truth_topic, odom_topic = f"{namespace}/sim/ground_truth", f"{namespace}/odom"
    times, xy = [], []
    start_s = end_s = None
    final = None
    arrivals: list[float] = []
    target = 0
    last_feedback = None
    odom_times, odom_xy = [], []
    feedback_times: list[float] = []
    searching: list[bool] = []
    for topic, stamp_ns, msg in read_messages(bag, [truth_topic, odom_topic, status_topic, feedback_topic]):
        now_s = stamp_ns * 1e-9
        if topic in (truth_topic, odom_topic):
            stamp_s = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
            position = (msg.pose.pose.position.x, msg.pose.pose.position.y)
            (times if topic == truth_topic else odom_times).append(stamp_s)
            (xy if topic == truth_topic else odom_xy).append(position)
        elif topic == status_topic:
            for status in msg.status_list:
                if status.status in (STATUS_ACCEPTED, STATUS_EXECUTING) and start_s is None:
                    start_s = status.goal_info.stamp.sec + status.goal_info.stamp.nanosec * 1e-9
                elif status.status in STATUS_FINAL and final is None:
                    final, end_s = STATUS_FINAL[status.status], now_s
        elif topic == feedback_topic and final is None:
            last_feedback = msg.feedback
            feedback_times.append(now_s)
            searching.append(is_searching(msg.feedback))
            while getattr(msg.feedback, "target_index", 0) > target:   # tag routes: the next target means arrival
                arrivals.append(now_s)
                target += 1
    source = "ground_truth"
    if not times:
        if not odom_times:
            raise BagError(f"{bag}: neither {truth_topic} nor {odom_topic} messages: nothing to report")
        times, xy, source = odom_times, odom_xy, "odom"
    if start_s is None:
        raise BagError(f"{bag}: no goal status on {status_topic}; was the mission sent?")
    if final == "succeeded" and len(arrivals) < len(route):
        arrivals.append(end_s)
    trajectory = Trajectory(np.array(times), np.array(xy))
    end_s = end_s if end_s is not None else float(trajectory.times_s[-1])
    return RunRecord(run_dir, bag, world, route, trajectory, start_s, end_s, final, arrivals,
                     list(scenario.get("metrics", [])), dict(mission["goal"]), last_feedback, action,
                     source, tuple(flagged_spans(feedback_times, searching, end_s)),
                     mission.get("success_within_m"), robot, namespace)


def is_searching(feedback: object) -> bool:
    """Whether a mission's feedback says it is searching: a tag route's search for an unheard target (its mode,
    rfidnav_control.tag_route.SEARCH_MODES) or a two-tier navigator's spiral search (its phase)."""
    return getattr(feedback, "mode", None) in SEARCH_MODES or getattr(feedback, "phase", None) == "searching"


def route_points(world: World, route: list[str]) -> np.ndarray:
    return np.array([world.tag(tag).position[:2] for tag in route], dtype=float).reshape(-1, 2)


def run_metrics(path: Path, robot: str | None = None) -> dict[str, float | int | None]:
    """The metric groups the run's scenario asks for, from its bag (``robot``'s, in a run of several)."""
    return record_metrics(load_run(path, robot))


def record_metrics(record: RunRecord) -> dict[str, float | int | None]:
    """The scenario's metric groups and, on every run with ground truth, the walls its whole track crossed."""
    if record.trajectory_source == "odom":
        run = record.ground_truth.between(record.mission_start_s, record.mission_end_s)
        return {"odom_path_length_m": float(np.linalg.norm(np.diff(run.xy, axis=0), axis=1).sum())}
    metrics: dict[str, float | int | None] = {
        "wall_crossings": wall_crossings(record.ground_truth.xy, record.world.wall_segments())}
    if "tracking" in record.metric_groups:
        metrics.update(tracking_metrics(record.ground_truth, route_points(record.world, record.route),
                                        record.arrival_times_s, record.mission_start_s, record.mission_end_s,
                                        searching=record.searching).as_dict())
    if "partition" in record.metric_groups:
        target = record.goal.get("target", {})
        replans = getattr(record.last_feedback, "replans", None)
        metrics.update(partition_metrics(record.ground_truth, record.mission_start_s, record.mission_end_s,
                                         (float(target.get("x", 0.0)), float(target.get("y", 0.0))),
                                         replans).as_dict())
    if "topological" in record.metric_groups:
        first_arrival = next(((msg.feedback.current_node, msg.feedback.arrival_direction)
                              for _, _, msg in mission_feedback(record) if msg.feedback.current_node), None)
        feedback = record.last_feedback
        topological_map = learned_map(record.run_dir / "map.yaml", feedback)
        metrics.update(topological_metrics(
            record.ground_truth, record.mission_start_s, record.mission_end_s, topological_map,
            str(record.goal.get("goal_node")), first_arrival,
            getattr(feedback, "tags_missed", None), getattr(feedback, "replans", None)).as_dict())
    if "two_tier" in record.metric_groups:
        target = record.goal.get("target", {})
        metrics.update(two_tier_metrics(record.ground_truth, record.mission_start_s, record.mission_end_s,
                                        (float(target.get("x", 0.0)), float(target.get("y", 0.0))),
                                        two_tier_fixes(record), list(record.searching)).as_dict())
    if record.metric_groups:
        metrics.update(success_verdict(metrics, record.success_within_m))
    return metrics


def learned_map(map_file: Path, feedback: object | None) -> TopologicalMap:
    """The run's map with the ``?`` hallways the mission executor learned (its last feedback's
    ``learned_hallways``), as its in-process runner measures the shortest path on the map learned by the end: a
    goal reached through an explored hallway has a route."""
    topological_map = load_topological_map(map_file)
    for text in getattr(feedback, "learned_hallways", None) or ():
        try:
            topological_map = topological_map.with_hallway(*parse_hallway_text(text))
        except (ValueError, KeyError) as error:      # a bag of another map or version: the given map stands
            print(f"{map_file}: learned hallway '{text}' not applied ({error})", file=sys.stderr)
    return topological_map


def mission_feedback(record: RunRecord, topics: tuple[str, ...] = ()):
    """(topic, stamp_ns, message) of the mission's action feedback, and of ``topics``, during the mission."""
    for topic, stamp_ns, msg in read_messages(record.bag, [*topics, f"{record.action}/_action/feedback"]):
        if record.mission_start_s <= stamp_ns * 1e-9 <= record.mission_end_s:
            yield topic, stamp_ns, msg


def two_tier_fixes(record: RunRecord) -> list[Fix]:
    """The tier-two fixes the navigator reported on /localization/status (a new last_fix_tag_id) during the
    mission."""
    fixes: list[Fix] = []
    last_tag = ""
    status_topic = f"{record.namespace}/localization/status"
    for topic, _, msg in mission_feedback(record, (status_topic,)):
        if topic != status_topic:
            continue
        if msg.last_fix_tier == 2 and msg.last_fix_tag_id != last_tag:
            fixes.append(Fix(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, msg.last_fix_tag_id,
                             (msg.x, msg.y)))
        last_tag = msg.last_fix_tag_id
    return fixes


def draw_world(axes, record: RunRecord, run: Trajectory) -> None:
    """The world's walls, tag deployments and tags, and the mission's desired path or goal, in the map frame."""
    draw_walls(axes, record.world)
    for deployment in record.world.deployments:
        x_min, y_min, x_max, y_max = deployment.area
        axes.plot([x_min, x_max, x_max, x_min, x_min], [y_min, y_min, y_max, y_max, y_min], color="tab:purple",
                  linewidth=1, label=f"{deployment.lattice.layout} tags, r = {deployment.read_range_m * 100:g} cm")
    points = route_points(record.world, record.route)
    if len(points):
        axes.plot(points[:, 0], points[:, 1], "--", color="tab:green", label="desired path")
    target = record.goal.get("target")
    if isinstance(target, dict) and len(run.xy):
        axes.plot([run.xy[0, 0], target["x"]], [run.xy[0, 1], target["y"]], "--", color="tab:green",
                  label="shortest path")
        axes.plot(target["x"], target["y"], "*", color="tab:red", markersize=12, label="goal")
    goal_node = record.goal.get("goal_node")
    if goal_node is not None:
        for tag in record.world.wall_tags:
            axes.plot(*tag.position, "s", color="tab:orange", markersize=4)
        goal_xy = load_topological_map(record.run_dir / "map.yaml").nodes[goal_node].position
        if goal_xy is not None:
            axes.plot(*goal_xy, "*", color="tab:red", markersize=12, label=f"goal node {goal_node}")
    for tag in record.world.tags:
        marker, colour = ("s", "tab:orange") if tag.kind == "ceiling" else ("o", "tab:purple")
        axes.plot(tag.position[0], tag.position[1], marker, color=colour, markersize=5)
        if tag.kind == "ceiling":
            axes.annotate(tag.tag_id, tag.position[:2], textcoords="offset points", xytext=(4, 4))


def draw_walls(axes, world: World) -> None:
    for x1, y1, x2, y2 in world.walls:
        axes.plot([x1, x2], [y1, y2], color="0.6", linewidth=2)


def save_map_plot(figure: Any, axes: Any, title: str, path: Path) -> Path:
    """A plot in the map frame finished as every trajectory plot is (equal axes in metres, legend, grid), saved."""
    axes.set_aspect("equal")
    axes.set_xlabel("x [m]")
    axes.set_ylabel("y [m]")
    axes.set_title(title)
    axes.legend(loc="best")
    axes.grid(True, alpha=0.3)
    figure.savefig(path, dpi=110, bbox_inches="tight")
    return path


def new_figure(width_in: float, height_in: float) -> Any:
    """A figure of matplotlib's object API (no pyplot and its global figures; PNGs through Agg), imported at the
    first plot: a run's summary, which computes metrics only, then does not wait for matplotlib (a second of a
    Ctrl-C's end on a loaded machine)."""
    from matplotlib.figure import Figure

    return Figure(figsize=(width_in, height_in))


def write_report(path: Path, out_dir: Path | None = None) -> tuple[dict[str, Any], list[Path]]:
    """Recompute the metrics and write trajectory.png (and tracking_error.png for tag routes) into ``out_dir``
    (created if missing; default: the run folder). A run of several robots: each robot's metrics (by name) and
    one trajectory.png of all of them in their world."""
    robots = robots_of(path)
    if robots:
        return write_fleet_report(path, robots, out_dir)
    record = load_run(path)
    out_dir = record.run_dir if out_dir is None else out_dir
    out_dir.mkdir(parents=True, exist_ok=True)
    metrics = record_metrics(record)
    run = record.ground_truth.between(record.mission_start_s, record.mission_end_s)
    figure = new_figure(7.0, 7.0)
    axes = figure.add_subplot()
    if record.trajectory_source == "ground_truth":
        draw_world(axes, record, run)
        axes.plot(run.xy[:, 0], run.xy[:, 1], color="tab:blue", label="robot (ground truth)")
    else:       # a real robot: its odometry, in the odom frame, which the world's map frame is not
        axes.plot(run.xy[:, 0], run.xy[:, 1], color="tab:blue", label="robot (odometry, odom frame)")
    axes.plot(*run.xy[0], "k^", label="start")
    trajectory_png = save_map_plot(figure, axes, f"{record.run_dir.name}: trajectory", out_dir / "trajectory.png")
    if "tracking" not in record.metric_groups or record.trajectory_source != "ground_truth":
        return metrics, [trajectory_png]
    points = route_points(record.world, record.route)

    error = tracking_error(run, points)
    figure = new_figure(8.0, 3.5)
    axes = figure.add_subplot()
    axes.plot(error.times_s - record.mission_start_s, error.xy[:, 0] * 100.0, color="tab:red")
    axes.axhline(0.0, color="0.5", linewidth=0.8)
    rmse = metrics.get("tracking_rmse_m")
    axes.set_title(f"tracking error (RMSE {rmse * 100:.2f} cm)" if rmse is not None else "tracking error")
    axes.set_xlabel("time since mission start [s]")
    axes.set_ylabel("e(t) [cm], + = left of path")
    axes.grid(True, alpha=0.3)
    error_png = out_dir / "tracking_error.png"
    figure.savefig(error_png, dpi=110, bbox_inches="tight")
    return metrics, [trajectory_png, error_png]


def fleet_metrics(records: list[RunRecord]) -> tuple[dict[str, dict[str, Any]], dict[str, Any]]:
    """A run of several robots: each robot's metrics by name, and what the robots did together."""
    return {str(record.robot): record_metrics(record) for record in records}, closest_approach(records)


def closest_approach(records: list[RunRecord]) -> dict[str, Any]:
    """How near two robots came (ground truth, centre to centre, over the samples both have: robot_sim stamps every
    robot's alike): the distance [m], when [s of sim time] and which two. Two round bases touch at the sum of their
    footprints' radii (0.34 m for two of robot_sim's defaults)."""
    best: tuple[float, float, str, str] | None = None
    for first, second in combinations(records, 2):
        a, b = first.ground_truth, second.ground_truth
        _, ia, ib = np.intersect1d(np.round(a.times_s, 6), np.round(b.times_s, 6), return_indices=True)
        if not len(ia):
            continue
        gaps = np.linalg.norm(a.xy[ia] - b.xy[ib], axis=1)
        nearest = int(np.argmin(gaps))
        if best is None or gaps[nearest] < best[0]:
            best = (float(gaps[nearest]), float(a.times_s[ia[nearest]]), str(first.robot), str(second.robot))
    if best is None:
        return {}
    return {"closest_approach_m": best[0], "closest_approach_at_s": best[1], "closest_pair": f"{best[2]}, {best[3]}"}


def write_fleet_report(path: Path, robots: list[str], out_dir: Path | None) -> tuple[dict[str, Any], list[Path]]:
    """Each robot's metrics, what they did together, and the joint plot: every robot's track, start and goal in the
    one world."""
    records = [load_run(path, robot) for robot in robots]
    out_dir = records[0].run_dir if out_dir is None else out_dir
    out_dir.mkdir(parents=True, exist_ok=True)
    per_robot, joint = fleet_metrics(records)
    metrics: dict[str, Any] = {**per_robot, **joint}
    figure = new_figure(8.0, 7.0)
    axes = figure.add_subplot()
    draw_walls(axes, records[0].world)
    for index, record in enumerate(records):
        colour = f"C{index}"
        run = record.ground_truth.between(record.mission_start_s, record.mission_end_s)
        axes.plot(run.xy[:, 0], run.xy[:, 1], color=colour, label=f"{record.robot} (ground truth)")
        axes.plot(*run.xy[0], "^", color=colour)
        goal = goal_position(record)
        if goal is not None:
            axes.plot(*goal, "*", color=colour, markersize=14, markeredgecolor="k", label=f"{record.robot}'s goal")
    return metrics, [save_map_plot(figure, axes, f"{records[0].run_dir.name}: trajectories (^ start, * goal)",
                                   out_dir / "trajectory.png")]


def goal_position(record: RunRecord) -> tuple[float, float] | None:
    """Where a record's mission ends in the map: its target point, its goal node's position, its route's last tag."""
    target = record.goal.get("target")
    if isinstance(target, dict):
        return float(target["x"]), float(target["y"])
    goal_node = record.goal.get("goal_node")
    if goal_node is not None:
        return load_topological_map(record.run_dir / "map.yaml").nodes[goal_node].position
    points = route_points(record.world, record.route)
    return (float(points[-1, 0]), float(points[-1, 1])) if len(points) else None


# ---------------------------------------------------------------- topological maps (./rfidnav map draw)

def draw_map(topological_map: TopologicalMap, path_png: Path | str) -> None:
    """Draw the map to a PNG: nodes, hallways labelled at each end with the side and its arrival tags,
    unmapped (``?``) hallways as dashed stubs, and a north arrow.

    Nodes stand at their positions when every node has one, else one unit step per hallway in its compass
    direction (relaxed by a spring layout where steps would stack nodes)."""
    positions = _layout(topological_map)
    edges = topological_map.edges()
    drawn_lengths = sorted(math.dist(positions[e.node_a], positions[e.node_b]) for e in edges)
    stub = 0.35 * (drawn_lengths[len(drawn_lengths) // 2] if drawn_lengths else 1.0)

    figure = new_figure(10.0, 8.0)
    axes = figure.add_subplot()
    label_style = {"fontsize": 7, "ha": "center", "va": "center",
                   "bbox": {"boxstyle": "round,pad=0.2", "facecolor": "white", "edgecolor": "none", "alpha": 0.85}}

    def end_label(node: str, side: str, at: tuple[float, float]) -> None:
        tags = topological_map.nodes[node].hallways[side].tags
        axes.text(at[0], at[1], f"{side} {','.join(tags) or '-'}", **label_style)

    for edge in edges:
        (xa, ya), (xb, yb) = positions[edge.node_a], positions[edge.node_b]
        axes.plot([xa, xb], [ya, yb], color="0.35", linewidth=2.0, zorder=1)
        end_label(edge.node_a, edge.side_a, (xa + 0.3 * (xb - xa), ya + 0.3 * (yb - ya)))
        end_label(edge.node_b, edge.side_b, (xb + 0.3 * (xa - xb), yb + 0.3 * (ya - yb)))
    for node in topological_map.nodes.values():
        for side, hallway in node.hallways.items():
            if hallway.neighbour == UNKNOWN:
                angle = topological_map.direction_angle_rad(side)
                x, y = positions[node.name]
                tip = (x + stub * math.cos(angle), y + stub * math.sin(angle))
                axes.plot([x, tip[0]], [y, tip[1]], color="0.35", linewidth=1.5, linestyle="--", zorder=1)
                axes.text(tip[0], tip[1], f"{side} ? {','.join(hallway.tags)}", **label_style)
    for name, (x, y) in positions.items():
        axes.scatter([x], [y], s=300, color="tab:blue", zorder=2)
        axes.text(x, y, name, color="white", fontsize=8, fontweight="bold", ha="center", va="center", zorder=3)

    north = math.radians(topological_map.north_deg)
    axes.annotate("N", xy=(0.93, 0.08), xycoords="axes fraction", textcoords="offset points",
                  xytext=(30.0 * math.cos(north), 30.0 * math.sin(north)), ha="center", va="center",
                  fontweight="bold", arrowprops={"arrowstyle": "<-", "linewidth": 1.5})
    axes.set_aspect("equal", adjustable="datalim")
    axes.margins(0.12)
    axes.set_title(f"{topological_map.name}: topological map (labels: side and arrival tags at each end)")
    if all(node.position is not None for node in topological_map.nodes.values()):
        axes.set_xlabel("x [m]")
        axes.set_ylabel("y [m]")
    else:
        axes.set_axis_off()
    figure.savefig(Path(path_png), dpi=110)


def _layout(topological_map: TopologicalMap) -> dict[str, tuple[float, float]]:
    nodes = topological_map.nodes.values()
    if all(node.position is not None for node in nodes):
        return {node.name: node.position for node in nodes if node.position is not None}
    # One unit step per hallway in its compass direction keeps the map's turns in the drawing; only where those
    # steps put two nodes on one spot (hallways of very different lengths) do springs pull the layout apart.
    graph = topological_map.graph("edges")
    steps: dict[str, tuple[float, float]] = {}
    for first in topological_map.nodes:
        if first in steps:
            continue
        steps[first] = (2.0 * len(steps), 0.0)
        for parent, child in nx.bfs_edges(graph, first):
            angle = topological_map.direction_angle_rad(topological_map.departure_direction(parent, child))
            steps[child] = (steps[parent][0] + math.cos(angle), steps[parent][1] + math.sin(angle))
    spots = {(round(x, 6), round(y, 6)) for x, y in steps.values()}
    if len(spots) == len(steps):
        return steps
    layout = nx.spring_layout(graph, pos=steps, seed=0)
    return {name: (float(x), float(y)) for name, (x, y) in layout.items()}

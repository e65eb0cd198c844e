"""Fuzzy heading controller of paper 001: fast path against scikit-fuzzy, sign convention, spec validation."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
import skfuzzy

from rfidnav_common.errors import RfidnavError
from rfidnav_control.errors import ControlError, FuzzySpecError
from rfidnav_control.fuzzy import (
    FuzzyHeadingController,
    FuzzyHeadingSpec,
    FuzzySet,
    paper_spec,
    reference_controller,
)
from rfidnav_experiments.bench.fuzzy import benchmark

# skfuzzy 0.5.0 calls np.maximum(a, b, out) positionally, which numpy 2.4 deprecates; not ours to fix.
pytestmark = [pytest.mark.tier("unit"),
              pytest.mark.filterwarnings("ignore:Passing more than 2 positional arguments:DeprecationWarning")]

PI = math.pi
TOLERANCE_RAD = 1e-3
RANDOM_INPUTS = 10_000
SIMULATION_INPUTS = {"paper": 1000, "five": 300}  # ControlSystemSimulation costs ~5 ms per input


def five_rule_spec() -> FuzzyHeadingSpec:
    # Corners at whole radians lie between the reference's grid points (multiples of pi/1000), so this spec
    # also exercises the reference's sampling of the sets, not only the inference.
    return FuzzyHeadingSpec.from_flat(
        input_range=PI,
        output_range=0.5,
        input_set_names=["NB", "NS", "Z", "PS", "PB"],
        input_set_points=[-PI, -PI, -2, -1, -2, -1, -1, 0, -1, 0, 0, 1, 0, 1, 1, 2, 1, 2, PI, PI],
        output_set_names=["RB", "RS", "Z", "LS", "LB"],
        output_set_points=[-0.5, -0.5, -0.4, -0.2, -0.4, -0.2, -0.2, 0, -0.2, 0, 0, 0.2, 0, 0.2, 0.2, 0.4,
                           0.2, 0.4, 0.5, 0.5],
        rules=["NB->LB", "NS->LS", "Z->Z", "PS->RS", "PB->RB"],
        resolution=2001,
    )


SPECS = {"paper": paper_spec, "five": five_rule_spec}


def lowlevel_reference(spec: FuzzyHeadingSpec, inputs: np.ndarray) -> np.ndarray:
    """What ControlSystemSimulation computes, step by step with skfuzzy's own functions, ~10x faster.

    Fuzzification by ``interp_membership`` on the sampled sets, max over rules per output set, the output
    universe upsampled at the cut points with ``interp_universe``, clipped sets max-aggregated, then the
    centroid with skfuzzy's piecewise-linear formula (``skfuzzy.defuzzify.centroid``) written with numpy
    instead of its Python loop. Checked against ControlSystemSimulation in the tests below.
    """
    input_universe = np.linspace(-spec.input_range, spec.input_range, spec.resolution)
    output_universe = np.linspace(-spec.output_range, spec.output_range, spec.resolution)
    input_mfs = {s.name: skfuzzy.trapmf(input_universe, list(s.points)) for s in spec.input_sets}
    output_mfs = {s.name: skfuzzy.trapmf(output_universe, list(s.points)) for s in spec.output_sets}
    clipped = np.clip(inputs, input_universe[0], input_universe[-1])
    firing = {name: skfuzzy.interp_membership(input_universe, mf, clipped) for name, mf in input_mfs.items()}
    results = np.empty(len(clipped))
    for k in range(len(clipped)):
        cuts: dict[str, float] = {}
        for source, target in spec.rules:
            cuts[target] = max(cuts.get(target, 0.0), float(firing[source][k]))
        extra = [x for name, cut in cuts.items()
                 for x in skfuzzy.interp_universe(output_universe, output_mfs[name], cut)]
        universe = np.union1d(output_universe, extra)
        aggregated = np.zeros_like(universe)
        for name, cut in cuts.items():
            clipped_set = np.minimum(cut, skfuzzy.interp_membership(output_universe, output_mfs[name], universe))
            np.maximum(aggregated, clipped_set, out=aggregated)
        if aggregated.sum() == 0.0:
            results[k] = 0.0
            continue
        x1, x2, y1, y2 = universe[:-1], universe[1:], aggregated[:-1], aggregated[1:]
        area = 0.5 * (x2 - x1) * (y1 + y2)
        height = np.where(y1 + y2 > 0.0, y1 + y2, 1.0)
        moment = x1 + 2.0 / 3.0 * (x2 - x1) * (y2 + 0.5 * y1) / height
        results[k] = (moment * area).sum() / max(area.sum(), np.finfo(float).eps)
    return results


@pytest.fixture(scope="module", params=sorted(SPECS))
def case(request: pytest.FixtureRequest) -> dict[str, Any]:
    spec = SPECS[request.param]()
    inputs = np.random.default_rng(20261122).uniform(-spec.input_range, spec.input_range, RANDOM_INPUTS)
    return {
        "name": request.param,
        "spec": spec,
        "inputs": inputs,
        "controller": FuzzyHeadingController(spec),
        "reference": lowlevel_reference(spec, inputs),
    }


# -- fast path against the reference ------------------------------------------------------------------------------


@pytest.mark.tier("slow")
def test_fast_path_matches_control_system_simulation(case: dict[str, Any]) -> None:
    count = SIMULATION_INPUTS[case["name"]]
    inputs = case["inputs"][:count]
    simulate = reference_controller(case["spec"])
    simulated = np.array([simulate(x) for x in inputs])
    # The low-level reference used for the 10,000 inputs is the simulation, to rounding.
    np.testing.assert_allclose(case["reference"][:count], simulated, rtol=0.0, atol=1e-9)
    fast = np.array([case["controller"](x) for x in inputs])
    assert np.max(np.abs(fast - simulated)) < TOLERANCE_RAD


@pytest.mark.tier("slow")
def test_fast_path_matches_reference_on_random_inputs(case: dict[str, Any]) -> None:
    controller: FuzzyHeadingController = case["controller"]
    many = controller.evaluate_many(case["inputs"])
    scalar = np.array([controller(x) for x in case["inputs"]])
    np.testing.assert_array_equal(scalar, many)
    assert np.max(np.abs(many - case["reference"])) < TOLERANCE_RAD
    # The comparison is not vacuous: the outputs span a good part of the output universe.
    assert np.ptp(case["reference"]) > 0.5 * case["spec"].output_range


@pytest.mark.tier("slow")
def test_table_matches_exact_centroid(case: dict[str, Any]) -> None:
    controller: FuzzyHeadingController = case["controller"]
    assert controller.table_error <= 1e-6
    exact = controller.evaluate_exact(case["inputs"])
    assert np.max(np.abs(controller.evaluate_many(case["inputs"]) - exact)) <= controller.table_error * 1.01 + 1e-12


@pytest.mark.tier("slow")
def test_comparison_detects_a_wrong_rule(case: dict[str, Any]) -> None:
    spec: FuzzyHeadingSpec = case["spec"]
    # Swap the consequents of the first and last rules: the controller then steers the wrong way for large |x|.
    rules = list(spec.rules)
    (first_in, first_out), (last_in, last_out) = rules[0], rules[-1]
    rules[0], rules[-1] = (first_in, last_out), (last_in, first_out)
    wrong = FuzzyHeadingController(FuzzyHeadingSpec(spec.input_range, spec.output_range, spec.input_sets,
                                                     spec.output_sets, tuple(rules), spec.resolution))
    assert np.max(np.abs(wrong.evaluate_many(case["inputs"]) - case["reference"])) > 0.1


# -- sign convention and shape --------------------------------------------------------------------------------------


def test_tag_on_left_turns_ccw_and_on_right_turns_cw() -> None:
    controller = FuzzyHeadingController(paper_spec())
    reference = reference_controller(paper_spec())
    left = -np.geomspace(1e-3, PI, 200)  # delta_phi < 0: tag closer to antenna 1, on the left
    assert np.all(controller.evaluate_many(left) > 0.0)
    assert np.all(controller.evaluate_many(-left) < 0.0)
    assert controller(0.0) == pytest.approx(0.0, abs=1e-12)
    for x in (-2.0, -0.3):
        assert reference(x) > 0.0 and reference(-x) < 0.0
        assert controller(x) == pytest.approx(reference(x), abs=TOLERANCE_RAD)
    assert reference(0.0) == pytest.approx(0.0, abs=1e-12)


def test_paper_output_is_monotone_and_odd() -> None:
    controller = FuzzyHeadingController(paper_spec())
    grid = np.linspace(-PI, PI, 20001)
    for output in (controller.evaluate_many(grid), controller.evaluate_exact(grid)):
        assert np.all(np.diff(output) <= 1e-12)
        np.testing.assert_allclose(output, -output[::-1], rtol=0.0, atol=1e-9)
    # Saturated ends: the centroid of the CCW shoulder (0, 0.15, 0.3, 0.3) alone.
    assert controller(-PI) == pytest.approx(0.04125 / 0.225, abs=1e-9)


def test_evaluate_many_keeps_shape() -> None:
    controller = FuzzyHeadingController(paper_spec())
    inputs = np.linspace(-1.0, 1.0, 12).reshape(3, 4)
    outputs = controller.evaluate_many(inputs)
    assert outputs.shape == (3, 4)
    np.testing.assert_array_equal(outputs.ravel(), [controller(x) for x in inputs.ravel()])


# -- clipping, no rule firing, NaN ----------------------------------------------------------------------------------


@pytest.mark.parametrize("outside, edge", [(10.0, PI), (-10.0, -PI), (PI + 1e-9, PI), (-7.5, -PI)])
def test_inputs_outside_universe_are_clipped(outside: float, edge: float) -> None:
    controller = FuzzyHeadingController(paper_spec())
    reference = reference_controller(paper_spec())
    assert controller(outside) == controller(edge)
    assert abs(controller(outside)) > 0.1
    assert controller.evaluate_many(np.array([outside]))[0] == controller(edge)
    assert reference(outside) == pytest.approx(reference(edge), abs=1e-12)
    assert controller(outside) == pytest.approx(reference(outside), abs=TOLERANCE_RAD)


def test_no_rule_firing_gives_zero() -> None:
    # Only the left third of the input universe has a set: elsewhere no rule fires.
    spec = FuzzyHeadingSpec.from_flat(PI, 0.3, ["neg"], [-PI, -PI, -2.0, -1.0], ["ccw", "cw"],
                                      [0.0, 0.15, 0.3, 0.3, -0.3, -0.3, -0.15, 0.0], ["neg->ccw"], 2001)
    controller = FuzzyHeadingController(spec)
    reference = reference_controller(spec)
    for x in (0.0, 1.5, PI, 20.0):
        assert controller(x) == 0.0
        assert reference(x) == 0.0
    assert controller.evaluate_many(np.array([0.0, 2.0])).tolist() == [0.0, 0.0]
    # Just inside the set the output jumps to the CCW centroid, as the weakest firing still picks the set.
    assert controller(-1.0 - 1e-6) == pytest.approx(0.15, abs=1e-3)
    assert controller(-2.5) == pytest.approx(reference(-2.5), abs=TOLERANCE_RAD)


def test_nan_input_raises_control_error() -> None:
    controller = FuzzyHeadingController(paper_spec())
    with pytest.raises(ControlError, match="NaN"):
        controller(float("nan"))
    with pytest.raises(ControlError, match="NaN"):
        controller.evaluate_many(np.array([0.0, np.nan]))


# -- specification ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("make_spec", [paper_spec, five_rule_spec], ids=["paper", "five"])
def test_from_flat_round_trip(make_spec: Any) -> None:
    spec = make_spec()
    flat = spec.to_flat()
    assert FuzzyHeadingSpec.from_flat(**flat) == spec
    assert len(flat["input_set_points"]) == 4 * len(flat["input_set_names"])
    assert all("->" in rule for rule in flat["rules"])


def test_from_flat_accepts_integers_and_spaced_rules() -> None:
    spec = FuzzyHeadingSpec.from_flat(3, 1, ["n", "p"], [-3, -3, -1, 0, 0, 1, 3, 3], ["l", "r"],
                                      [0, 1, 1, 1, -1, -1, -1, 0], [" n -> l", "p->r "], 101)
    assert spec.rules == (("n", "l"), ("p", "r"))
    assert spec.input_range == 3.0 and isinstance(spec.input_range, float)
    assert spec.input_sets[0] == FuzzySet("n", (-3.0, -3.0, -1.0, 0.0))


def _flat_with(**changes: Any) -> dict[str, Any]:
    flat = paper_spec().to_flat()
    flat.update(changes)
    return flat


def _points_with(kind: str, index: int, value: Any) -> list[Any]:
    points = list(paper_spec().to_flat()[f"{kind}_set_points"])
    points[index] = value
    return points


BAD_FLAT = {
    "input points too short": (_flat_with(input_set_points=_points_with("input", 0, -PI)[:-1]),
                               ["input_set_points", "4 numbers per set", "12", "11"]),
    "output points too long": (_flat_with(output_set_points=_points_with("output", 0, -0.3) + [0.3]),
                               ["output_set_points", "13"]),
    "unsorted input set": (_flat_with(input_set_points=_points_with("input", 5, 1.0)),
                           ["input set 'zero'", "a <= b <= c <= d"]),
    "unsorted output set": (_flat_with(output_set_points=_points_with("output", 8, 0.2)),
                            ["output set 'ccw'", "a <= b <= c <= d"]),
    "rule names unknown output": (_flat_with(rules=["neg->left", "zero->zero", "pos->cw"]),
                                  ["rule 0 'neg->left'", "unknown output set 'left'"]),
    "rule names unknown input": (_flat_with(rules=["neg->ccw", "zero->zero", "positive->cw"]),
                                 ["rule 2 'positive->cw'", "unknown input set 'positive'"]),
    "rule without arrow": (_flat_with(rules=["neg->ccw", "zero zero"]), ["rule 1 'zero zero'"]),
    "rule with empty side": (_flat_with(rules=["neg->"]), ["rule 0 'neg->'"]),
    "duplicate rule": (_flat_with(rules=["neg->ccw", "neg->ccw"]), ["rule 1 'neg->ccw'", "duplicate"]),
    "no rules": (_flat_with(rules=[]), ["rules", "at least one"]),
    "input set outside universe": (_flat_with(input_set_points=_points_with("input", 11, 4.0)),
                                   ["input set 'pos'", "universe"]),
    "output set outside universe": (_flat_with(output_set_points=_points_with("output", 0, -0.31)),
                                    ["output set 'cw'", "universe"]),
    "NaN in output set": (_flat_with(output_set_points=_points_with("output", 1, float("nan"))),
                          ["output set 'cw'", "point b", "finite"]),
    "infinite input point": (_flat_with(input_set_points=_points_with("input", 0, -math.inf)),
                             ["input set 'neg'", "point a", "finite"]),
    "text among points": (_flat_with(input_set_points=_points_with("input", 6, "0")),
                          ["input set 'zero'", "point c", "expected a number"]),
    "bool among points": (_flat_with(input_set_points=_points_with("input", 6, True)),
                          ["input set 'zero'", "expected a number"]),
    "zero-width set": (_flat_with(output_set_points=[-0.3, -0.3, -0.15, 0.0, 0.0, 0.0, 0.0, 0.0,
                                                     0.0, 0.15, 0.3, 0.3]),
                       ["output set 'zero'", "zero width"]),
    "duplicate set name": (_flat_with(input_set_names=["neg", "zero", "neg"]), ["input set 'neg'", "more than once"]),
    "name with arrow": (_flat_with(input_set_names=["neg", "ze->ro", "pos"]), ["'ze->ro'"]),
    "non-positive input range": (_flat_with(input_range=0.0), ["input_range", "positive"]),
    "NaN output range": (_flat_with(output_range=float("nan")), ["output_range", "finite"]),
    "resolution too small": (_flat_with(resolution=2), ["resolution", ">= 3"]),
    "resolution not integer": (_flat_with(resolution=2001.5), ["resolution"]),
}


@pytest.mark.parametrize("flat, expected", BAD_FLAT.values(), ids=BAD_FLAT.keys())
def test_from_flat_rejects_inconsistency(flat: dict[str, Any], expected: list[str]) -> None:
    with pytest.raises(FuzzySpecError) as raised:
        FuzzyHeadingSpec.from_flat(**flat)
    message = str(raised.value)
    for fragment in expected:
        assert fragment in message, f"{fragment!r} not in {message!r}"


def test_spec_errors_belong_to_the_hierarchy() -> None:
    assert issubclass(FuzzySpecError, ControlError) and issubclass(ControlError, RfidnavError)
    with pytest.raises(FuzzySpecError, match="fuzzy set 'x'"):
        FuzzySet("x", (1.0, 0.0, 2.0, 3.0))
    spec = paper_spec()
    with pytest.raises(FuzzySpecError, match="unknown output set 'ccw2'"):
        FuzzyHeadingSpec(spec.input_range, spec.output_range, spec.input_sets, spec.output_sets, (("neg", "ccw2"),))


def test_fuzzy_set_membership_matches_skfuzzy_trapmf() -> None:
    grid = np.linspace(-PI, PI, 2001)
    for fuzzy_set in paper_spec().input_sets + five_rule_spec().input_sets:
        ours = np.array([fuzzy_set.membership(x) for x in grid])
        np.testing.assert_allclose(ours, skfuzzy.trapmf(grid, list(fuzzy_set.points)), rtol=0.0, atol=1e-12)


def test_benchmark_reports_figures() -> None:
    figures = benchmark(evaluations=20, seed=3)
    assert set(figures) == {"reference_us", "fast_us", "speedup"}
    assert all(math.isfinite(v) and v > 0.0 for v in figures.values())
    assert figures["speedup"] == pytest.approx(figures["reference_us"] / figures["fast_us"])

"""The phase-difference fuzzy heading controller of paper 001 (Sec. IV-B), as a pure module (no ROS).

The controller is a single-input single-output Mamdani system: the input is the phase difference
``delta_phi = phi1 - phi2`` between the reader's two receiving antennas (antenna 1 on the robot's left), the
output is the heading change ``delta_theta`` the robot applies per control step (``theta_new = theta_old +
delta_theta``, paper eq. 3; CCW positive as in REP 103). Membership functions are trapezoids (a triangle is a
trapezoid with ``b == c``), AND/aggregation are min/max, implication is min (clipping), and defuzzification is the
centroid ("center of area").

Two implementations of the same controller live here:

* :func:`reference_controller` builds it with scikit-fuzzy's ``skfuzzy.control``. It is the reference the fast
  path is checked against, and it is slow (several milliseconds per evaluation).
* :class:`FuzzyHeadingController` is the runtime path: an exact analytic centroid, tabulated over the input
  universe and linearly interpolated (see its docstring), a microsecond or so per scalar evaluation.

:class:`FuzzyHeadingSpec` describes the controller; :meth:`FuzzyHeadingSpec.from_flat` builds one from the flat
lists a ROS 2 parameter file can hold, and :func:`paper_spec` gives the three rules of the paper.
"""

from __future__ import annotations

import bisect
import math
import numbers
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from rfidnav_control.errors import ControlError, FuzzySpecError

RULE_ARROW = "->"
INPUT_LABEL = "delta_phi"
OUTPUT_LABEL = "delta_theta"


def _as_real(value: Any, what: str) -> float:
    # bool is an int subclass; a True among set points is a YAML slip, not the number 1.
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise FuzzySpecError(f"{what}: expected a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise FuzzySpecError(f"{what}: expected a finite number, got {number!r}")
    return number


def _trapezoid_many(x: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Membership of every x (shape (N,)) in every trapezoid (rows of ``points``, shape (S, 4)) -> (N, S)."""
    a, b, c, d = (points[:, i] for i in range(4))
    xa = x[:, None]
    has_rise = b > a
    has_fall = d > c
    with np.errstate(divide="ignore", invalid="ignore"):
        rise = np.where(has_rise, (xa - a) / np.where(has_rise, b - a, 1.0), 1.0)
        fall = np.where(has_fall, (d - xa) / np.where(has_fall, d - c, 1.0), 1.0)
    inside = (xa >= a) & (xa <= d)
    return np.where(inside, np.clip(np.minimum(rise, fall), 0.0, 1.0), 0.0)


@dataclass(frozen=True)
class FuzzySet:
    """A named trapezoidal membership function with corners ``a <= b <= c <= d`` and ``a < d``.

    Membership is 0 outside [a, d], rises linearly on (a, b), is 1 on [b, c] and falls linearly on (c, d). A
    triangle has ``b == c``; a shoulder has ``a == b`` (left) or ``c == d`` (right), normally at the universe edge.
    The membership at a vertical edge (``a == b``) is 1, as in ``skfuzzy.trapmf``.
    """

    name: str
    points: tuple[float, float, float, float]

    def __post_init__(self) -> None:
        name = self.name
        if not isinstance(name, str) or not name or name != name.strip() or RULE_ARROW in name:
            raise FuzzySpecError(
                f"fuzzy set name {name!r}: expected a non-empty name without surrounding spaces or '{RULE_ARROW}'"
            )
        raw = tuple(self.points) if isinstance(self.points, Iterable) else (self.points,)
        if len(raw) != 4:
            raise FuzzySpecError(f"fuzzy set {name!r}: expected 4 points (a, b, c, d), got {len(raw)}")
        points = tuple(_as_real(p, f"fuzzy set {name!r}: point {'abcd'[i]}") for i, p in enumerate(raw))
        a, b, c, d = points
        if not a <= b <= c <= d:
            raise FuzzySpecError(f"fuzzy set {name!r}: points must satisfy a <= b <= c <= d, got {points}")
        if not a < d:
            # A zero-width set has zero area: it could never move a centroid.
            raise FuzzySpecError(f"fuzzy set {name!r}: zero width (a == d == {a})")
        object.__setattr__(self, "points", points)

    def membership(self, x: float) -> float:
        """Degree of membership of the crisp value ``x`` in this set, in [0, 1]."""
        a, b, c, d = self.points
        if x < a or x > d:
            return 0.0
        if x < b:
            return (x - a) / (b - a)
        if x <= c:
            return 1.0
        return (d - x) / (d - c)


def _check_sets(sets: Any, kind: str, universe: float) -> tuple[FuzzySet, ...]:
    if isinstance(sets, FuzzySet) or not isinstance(sets, Iterable):
        raise FuzzySpecError(f"{kind} sets: expected a sequence of FuzzySet, got {sets!r}")
    sets = tuple(sets)
    if not sets:
        raise FuzzySpecError(f"{kind} sets: at least one set is needed")
    seen: set[str] = set()
    for fuzzy_set in sets:
        if not isinstance(fuzzy_set, FuzzySet):
            raise FuzzySpecError(f"{kind} sets: expected FuzzySet, got {fuzzy_set!r}")
        if fuzzy_set.name in seen:
            raise FuzzySpecError(f"{kind} set {fuzzy_set.name!r}: name appears more than once")
        seen.add(fuzzy_set.name)
        a, _, _, d = fuzzy_set.points
        if a < -universe or d > universe:
            raise FuzzySpecError(
                f"{kind} set {fuzzy_set.name!r}: points {fuzzy_set.points} leave the {kind} universe "
                f"[{-universe!r}, {universe!r}]"
            )
    return sets


@dataclass(frozen=True)
class FuzzyHeadingSpec:
    """A single-input single-output Mamdani heading controller.

    ``input_range``: the input ``delta_phi`` lives in [-input_range, input_range] (rad); inputs outside are
    clipped. ``output_range``: the output ``delta_theta`` lives in [-output_range, output_range] (rad per control
    step, CCW positive). ``rules`` pairs an input set name with an output set name. ``resolution`` is the number
    of samples of each universe in the scikit-fuzzy reference only; the fast path is exact and does not use it.
    Every inconsistency raises :class:`FuzzySpecError` naming the offending item.
    """

    input_range: float
    output_range: float
    input_sets: tuple[FuzzySet, ...]
    output_sets: tuple[FuzzySet, ...]
    rules: tuple[tuple[str, str], ...]
    resolution: int = 2001

    def __post_init__(self) -> None:
        input_range = _as_real(self.input_range, "input_range")
        output_range = _as_real(self.output_range, "output_range")
        for what, value in (("input_range", input_range), ("output_range", output_range)):
            if value <= 0.0:
                raise FuzzySpecError(f"{what}: expected a positive half-width of the universe, got {value!r}")
        input_sets = _check_sets(self.input_sets, "input", input_range)
        output_sets = _check_sets(self.output_sets, "output", output_range)
        input_names = [s.name for s in input_sets]
        output_names = [s.name for s in output_sets]
        if isinstance(self.rules, (str, bytes)) or not isinstance(self.rules, Iterable):
            raise FuzzySpecError(f"rules: expected a sequence of (input set, output set) pairs, got {self.rules!r}")
        rules = tuple(tuple(rule) if isinstance(rule, (tuple, list)) else rule for rule in self.rules)
        if not rules:
            raise FuzzySpecError("rules: at least one rule is needed")
        for index, rule in enumerate(rules):
            if not (isinstance(rule, tuple) and len(rule) == 2 and all(isinstance(n, str) for n in rule)):
                raise FuzzySpecError(f"rule {index} {rule!r}: expected a pair (input set name, output set name)")
            source, target = rule
            text = f"{source}{RULE_ARROW}{target}"
            if source not in input_names:
                raise FuzzySpecError(
                    f"rule {index} {text!r}: unknown input set {source!r} (input sets: {', '.join(input_names)})"
                )
            if target not in output_names:
                raise FuzzySpecError(
                    f"rule {index} {text!r}: unknown output set {target!r} (output sets: {', '.join(output_names)})"
                )
            if rule in rules[:index]:
                raise FuzzySpecError(f"rule {index} {text!r}: duplicate of an earlier rule")
        resolution = self.resolution
        if isinstance(resolution, bool) or not isinstance(resolution, numbers.Integral) or resolution < 3:
            raise FuzzySpecError(f"resolution: expected an integer >= 3, got {resolution!r}")
        object.__setattr__(self, "input_range", input_range)
        object.__setattr__(self, "output_range", output_range)
        object.__setattr__(self, "input_sets", input_sets)
        object.__setattr__(self, "output_sets", output_sets)
        object.__setattr__(self, "rules", rules)
        object.__setattr__(self, "resolution", int(resolution))

    @classmethod
    def from_flat(
        cls,
        input_range: float,
        output_range: float,
        input_set_names: Sequence[str],
        input_set_points: Sequence[float],
        output_set_names: Sequence[str],
        output_set_points: Sequence[float],
        rules: Sequence[str],
        resolution: int = 2001,
    ) -> FuzzyHeadingSpec:
        """Build a spec from flat lists as ROS 2 parameters hold them.

        ``*_set_points`` holds 4 numbers (a, b, c, d) per set, concatenated in the order of ``*_set_names``;
        ``rules`` holds strings ``"input_set->output_set"`` (spaces around the names are ignored).
        """
        input_sets = cls._sets_from_flat("input", input_set_names, input_set_points)
        output_sets = cls._sets_from_flat("output", output_set_names, output_set_points)
        if isinstance(rules, str) or not isinstance(rules, Iterable):
            raise FuzzySpecError(f"rules: expected a list of strings 'input->output', got {rules!r}")
        parsed: list[tuple[str, str]] = []
        for index, rule in enumerate(rules):
            parts = rule.split(RULE_ARROW) if isinstance(rule, str) else []
            if len(parts) != 2 or not all(part.strip() for part in parts):
                raise FuzzySpecError(f"rule {index} {rule!r}: expected 'input_set{RULE_ARROW}output_set'")
            parsed.append((parts[0].strip(), parts[1].strip()))
        return cls(
            input_range=input_range,
            output_range=output_range,
            input_sets=input_sets,
            output_sets=output_sets,
            rules=tuple(parsed),
            resolution=resolution,
        )

    @staticmethod
    def _sets_from_flat(kind: str, names: Sequence[str], points: Sequence[float]) -> tuple[FuzzySet, ...]:
        if isinstance(names, str) or not isinstance(names, Iterable):
            raise FuzzySpecError(f"{kind}_set_names: expected a list of names, got {names!r}")
        if isinstance(points, str) or not isinstance(points, Iterable):
            raise FuzzySpecError(f"{kind}_set_points: expected a list of numbers, got {points!r}")
        names = list(names)
        points = list(points)
        if len(points) != 4 * len(names):
            raise FuzzySpecError(
                f"{kind}_set_points: expected 4 numbers per set ({len(names)} sets in {kind}_set_names -> "
                f"{4 * len(names)}), got {len(points)}"
            )
        sets = []
        for index, name in enumerate(names):
            corners = points[4 * index : 4 * index + 4]
            label = f"{kind} set {name!r}" if isinstance(name, str) else f"{kind}_set_names[{index}]"
            if not isinstance(name, str):
                raise FuzzySpecError(f"{label}: expected a string, got {name!r}")
            try:
                sets.append(FuzzySet(name, tuple(corners)))  # type: ignore[arg-type]
            except FuzzySpecError as error:
                # Re-raised with the kind so "input set 'neg'" and "output set 'zero'" are told apart.
                raise FuzzySpecError(str(error).replace("fuzzy set", f"{kind} set", 1)) from None
        return tuple(sets)

    def to_flat(self) -> dict[str, Any]:
        """The keyword arguments of :meth:`from_flat` (and the ROS 2 parameters) that rebuild this spec."""
        return {
            "input_range": self.input_range,
            "output_range": self.output_range,
            "input_set_names": [s.name for s in self.input_sets],
            "input_set_points": [p for s in self.input_sets for p in s.points],
            "output_set_names": [s.name for s in self.output_sets],
            "output_set_points": [p for s in self.output_sets for p in s.points],
            "rules": [f"{source}{RULE_ARROW}{target}" for source, target in self.rules],
            "resolution": self.resolution,
        }


def paper_spec() -> FuzzyHeadingSpec:
    """The three rules of paper 001: Neg -> CCW, Zero -> Zero, Pos -> CW.

    Sign convention: ``delta_phi = phi1 - phi2`` with antenna 1 on the robot's left. A tag on the left is closer
    to antenna 1, so ``delta_phi < 0`` and the robot must turn left (CCW, ``delta_theta > 0``).

    The numbers are ours, since Fig. 5's numbers are not in the text (the paper only says that the sets are
    triangles and trapezoids tuned empirically):

    * input universe [-pi, pi] (a wrapped phase difference): Neg = (-pi, -pi, -pi/2, 0) (left shoulder),
      Zero = (-pi/2, 0, 0, pi/2) (triangle), Pos = (0, pi/2, pi, pi) (right shoulder);
    * output universe [-0.3, 0.3] rad per control step: CW = (-0.3, -0.3, -0.15, 0) (shoulder),
      Zero = (-0.15, 0, 0, 0.15) (triangle), CCW = (0, 0.15, 0.3, 0.3) (shoulder).

    With only Neg (or Pos) firing fully, the output is +-0.183 rad (about 10.5 degrees) per step; near
    ``delta_phi = 0`` the output tends smoothly to 0. Parameter files override all of it.
    """
    pi = math.pi
    return FuzzyHeadingSpec(
        input_range=pi,
        output_range=0.3,
        input_sets=(
            FuzzySet("neg", (-pi, -pi, -pi / 2.0, 0.0)),
            FuzzySet("zero", (-pi / 2.0, 0.0, 0.0, pi / 2.0)),
            FuzzySet("pos", (0.0, pi / 2.0, pi, pi)),
        ),
        output_sets=(
            FuzzySet("cw", (-0.3, -0.3, -0.15, 0.0)),
            FuzzySet("zero", (-0.15, 0.0, 0.0, 0.15)),
            FuzzySet("ccw", (0.0, 0.15, 0.3, 0.3)),
        ),
        rules=(("neg", "ccw"), ("zero", "zero"), ("pos", "cw")),
    )


def _reference_simulation(spec: FuzzyHeadingSpec) -> Any:
    # Imported here: skfuzzy pulls in scipy and networkx, which the runtime path never needs.
    import skfuzzy
    from skfuzzy import control

    antecedent = control.Antecedent(np.linspace(-spec.input_range, spec.input_range, spec.resolution), INPUT_LABEL)
    consequent = control.Consequent(
        np.linspace(-spec.output_range, spec.output_range, spec.resolution), OUTPUT_LABEL, defuzzify_method="centroid"
    )
    for fuzzy_set in spec.input_sets:
        antecedent[fuzzy_set.name] = skfuzzy.trapmf(antecedent.universe, list(fuzzy_set.points))
    for fuzzy_set in spec.output_sets:
        consequent[fuzzy_set.name] = skfuzzy.trapmf(consequent.universe, list(fuzzy_set.points))
    rules = [control.Rule(antecedent[source], consequent[target]) for source, target in spec.rules]
    # cache=False: with the cache on, a repeated input whose defuzzification failed (no rule fired) would
    # silently return the previous output, since a cache hit does not clear the output dictionary.
    return control.ControlSystemSimulation(control.ControlSystem(rules), cache=False)


def reference_controller(spec: FuzzyHeadingSpec) -> Callable[[float], float]:
    """The controller built with scikit-fuzzy: THE reference for :class:`FuzzyHeadingController`.

    Both universes are ``np.linspace`` grids of ``spec.resolution`` points, the sets are ``skfuzzy.trapmf``
    sampled on them, and ``skfuzzy.control`` does min implication, max aggregation and centroid
    defuzzification. Inputs are clipped to the input universe first. Where no rule fires skfuzzy has no
    centroid (its lenient simulation leaves the output out); this wrapper returns 0.0 there, as the fast path
    does. Several milliseconds per call: for tests and benchmarks, not for control loops.
    """
    simulation = _reference_simulation(spec)
    low, high = -spec.input_range, spec.input_range

    def evaluate(delta_phi: float) -> float:
        simulation.input[INPUT_LABEL] = min(max(float(delta_phi), low), high)
        simulation.compute()
        return float(simulation.output.get(OUTPUT_LABEL, 0.0))

    return evaluate


class FuzzyHeadingController:
    """Fast runtime path of the fuzzy heading controller: exact centroid, tabulated, linearly interpolated.

    **Exact part** (:meth:`evaluate_exact`, vectorised numpy). For an input x the rule firing strengths are the
    input memberships; each output set's cut is the max over its rules. The aggregated output membership
    ``E(y) = max_o min(cut_o, mu_o(y))`` is piecewise linear, and every kink is one of: a corner of an output
    set, a point where an output set's ramp reaches any set's cut (``a + cut*(b - a)``, ``d - cut*(d - c)``), or a
    crossing of two ramp lines (fixed, precomputed). Between consecutive candidates E is linear, so area and
    first moment are integrated exactly from E at the quarter points of each piece (never at a kink, so
    vertical edges are handled too). The centroid is moment / area: the continuous-universe Mamdani result that
    scikit-fuzzy approximates on its sampled universe.

    **Table** (``__call__``, :meth:`evaluate_many`). Between consecutive corners of the input sets every firing
    strength is affine in x, so the output is a smooth function there and either no rule fires on the whole
    open interval or some rule fires on all of it. Each such interval is tabulated on a uniform sub-grid, its
    end values taken as the one-sided limits, so the only discontinuities (edges of regions where no rule fires,
    vertical set edges) sit exactly on table nodes; nodes themselves store the exact value. The sub-grid is
    refined until linear interpolation matches :meth:`evaluate_exact` at every cell midpoint within
    ``tolerance`` rad (default 1e-6, far below any heading a robot can act on; the measured figure is
    :attr:`table_error`; a few thousand cells, built in well under a second). A scalar call is a clip, one
    ``bisect`` on a Python list and one multiply-add: about a microsecond.

    Against the scikit-fuzzy reference the difference is dominated by the reference's own sampling: it
    samples the sets on ``spec.resolution`` points and interpolates, which rounds corners lying between grid
    points (a few 1e-4 rad for 1-rad ramps at the default resolution) and smears a jump of the output (the edge
    of a region where no rule fires, a vertical set edge) over one grid cell, where the two may differ by the
    size of the jump.

    Inputs outside the input universe are clipped to it. Where no rule fires (all firing strengths 0) the
    output is 0.0: no evidence, no turn. A NaN input raises :class:`ControlError`.
    """

    def __init__(self, spec: FuzzyHeadingSpec, tolerance: float = 1e-6, max_cells: int = 1 << 16) -> None:
        if not isinstance(spec, FuzzyHeadingSpec):
            raise ControlError(f"FuzzyHeadingController: expected a FuzzyHeadingSpec, got {spec!r}")
        if not (tolerance > 0.0 and max_cells >= 1):
            raise ControlError(f"FuzzyHeadingController: need tolerance > 0 and max_cells >= 1, got "
                               f"{tolerance!r} and {max_cells!r}")
        self.spec = spec
        self._low = -spec.input_range
        self._high = spec.input_range
        input_index = {s.name: i for i, s in enumerate(spec.input_sets)}
        output_index = {s.name: i for i, s in enumerate(spec.output_sets)}
        self._input_points = np.array([s.points for s in spec.input_sets], dtype=float)
        self._output_points = np.array([s.points for s in spec.output_sets], dtype=float)
        self._rule_pairs = [(input_index[source], output_index[target]) for source, target in spec.rules]
        self._fixed_candidates = self._ramp_crossings_and_corners()
        self.table_error = math.inf
        self._build_table(tolerance, max_cells)

    # -- exact path -------------------------------------------------------------------------------------------

    def _ramp_crossings_and_corners(self) -> np.ndarray:
        limit = self.spec.output_range
        lines = []  # (slope, intercept) of every sloped ramp of the output sets
        for a, b, c, d in self._output_points:
            if b > a:
                lines.append((1.0 / (b - a), -a / (b - a)))
            if d > c:
                lines.append((-1.0 / (d - c), d / (d - c)))
        crossings = []
        for i, (slope_i, intercept_i) in enumerate(lines):
            for slope_j, intercept_j in lines[i + 1 :]:
                if slope_i != slope_j:
                    x = (intercept_j - intercept_i) / (slope_i - slope_j)
                    if -limit < x < limit:
                        crossings.append(x)
        return np.unique(np.concatenate([[-limit, limit], self._output_points.ravel(), crossings]))

    def _cuts(self, x: np.ndarray) -> np.ndarray:
        firing = _trapezoid_many(x, self._input_points)
        cuts = np.zeros((x.size, len(self._output_points)))
        for source, target in self._rule_pairs:
            np.maximum(cuts[:, target], firing[:, source], out=cuts[:, target])
        return cuts

    def _centroid_of_cuts(self, cuts: np.ndarray) -> np.ndarray:
        points = self._output_points
        a, b, c, d = (points[:, i] for i in range(4))
        n = cuts.shape[0]
        # Where each set's ramps reach each cut level: (n, sets * levels) per side.
        rising = (a[None, :, None] + cuts[:, None, :] * (b - a)[None, :, None]).reshape(n, -1)
        falling = (d[None, :, None] - cuts[:, None, :] * (d - c)[None, :, None]).reshape(n, -1)
        fixed = np.broadcast_to(self._fixed_candidates, (n, self._fixed_candidates.size))
        knots = np.sort(np.concatenate([fixed, rising, falling], axis=1), axis=1)
        left, right = knots[:, :-1], knots[:, 1:]
        width = right - left
        quarter = left + 0.25 * width
        three_quarters = left + 0.75 * width

        def envelope(y: np.ndarray) -> np.ndarray:
            memberships = _trapezoid_many(y.ravel(), points).reshape(y.shape + (len(points),))
            return np.max(np.minimum(memberships, cuts[:, None, :]), axis=2)

        low_value = envelope(quarter)
        high_value = envelope(three_quarters)
        area_pieces = 0.5 * width * (low_value + high_value)
        area = area_pieces.sum(axis=1)
        moment = (0.5 * (left + right) * area_pieces + (high_value - low_value) * width * width / 6.0).sum(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(area > 0.0, moment / np.where(area > 0.0, area, 1.0), 0.0)

    def evaluate_exact(self, delta_phi: np.ndarray | Sequence[float] | float, chunk: int = 512) -> np.ndarray:
        """The exact continuous-universe Mamdani output for each input (clipped to the universe); slow path."""
        x = self._clipped(delta_phi)
        flat = x.ravel()
        out = np.empty_like(flat)
        for start in range(0, flat.size, chunk):
            piece = flat[start : start + chunk]
            out[start : start + chunk] = self._centroid_of_cuts(self._cuts(piece))
        return out.reshape(x.shape)

    # -- table --------------------------------------------------------------------------------------------------

    def _build_table(self, tolerance: float, max_cells: int) -> None:
        corners = np.unique(np.clip(np.concatenate([self._input_points.ravel(), [self._low, self._high]]),
                                    self._low, self._high))
        exact_at_corners = self.evaluate_exact(corners)
        step = (self._high - self._low) / 512.0
        while True:
            nodes, starts, slopes, node_values = self._tabulate(corners, exact_at_corners, step)
            midpoints = 0.5 * (nodes[:-1] + nodes[1:])
            interpolated = starts + (midpoints - nodes[:-1]) * slopes
            error = float(np.max(np.abs(interpolated - self.evaluate_exact(midpoints))))
            if error <= tolerance or len(starts) >= max_cells:
                break
            # Interpolation error of a smooth function shrinks with the square of the step: aim just below
            # the tolerance in one go instead of halving repeatedly (building is the slow, exact part).
            shrink = min(0.7, max(1.0 / 16.0, 0.9 * math.sqrt(tolerance / error)))
            step = max(step * shrink, (self._high - self._low) / max_cells)
        self.table_error = error
        # Python lists: bisect and float arithmetic on them beat numpy scalars by an order of magnitude.
        self._nodes = nodes.tolist()
        self._starts = starts.tolist()
        self._slopes = slopes.tolist()
        self._node_values = node_values.tolist()
        self._nodes_array = nodes
        self._starts_array = starts
        self._slopes_array = slopes
        self._node_values_array = node_values

    def _tabulate(
        self, corners: np.ndarray, exact_at_corners: np.ndarray, step: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        grids = []
        for left, right in zip(corners[:-1], corners[1:]):
            cells = max(1, math.ceil((right - left) / step))
            grid = np.linspace(left, right, cells + 1)
            # One-sided limits at the interval's ends: the output may jump at a corner (a no-rule region
            # starts, a vertical edge), but inside the open interval it is smooth.
            nudge = 1e-9 * (right - left)
            samples = grid.copy()
            samples[0] += nudge
            samples[-1] -= nudge
            grids.append((grid, samples))
        all_samples = np.concatenate([samples for _, samples in grids])
        values = self.evaluate_exact(all_samples)
        nodes, starts, slopes, node_values = [], [], [], []
        offset = 0
        for index, (grid, _) in enumerate(grids):
            sampled = values[offset : offset + grid.size]
            offset += grid.size
            nodes.append(grid[:-1])
            starts.append(sampled[:-1])
            slopes.append(np.diff(sampled) / np.diff(grid))
            inner = sampled[:-1].copy()
            inner[0] = exact_at_corners[index]
            node_values.append(inner)
        nodes.append(corners[-1:])
        node_values.append(exact_at_corners[-1:])
        return (np.concatenate(nodes), np.concatenate(starts), np.concatenate(slopes), np.concatenate(node_values))

    # -- runtime ------------------------------------------------------------------------------------------------

    def _clipped(self, delta_phi: np.ndarray | Sequence[float] | float) -> np.ndarray:
        x = np.asarray(delta_phi, dtype=float)
        if np.isnan(x).any():
            raise ControlError(f"{INPUT_LABEL}: NaN input to the fuzzy heading controller")
        return np.clip(x, self._low, self._high)

    def __call__(self, delta_phi: float) -> float:
        """Heading change (rad, CCW positive) for the phase difference ``delta_phi`` (rad)."""
        x = float(delta_phi)
        if x >= self._high:
            x = self._high
        elif x <= self._low:
            x = self._low
        elif x != x:
            raise ControlError(f"{INPUT_LABEL}: NaN input to the fuzzy heading controller")
        index = bisect.bisect_right(self._nodes, x) - 1
        node = self._nodes[index]
        if x == node:
            return self._node_values[index]
        return self._starts[index] + (x - node) * self._slopes[index]

    def evaluate_many(self, delta_phi: np.ndarray | Sequence[float]) -> np.ndarray:
        """Vectorised :meth:`__call__`: same shape out as in."""
        x = self._clipped(delta_phi)
        nodes = self._nodes_array
        node_index = np.searchsorted(nodes, x, side="right") - 1
        cell = np.minimum(node_index, self._starts_array.size - 1)
        interpolated = self._starts_array[cell] + (x - nodes[cell]) * self._slopes_array[cell]
        return np.where(x == nodes[node_index], self._node_values_array[node_index], interpolated)

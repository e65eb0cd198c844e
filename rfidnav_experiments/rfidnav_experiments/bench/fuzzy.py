"""``./rfidnav bench flc``: the fuzzy heading controller's fast path against scikit-fuzzy, per evaluation."""

from __future__ import annotations

import math
import time

import numpy as np

from rfidnav_control.errors import ControlError
from rfidnav_control.fuzzy import FuzzyHeadingController, FuzzyHeadingSpec, paper_spec, reference_controller


def benchmark(spec: FuzzyHeadingSpec | None = None, evaluations: int = 2000, seed: int = 0) -> dict[str, float]:
    """Mean microseconds per scalar evaluation: scikit-fuzzy (:func:`reference_controller`) versus
    :class:`FuzzyHeadingController`.

    Both run over the same seeded uniform inputs on the input universe, each controller built beforehand; the
    fast loop repeats the inputs until at least 100,000 calls so that timer resolution does not matter.
    """
    spec = spec if spec is not None else paper_spec()
    if evaluations < 1:
        raise ControlError(f"benchmark: evaluations must be >= 1, got {evaluations}")
    inputs = np.random.default_rng(seed).uniform(-spec.input_range, spec.input_range, evaluations).tolist()

    reference = reference_controller(spec)
    start = time.perf_counter()
    for x in inputs:
        reference(x)
    reference_us = (time.perf_counter() - start) / evaluations * 1e6

    controller = FuzzyHeadingController(spec)
    repeats = max(1, math.ceil(100_000 / evaluations))
    start = time.perf_counter()
    for _ in range(repeats):
        for x in inputs:
            controller(x)
    fast_us = (time.perf_counter() - start) / (repeats * evaluations) * 1e6

    return {"reference_us": reference_us, "fast_us": fast_us, "speedup": reference_us / fast_us}

"""The fused filter's extension point (pure): each kind of evidence is one class implementing :class:`Measurement`,
and a round's :class:`Evidence` holds each kind's reading under that kind's name.

The filter (rfidnav_localization.fused.filter) knows no kind of evidence. It is built with a sequence of measurement
factories (rfidnav_localization.fused.kinds.MEASUREMENTS unless told otherwise: the shipped kinds, in order), each
called with the filter's settings and map; a measurement class whose ``__init__`` takes those two is its own
factory. Each round, for each measurement in that order whose reading the round holds, the filter adds the
log-likelihoods it returns (one array per kind of likelihood it reports: Update.used and
LocalizationStatus.evidence_used name them in that order). When particles are redrawn (sensor resetting), their
headings come from the first measurement that gives headings, their poses from the first by ``proposal_rank`` whose
reading allows some.

Adding a kind of evidence is one class (subclass Measurement to inherit its defaults for the hooks it does not
need) and its factory in MEASUREMENTS (or in the ``measurements`` a filter is built with).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol, TypeVar

import numpy as np

from rfidnav_localization.fused.settings import FusedSettings
from rfidnav_localization.fused.tag_map import FusedMap

Reading = TypeVar("Reading", contravariant=True)


class Evidence(Mapping[str, Any]):
    """What one round of the sensors says: each kind's reading under its name (:attr:`Measurement.name`), e.g.
    ``Evidence(floor_tag_ids=["G1-00"], compass_yaw_rad=0.3)``. A kind absent, or given None, has no reading this
    round and costs nothing."""

    def __init__(self, **readings: Any) -> None:
        self._readings = {name: reading for name, reading in readings.items() if reading is not None}

    def __getitem__(self, name: str) -> Any:
        return self._readings[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._readings)

    def __len__(self) -> int:
        return len(self._readings)

    def __repr__(self) -> str:
        return f"Evidence({', '.join(f'{name}={reading!r}' for name, reading in self._readings.items())})"

    def without(self, names: Collection[str]) -> Evidence:
        """This evidence with the readings of ``names`` left out."""
        return Evidence(**{name: reading for name, reading in self._readings.items() if name not in names})


@dataclass(frozen=True)
class Particles:
    """What a measurement sees of the filter's particles."""
    states: np.ndarray        # 3 x n: x, y, yaw of the robot's centre in the map frame
    weights: np.ndarray       # n, summing to 1: before this round's evidence when it is weighed
    biases: np.ndarray        # n: each particle's compass bias [rad]


@dataclass
class Likelihoods:
    """What a measurement makes of its reading: per kind of likelihood it reports, the log-likelihood per particle
    (0 at best agreement); the ids of tags the map does not know, ignored."""
    by_kind: dict[str, np.ndarray] = field(default_factory=dict)
    ignored: list[str] = field(default_factory=list)

    def add(self, kind: str, values: np.ndarray) -> None:
        """One reading's log-likelihoods, summed with the kind's others this round (independent readings)."""
        self.by_kind[kind] = self.by_kind[kind] + values if kind in self.by_kind else values


class Measurement(Protocol[Reading]):
    """One kind of evidence: the reading it takes of a round, its log-likelihood per particle, and what sensor
    resetting takes of it. Every model scores 0 at best agreement (rfidnav_localization.fused.models), so that the
    weight-averaged likelihood of a round says how well the particles explain it (1: perfectly)."""

    name: str                                       # the key of its reading in a round's Evidence
    kinds: tuple[str, ...]                          # the likelihoods it reports, in the order they are reported
    # Of its kinds, those whose readings can place the robot, and how much of the running average of how well the
    # particles explain them a round replaces: when that falls below FusedSettings.reset_threshold, particles are
    # redrawn (1: at once, a tag read no particle explains; less: over several rounds, for noisy fixes).
    reset_memory: Mapping[str, float] = {}
    # Its place among the kinds proposing poses for redrawn particles (the lowest rank with a reading proposes them);
    # None: it proposes none.
    proposal_rank: int | None = None

    def log_likelihoods(self, reading: Reading, particles: Particles) -> Likelihoods:
        """Its log-likelihoods of this round's reading, per particle (none: the reading says nothing)."""
        ...

    def headings(self, reading: Reading, biases: np.ndarray, rng: np.random.Generator) -> np.ndarray | None:
        """Headings for redrawn particles of these compass ``biases``, or None: the reading says none."""
        return None

    def poses(self, reading: Reading, yaw: np.ndarray, rng: np.random.Generator) -> np.ndarray | None:
        """Poses (3 x len(yaw)) the reading allows for redrawn particles headed ``yaw``, or None: it allows none."""
        return None

    def moved(self, distance_m: float) -> None:
        """The robot moved ``distance_m`` by the odometry."""

    def end_round(self, reading: Reading | None, particles: Particles) -> None:
        """After each update (resampled or not), with this round's reading (None: none) and the particles."""

    def restart(self) -> None:
        """The filter restarts (global localization or a given pose): forget what earlier rounds left."""


# A measurement made for one filter of its settings and map (a measurement class taking those two is one).
MeasurementFactory = Callable[[FusedSettings, FusedMap], Measurement[Any]]

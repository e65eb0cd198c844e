"""What every reproduction shares: figures saved alike, plain-text tables, means of maybe nothing, 95 % intervals
(paired where two methods ran on the same seeds), and the conditions table: every physical setting of a reproduction
with where it comes from. The runs themselves go through :mod:`rfidnav_experiments.engine`."""

from __future__ import annotations

import math
import statistics
from collections.abc import Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, TypeVar

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from scipy import stats  # noqa: E402

from rfidnav_scenario.scenario import CONFIG_DIR  # noqa: E402

Key = TypeVar("Key", bound=Hashable)   # what pairs two methods' values: a seed, a placement, a mission


def save(figure: plt.Figure, path: Path, dpi: int) -> Path:
    """Lay out, write and close a reproduction's figure."""
    figure.tight_layout()
    figure.savefig(path, dpi=dpi)
    plt.close(figure)
    return path


def mean_or_none(values: list[float]) -> float | None:
    return statistics.fmean(values) if values else None


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    widths = [max(len(cell) for cell in column) for column in zip(header, *rows)]
    line = lambda cells: "  ".join(cell.ljust(width) for cell, width in zip(cells, widths)).rstrip()  # noqa: E731
    return [line(header), line(["-" * width for width in widths]), *(line(row) for row in rows)]


@dataclass(frozen=True)
class Interval:
    """A mean with its 95 % t-interval over ``n`` values (no interval below two)."""
    mean: float | None
    half_width: float | None
    n: int
    bounds: tuple[float, float] | None = None     # an asymmetric interval (a proportion's)

    @classmethod
    def of(cls, values: Sequence[float]) -> Interval:
        if not values:
            return cls(None, None, 0)
        if len(values) < 2:
            return cls(values[0], None, 1)
        half = float(stats.t.ppf(0.975, len(values) - 1)) * statistics.stdev(values) / math.sqrt(len(values))
        return cls(statistics.fmean(values), half, len(values))

    @classmethod
    def of_proportion(cls, successes: int, runs: int) -> Interval:
        """A success rate in percent with its 95 % Wilson interval (a t-interval is wrong near 0 and 100 %,
        and the interval is not symmetric there: ``bounds`` holds it, ``half_width`` its larger side)."""
        if runs == 0:
            return cls(None, None, 0)
        p, z = successes / runs, float(stats.norm.ppf(0.975))
        centre = (p + z * z / (2 * runs)) / (1 + z * z / runs)
        spread = z * math.sqrt(p * (1 - p) / runs + z * z / (4 * runs * runs)) / (1 + z * z / runs)
        low, high = 100.0 * max(0.0, centre - spread), 100.0 * min(1.0, centre + spread)
        return cls(100.0 * p, max(100.0 * p - low, high - 100.0 * p), runs, (low, high))

    def text(self, scale: float = 100.0, digits: int = 2) -> str:
        if self.mean is None:
            return "no success"
        if self.bounds is not None:
            low, high = self.bounds
            return f"{self.mean * scale:.{digits}f} [{low * scale:.{digits}f}, {high * scale:.{digits}f}] (n={self.n})"
        width = "" if self.half_width is None else f" ± {self.half_width * scale:.{digits}f}"
        return f"{self.mean * scale:.{digits}f}{width} (n={self.n})"


def paired_interval(ours: Mapping[Key, float | None], baseline: Mapping[Key, float | None]) -> Interval:
    """The mean of ``ours - baseline`` over the keys (seeds, placements) where both have a value."""
    differences = []
    for key, value in ours.items():
        theirs = baseline.get(key)
        if value is not None and theirs is not None:
            differences.append(value - theirs)
    return Interval.of(differences)


@dataclass(frozen=True)
class Condition:
    """One physical setting of a reproduction: its value for each compared method and where it comes from."""
    setting: str                        # NODE.field, or world. / scenario. for what the scenario fixes
    values: dict[str, Any]              # by method or parameter set
    source: str                         # paper | calibrated | ours (| "paper, interpreted: ...")
    note: str                           # the paper's section, the fit, or why we chose it
    sources: dict[str, str] | None = None   # by method, where the methods' values come from different places

    def source_text(self) -> str:
        """The source column: one source, or each method's where they differ."""
        if not self.sources:
            return self.source
        return "; ".join(f"{method}: {source}" for method, source in self.sources.items())


CONDITION_SOURCES = ("paper", "calibrated", "ours")
CONFIG_ROOT = CONFIG_DIR.resolve()    # where a scenario's resolved paths point, on this clone
INTERPRETED = "paper, interpreted"   # a reading of the paper's text where it gives no number


def interpreted(reading: str) -> str:
    """The source of a setting the paper implies: the reading follows the label."""
    return f"{INTERPRETED}: {reading}"


def is_condition_source(source: str) -> bool:
    """One of the sources, or the paper interpreted (the reading in the source, or in the row's note)."""
    return source in CONDITION_SOURCES or source == INTERPRETED or source.startswith(INTERPRETED + ": ")


def rowless_fields(settings: Iterable[str], parameters: Mapping[str, type]) -> set[str]:
    """``NODE.field`` of every field of the nodes' parameter classes that has no row among ``settings``."""
    named = set(settings)
    return {f"{node}.{field.name}" for node, cls in parameters.items() for field in fields(cls)} - named


def portable(value: Any) -> Any:
    """A value written alike on every clone: a path into the configuration is written from ``config/``."""
    if isinstance(value, str) and value.startswith(f"{CONFIG_ROOT}/"):
        return "config/" + value.removeprefix(f"{CONFIG_ROOT}/")
    if isinstance(value, dict):
        return {key: portable(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(portable(item) for item in value)
    return value



def condition_lines(rows: Sequence[Condition], methods: Sequence[str]) -> list[str]:
    """The conditions table: one column per method, "same" where a value equals the first method's."""
    def shown(value: Any) -> str:
        text = f"{value:g}" if isinstance(value, float) else str(value)
        return text if len(text) <= 40 else text[:37] + "..."

    body = []
    for row in rows:
        row_values = portable(row.values)
        first = repr(row_values[methods[0]])
        values = [shown(row_values[methods[0]]),
                  *("same" if repr(row_values[method]) == first else shown(row_values[method])
                    for method in methods[1:])]
        body.append([row.setting, *values, row.source_text(), row.note])
    return ["conditions: every physical setting of these runs and where it comes from",
            *table(["setting", *methods, "source", "why / where"], body)]


def condition_json_rows(experiment: str, rows: Sequence[Condition]) -> list[dict[str, Any]]:
    """The conditions as ``--json`` rows (metric "condition"), ahead of the figures."""
    return [{"experiment": experiment,
             "setting": {"condition": row.setting, "source": row.source, "note": row.note,
                         **({"sources": row.sources} if row.sources else {})},
             "metric": "condition", "ours": portable(row.values), "paper": None} for row in rows]

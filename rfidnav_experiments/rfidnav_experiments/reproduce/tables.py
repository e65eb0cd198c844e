"""What every reproduction shares: progress on stderr, figures saved alike, plain-text tables, means of maybe
nothing."""

from __future__ import annotations

import statistics
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def progress(line: str, final: bool) -> None:
    # One overwritten line on a terminal; in a log only the final line, not hundreds.
    if sys.stderr.isatty():
        print(f"\r\033[K{line}", end="\n" if final else "", file=sys.stderr, flush=True)
    elif final:
        print(line, file=sys.stderr, flush=True)


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

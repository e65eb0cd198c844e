"""The soft read model of a downward antenna over floor tags, shared by the partition filter (paper 000) and the
fused localizer: a tag within the read range r (horizontally) is read, one beyond it is not, with a soft edge and
a floor on what one contradicting tag can cost,

    P(read | d) = eps + (1 - 2 eps) * sigmoid((r - d) / softness),   P(not read | d) = 1 - P(read | d).
"""

from __future__ import annotations

import numpy as np


def soft_read_log_likelihood(antennas: np.ndarray, read: np.ndarray, unread: np.ndarray, read_range_m: float,
                             softness_m: float, eps: float) -> np.ndarray:
    """log P(these reads and non-reads | antenna) per antenna position (``antennas``: 2 x count; ``read`` and
    ``unread``: tag positions, k x 2)."""
    tags = np.concatenate((read, unread))
    sign = np.concatenate((np.ones(len(read)), -np.ones(len(unread))))
    # In place, one particles x tags array throughout (the same operations as out of place, to the bit).
    value = antennas[0][:, None] - tags[:, 0]
    dy = antennas[1][:, None] - tags[:, 1]
    value *= value
    dy *= dy
    value += dy
    np.sqrt(value, out=value)                # the distance; not np.hypot: its overflow care costs twice the rest
    np.subtract(read_range_m, value, out=value)
    value /= softness_m
    value *= sign                            # the margin
    # log(eps + (1 - 2 eps) * sigmoid(margin)); tanh keeps the sigmoid from overflowing.
    value *= 0.5
    np.tanh(value, out=value)
    value += 1.0
    value *= (1.0 - 2.0 * eps) * 0.5
    value += eps
    np.log(value, out=value)
    return value.sum(axis=1)

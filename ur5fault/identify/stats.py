"""Estimates with intervals: the record every identification step returns, and the resampling
that gives the interval.

Samples of a log are not independent (a joint's friction residual stays correlated over a motion
segment), so regressions are resampled by whole time blocks (a *block bootstrap*); statistics
computed per event (a start from rest, a rest segment) are resampled by event.  Intervals are the
2.5 and 97.5 percentiles of the resampled estimates (95 %).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

#: time block of the block bootstrap [s]: longer than one motion segment of a pick-and-place
#: (~1 s), short enough to leave ~30 blocks in a one-minute log
BLOCK_S = 2.0
#: resamples of every bootstrap interval (assumption: enough for stable 2.5/97.5 % quantiles at ~30 blocks)
N_BOOT = 200
#: the most resamples a user may ask for (assumption: at 10,000 the Monte-Carlo error of a 2.5 % quantile is
#: ~0.16 % in probability, far below what the ~30 blocks of a log decide; more only costs time without a bound)
MAX_BOOT = 10_000
LEVEL = 0.95


@dataclasses.dataclass(frozen=True)
class Estimate:
    """One identified quantity with its 95 % interval.

    Attributes:
        key: what it is, e.g. ``"friction.coulomb_A"`` (units in the name).
        joint: 0-based joint index, or ``None`` for a robot-wide value.
        value: the estimate.
        lo, hi: bounds of the 95 % resampling interval.
        method: one line saying how it was obtained.
        identifiable: ``False`` when the log does not carry the information; ``value`` is then
            the stated assumption it falls back to, and ``lo``/``hi`` are NaN.
        note: why not identifiable, or a caveat.
    """

    key: str
    joint: int | None
    value: float
    lo: float
    hi: float
    method: str
    identifiable: bool = True
    note: str = ""

    def contains(self, x: float, rel_tol: float = 0.0) -> bool:
        """``x`` lies in ``[lo, hi]`` widened by ``rel_tol * |value|`` on each side."""
        pad = rel_tol * abs(self.value)
        return bool(self.lo - pad <= x <= self.hi + pad)

    def to_json(self) -> dict:
        """As JSON data, the joint by its name (as every output names joints; ``None``: robot-wide)."""
        from ..sim.axes import JOINT_NAMES

        return {**dataclasses.asdict(self), "joint": None if self.joint is None else JOINT_NAMES[self.joint]}


def fallback(key: str, joint: int | None, value: float, method: str, note: str) -> Estimate:
    """An estimate the log cannot give: the stated assumption, no interval."""
    return Estimate(key, joint, float(value), float("nan"), float("nan"), method, False, note)


def interval(boot: NDArray, level: float = LEVEL) -> tuple[NDArray, NDArray]:
    """Percentile interval over the first axis of resampled estimates (NaNs ignored)."""
    a = (1.0 - level) / 2.0
    with warnings.catch_warnings():  # a quantity not fitted on a joint is NaN in every resample
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanquantile(boot, a, axis=0), np.nanquantile(boot, 1.0 - a, axis=0)


def block_indices(n_samples: int, block_len: int) -> list[NDArray]:
    """Consecutive blocks of sample indices (the last block takes the remainder)."""
    n_blocks = max(1, n_samples // block_len)
    edges = np.linspace(0, n_samples, n_blocks + 1).round().astype(int)
    return [np.arange(a, b) for a, b in zip(edges[:-1], edges[1:])]


def bootstrap(stat: Callable[[NDArray], NDArray], groups: Sequence[NDArray], n_boot: int = N_BOOT,
              seed: int = 0) -> NDArray:
    """Resample whole groups (time blocks or events) with replacement and recompute ``stat``.

    Args:
        stat: maps an array of row (or event) indices to a vector of estimates.
        groups: the resampling units, each an array of indices.
        n_boot: number of resamples.
        seed: seed of the resampling stream (results are reproducible).

    Returns:
        ``(n_boot, ...)`` resampled estimates; a resample on which ``stat`` fails
        (singular regression) is NaN.
    """
    rng = np.random.default_rng(seed)
    shape = np.shape(stat(np.concatenate(list(groups))))
    out = np.full((n_boot, *shape), np.nan)
    for b in range(n_boot):
        pick = rng.integers(0, len(groups), len(groups))
        try:
            out[b] = stat(np.concatenate([groups[g] for g in pick]))
        except np.linalg.LinAlgError:
            pass
    return out

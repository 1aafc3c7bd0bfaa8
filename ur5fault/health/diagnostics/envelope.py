"""The operating conditions the saved classifiers were trained over, and a note where a log or another campaign
leaves them.

A robot knows its payload and its joints' temperature, and both are inputs of the classifiers
(:data:`.data.CONTEXT_COLUMNS`).  Gradient-boosted trees hold their last value beyond the largest (or below the
smallest) value they were trained on, so a 4.5 kg payload scored by classifiers trained on 0-3 kg gets the
probability of a 3 kg run: an extrapolation nobody measured.  The schema records each condition's range over the
training runs (``training_ranges``); ``ur5fault diagnose`` and ``ur5fault benchmark --test`` say where they leave
it.  Classifiers saved before the record say nothing.

A value just beyond the training runs' extreme is as covered as one inside: the extremes of sampled conditions are
themselves where the draws happened to fall (a campaign drawing payloads from 0 kg trains on 0.0027 kg at least,
and ``diagnose``'s example at 0 kg was told it lies outside).  Inside the range no value is further than half the
largest gap between neighbouring training values from a trained one, so the schema records each condition's
largest gap (``training_range_gaps``) and a value is said to lie outside only when it is beyond the range by more
than half of it.  The shipped diagnostics campaigns' training runs: payload largest gaps 0.011 / 0.053 / 0.022 kg
(diagnostics / _reduced / _urlog) against smallest payloads of 0.0008 / 0.0038 / 0.0027 kg, temperature gaps
0.12-0.42 degC; computed from the campaigns' drawn conditions and split, not simulated.  Classifiers saved before
this record, or with a gap that is not a finite number >= 0, use no margin.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from .data import CONTEXT_COLUMNS

#: each condition's unit, for the notes
UNITS = {"payload_kg": "kg", "temperature_C": "degC"}


def _training_values(train: pd.DataFrame) -> dict[str, np.ndarray]:
    """``{condition: its distinct finite values over the training runs, sorted}`` for the conditions the table holds
    with at least one."""
    out = {}
    for c in CONTEXT_COLUMNS:
        if c in train:
            v = pd.to_numeric(train[c], errors="coerce").to_numpy(float)
            v = np.unique(v[np.isfinite(v)])
            if v.size:
                out[c] = v
    return out


def training_ranges(train: pd.DataFrame) -> dict[str, list[float]]:
    """``{condition: [smallest, largest]}`` over the training runs, for the conditions the table holds."""
    return {c: [float(v[0]), float(v[-1])] for c, v in _training_values(train).items()}


def training_range_gaps(train: pd.DataFrame) -> dict[str, float]:
    """``{condition: largest gap}`` between neighbouring distinct values over the training runs (0 for a condition
    with one value), for the conditions :func:`training_ranges` records."""
    return {c: float(np.diff(v).max()) if v.size > 1 else 0.0 for c, v in _training_values(train).items()}


def _half_gap(gap: Any) -> float:
    """Half a recorded gap, or 0 for one that is not a finite number >= 0 (a hand-edited schema)."""
    if isinstance(gap, (int, float)) and not isinstance(gap, bool) and math.isfinite(gap) and gap >= 0:
        return gap / 2
    return 0.0


def outside_notes(schema: Mapping[str, Any], values: Mapping[str, Any] | pd.DataFrame, where: str) -> list[str]:
    """One note per condition of ``values`` (a log's value, or another campaign's column) outside the schema's
    ``training_ranges`` by more than half its ``training_range_gaps`` (module docstring; none recorded, or not a
    finite number >= 0: no margin); none where the schema has no record."""
    ranges = schema.get("training_ranges")
    if not isinstance(ranges, Mapping):
        return []
    gaps = schema.get("training_range_gaps")
    gaps = gaps if isinstance(gaps, Mapping) else {}
    notes = []
    for c, rng in ranges.items():
        if c not in values or not isinstance(rng, (list, tuple)) or len(rng) != 2:
            continue
        lo, hi = float(rng[0]), float(rng[1])
        margin = _half_gap(gaps.get(c))
        v = np.atleast_1d(pd.to_numeric(pd.Series(np.ravel(values[c])), errors="coerce").to_numpy(float))
        v = v[np.isfinite(v)]
        out = v[(v < lo - margin) | (v > hi + margin)]
        if not out.size:
            continue
        unit = UNITS.get(c, "")
        seen = (f"{out[0]:.3g} {unit}" if v.size == 1 else
                f"{out.size} of {v.size} runs ({out.min():.3g} to {out.max():.3g} {unit})")
        notes.append(f"{where}: {c} {seen} outside the training runs' {lo:.3g} to {hi:.3g} {unit}: the classifiers "
                     "hold their value at the edge there (trees do not extrapolate), so p(fault) is not a measured "
                     "rate; train on a campaign that covers it")
    return notes

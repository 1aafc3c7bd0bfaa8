"""The baseline of a robot: its fitted model overlay and the residual statistics of healthy runs under it.

:func:`fit_baseline` takes healthy runs of the robot replayed under the overlay (:func:`.observe.observe`) and
keeps, per joint and motion state, the smoothed current residual's median and threshold (:mod:`.events`),
and per library candidate the mean and spread of its estimates over the runs (:mod:`.changes`). It is written
as ``baseline.json`` (:meth:`Baseline.to_json`) with the SHA-256 of the overlay it belongs to, so a later
``ur5fault monitor --baseline-stats`` reuses it only with that same overlay.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...errors import ParameterError
from ...sim.axes import JOINT_NAMES, N_JOINTS
from .changes import estimates, spread
from .events import SMOOTH_S, STATES, deviation_stats, prepare
from .observe import Observed

FORMAT = "ur5fault-monitor-baseline-1"


def overlay_sha256(params: dict, effects: Sequence) -> str:
    """A fingerprint of a model overlay's content (parameter overrides and effects)."""
    data = {"params": params, "effects": [[e.name, e.joint_index, [list(v) for v in e.values]] for e in effects]}
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=float).encode()).hexdigest()


@dataclasses.dataclass(frozen=True)
class Baseline:
    """Residual statistics of healthy runs under one overlay (module docstring). Arrays ``(6, 2)`` per joint and
    state :data:`~.events.STATES`; ``candidates``: ``{label: (mean, variance, n_segments)}`` of the coefficient."""

    overlay_sha256: str
    period_s: float
    segments: tuple[str, ...]
    median_A: NDArray
    threshold_A: NDArray
    deviation_A: NDArray  # (k, 6, 2): the largest deviation on each event segment
    candidates: dict[str, tuple[float, float, int]]

    def to_json(self) -> dict[str, Any]:
        def table(a: NDArray) -> dict:
            return {JOINT_NAMES[j]: {s: None if np.isnan(a[j, i]) else float(a[j, i]) for i, s in enumerate(STATES)}
                    for j in range(N_JOINTS)}

        return {"format": FORMAT, "overlay_sha256": self.overlay_sha256, "period_s": self.period_s,
                "smooth_s": SMOOTH_S, "segments": list(self.segments), "median_A": table(self.median_A),
                "threshold_A": table(self.threshold_A),
                "deviation_A": [table(d) for d in self.deviation_A],
                "candidates": {k: {"mean": m, "variance": v, "n_segments": n}
                               for k, (m, v, n) in self.candidates.items()}}

    @classmethod
    def from_json(cls, data: Any, where: str) -> Baseline:
        """Read a ``baseline.json`` written by :meth:`to_json`; anything else is refused with one line."""
        try:
            if data.get("format") != FORMAT:
                raise ParameterError(f"{where}: not a monitor baseline (format {data.get('format')!r}, expected "
                                     f"{FORMAT!r}); write one with ur5fault monitor --baseline-logs")
            if data["smooth_s"] != SMOOTH_S:
                raise ParameterError(f"{where}: written with a {data['smooth_s']} s smoothing window, this version "
                                     f"uses {SMOOTH_S} s; rebuild it with --baseline-logs")

            def array(t: dict) -> NDArray:
                return np.array([[np.nan if t[j][s] is None else float(t[j][s]) for s in STATES]
                                 for j in JOINT_NAMES])

            return cls(str(data["overlay_sha256"]), float(data["period_s"]), tuple(map(str, data["segments"])),
                       array(data["median_A"]), array(data["threshold_A"]),
                       np.array([array(d) for d in data["deviation_A"]]),
                       {str(k): (float(v["mean"]), float(v["variance"]), int(v["n_segments"]))
                        for k, v in data["candidates"].items()})
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise ParameterError(f"{where}: not a valid monitor baseline ({type(exc).__name__}: {exc})") from None

    @classmethod
    def load(cls, path: str | Path) -> Baseline:
        path = Path(path)
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise ParameterError(f"{path}: no such file") from None
        except (OSError, ValueError) as exc:
            raise ParameterError(f"{path}: cannot be read as JSON ({exc})") from None
        return cls.from_json(data, str(path))


def fit_baseline(healthy: Sequence[Observed], overlay_sha: str) -> Baseline:
    """The baseline from healthy log parts replayed under the overlay."""
    if not healthy:
        raise ParameterError("a baseline needs at least one healthy log")
    period = healthy[0].period_s
    for o in healthy[1:]:
        if abs(o.period_s - period) > 1e-9:
            raise ParameterError(f"{o.name}: sample period {o.period_s:g} s differs from {healthy[0].name}'s "
                                 f"{period:g} s")
    segs = [prepare(o.residual_A, o.moving, o.logged, o.period_s) for o in healthy]
    median, dev, thr = deviation_stats(segs)
    per: dict[str, tuple[list[float], list[float]]] = {}
    for o in healthy:
        for label, est in estimates(o, o.logged[: o.e.shape[0]]).items():
            if np.isfinite(est.se):
                per.setdefault(label, ([], []))[0].append(est.theta)
                per[label][1].append(est.se)
    cands = {k: spread(th, se) for k, (th, se) in per.items()}
    return Baseline(overlay_sha, period, tuple(o.name for o in healthy), median, thr, dev, cands)

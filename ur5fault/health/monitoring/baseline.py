"""The baseline of a robot: its fitted model overlay and the residual statistics of healthy runs under it.

:func:`fit_baseline` takes healthy runs of the robot replayed under the overlay (:func:`.observe.observe`) and
keeps, per channel (current and position residual) and joint, the spread model of the residual's transient and
the tail of its normalised window maxima (:mod:`.events`), per joint the quantum of the measured positions, and
per library candidate the mean and spread of its estimates over time blocks of the
runs (:mod:`.changes`), and for a robot that repeats its task (:mod:`.task`) every baseline run's targets and
current residual (the reference a log that repeats them is judged against) with the spread and tail of the
current's transient against that reference, measured where the baseline runs repeat each other, and per library
candidate the mean and spread of its estimates on the difference of residuals there (:mod:`.paired`). The event
limits are fitted in :mod:`.event_fit`; this module keeps them with the change statistics. It is written
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
from ...logs.measured import same_period
from ...sim.axes import JOINT_NAMES, N_JOINTS
from ...util.checks import is_real
from ...util.io import checksum_path, json_float, verify_checksum
from ...util.results import check_whole
from . import paired
from .changes import BLOCK_S, block_estimates, spreads
from .conditions import CONDITIONS
from .coverage import QUANTITIES, envelope
from .event_fit import fit_events, fit_task, segment, task_residual
from .events import CHANNELS, FEATURES, LEVEL_S, SMOOTH_S, WINDOW_S
from .observe import Observed

#: 10: a fifth motion condition, a joint standing while others move (:mod:`.conditions`); 9: the paired
#: statistics' ``design_effect`` the larger of their autocorrelation's and the runs' as clusters
#: (:func:`.effective.run_design_effect`); 8: the paired statistics on 0.5 s blocks, ``n_blocks`` the effective
#: number of independent ones (a float: their autocorrelation accounted for, :mod:`.effective`) and their
#: ``design_effect``; 7 counted each independent 2 s difference once, 6 twice. ``rest_targets`` (the runs' target
#: at rest) was added within 9: optional, absent in the files written before it (read as not recorded); so were
#: ``samples_sha256`` (the runs' samples, :func:`.verdict.refuse_baseline_runs`)
FORMAT = "ur5fault-monitor-baseline-10"
#: a baseline is fitted on at least this many healthy observations (runs, or parts of logs) with judged samples:
#: the event limits' tail is fitted on each normalised by the spread fitted on the others (leave one out,
#: :func:`.event_fit.fit_channel`); a single one is judged by its own fit, which can leave a spread of 0 where it
#: holds little of a motion (Kufieta No8 alone: wrist_2's constant and moving terms 0), and healthy logs are
#: then called anomalies (events of 0.01 A)
MIN_RUNS = 2
#: the values of a baseline run's recorded target at rest (:attr:`Baseline.rest_targets`; ``None``: not seen)
REST_TARGETS = ("reading", "setpoint", None)
#: why (the end of each refusal's one line)
MIN_RUNS_WHY = ("the event limits' tail is fitted on each normalised by the spread fitted on the others (leave one "
                "out), which one cannot give: judged by its own fit its spread can be 0 where it holds little of a "
                "motion, and healthy logs are called anomalies")


def overlay_sha256(params: dict, effects: Sequence) -> str:
    """A fingerprint of a model overlay's content (parameter overrides and effects)."""
    data = {"params": params, "effects": [[e.name, e.joint_index, [list(v) for v in e.values]] for e in effects]}
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=float).encode()).hexdigest()


@dataclasses.dataclass(frozen=True)
class Baseline:
    """Residual statistics of healthy runs under one overlay (module docstring). ``scale`` ``(2, 6, 4)``: per
    channel (:data:`~.events.CHANNELS`) the transient's spread coefficients on :data:`~.events.FEATURES`;
    ``tail`` ``(2, 6, 3)``: ``(u0, beta, p0)`` of its normalised window maxima; ``quantum_rad`` ``(6,)``: the
    largest position quantum of any baseline run (NaN: the joint never moved); ``candidates``:
    ``{label: (mean, variance, n_blocks)}`` of the coefficient; ``task_target_rad`` / ``task_residual_A``: each
    baseline run's joint targets and current residual ``(m, 6)`` (NaN where the tick was not logged;
    :mod:`.task`); ``task_scale`` ``(k, 6, 4)``, ``task_tail`` ``(k, 6, 3)``: per baseline run, the spread and
    tail of its current's transient against the other runs and its own repeats where they repeat its task (NaN:
    they do not, over :data:`~.event_fit.MIN_TASK_S`; no log is then paired with that run): the spread of *that task*;
    ``slow_rad_s``: the overlay's Stribeck speed, where the slow condition ends (:mod:`.conditions`);
    ``cond_scale`` ``(2, 5, 6, 4)``, ``cond_tail`` ``(2, 5, 6, 3)``: per channel and motion condition
    (:data:`~.conditions.CONDITIONS`) the spread and tail fitted on that condition's samples alone (NaN: under
    :data:`~.conditions.MIN_CONDITION_S` of it on that joint; the samples are then judged by the widest limit);
    ``paired_candidates``: ``{label: (mean, variance, k_eff, DE)}`` of the coefficient fitted to the difference
    of a baseline run's residual and the other runs' and its own repeats' at the same point of the task, per block
    of paired samples, ``k_eff`` the effective number of independent blocks and ``DE`` their design effect
    (:mod:`.paired`; empty: the baseline runs do not repeat each other); ``rest_targets``: per baseline run what
    its target is while the arm stands (:attr:`.observe.Observed.rest_target`: the controller's style, so that a
    log of another controller is told with ``--baseline-stats`` as with ``--baseline-logs``; ``None``: not
    recorded, a ``baseline.json`` written before it was); ``motion_max`` ``(2, 6)``: per joint the runs' largest
    target speed and other joints' speed while it stands [rad/s] (:data:`.coverage.QUANTITIES`; NaN: not
    recorded), ``payloads_kg``: per run its stated payload [kg]
    (what the runs covered, :mod:`.coverage`; ``None``: not recorded, as ``rest_targets``); ``samples_sha256``: per
    run the SHA-256 of its log's samples (:attr:`.observe.Observed.samples_sha256`; ``None``: not recorded)."""

    overlay_sha256: str
    period_s: float
    segments: tuple[str, ...]
    scale: NDArray
    tail: NDArray
    quantum_rad: NDArray
    candidates: dict[str, tuple[float, float, int]]
    task_target_rad: tuple[NDArray, ...]
    task_residual_A: tuple[NDArray, ...]
    task_scale: NDArray
    task_tail: NDArray
    slow_rad_s: float
    cond_scale: NDArray
    cond_tail: NDArray
    paired_candidates: dict[str, tuple[float, float, float, float]] = dataclasses.field(default_factory=dict)
    rest_targets: tuple[str | None, ...] | None = None
    motion_max: NDArray | None = None
    payloads_kg: tuple[float | None, ...] | None = None
    samples_sha256: tuple[str | None, ...] | None = None

    @property
    def task_runs(self) -> list[int]:
        """The baseline runs a log can be paired with: those with task statistics."""
        return [i for i in range(len(self.task_target_rad)) if np.isfinite(self.task_scale[i]).all()]

    @property
    def pairs(self) -> bool:
        """Logs that repeat one of :attr:`task_runs` are judged against it."""
        return bool(self.task_runs)

    def to_json(self) -> dict[str, Any]:
        return {"format": FORMAT, "overlay_sha256": self.overlay_sha256, "period_s": self.period_s,
                "smooth_s": SMOOTH_S, "level_s": LEVEL_S, "block_s": BLOCK_S, "segments": list(self.segments),
                "channels": {c: {"scale": {JOINT_NAMES[j]: dict(zip(FEATURES, map(float, self.scale[i, j])))
                                           for j in range(N_JOINTS)},
                                 "tail": {JOINT_NAMES[j]: dict(zip(("u0", "beta", "p0"), map(float, self.tail[i, j])))
                                          for j in range(N_JOINTS)}} for i, c in enumerate(CHANNELS)},
                "position_quantum_rad": {JOINT_NAMES[j]: None if np.isnan(q) else float(q)
                                         for j, q in enumerate(self.quantum_rad)},
                "candidates": {k: {"mean": m, "variance": v, "n_blocks": n}
                               for k, (m, v, n) in self.candidates.items()},
                "paired_candidates": {k: {"mean": m, "variance": v, "n_blocks": n, "design_effect": de}
                                      for k, (m, v, n, de) in self.paired_candidates.items()},
                "task_runs": [{"target_rad": t.tolist(), "residual_A": _nulls(r),
                               "scale": None if i not in self.task_runs else
                               {JOINT_NAMES[j]: dict(zip(FEATURES, map(float, self.task_scale[i, j])))
                                for j in range(N_JOINTS)},
                               "tail": None if i not in self.task_runs else
                               {JOINT_NAMES[j]: dict(zip(("u0", "beta", "p0"), map(float, self.task_tail[i, j])))
                                for j in range(N_JOINTS)}}
                              for i, (t, r) in enumerate(zip(self.task_target_rad, self.task_residual_A))],
                "slow_rad_s": self.slow_rad_s,
                "conditions": {c: {k: {"scale": {JOINT_NAMES[j]: _stat(FEATURES, self.cond_scale[i, m, j])
                                                 for j in range(N_JOINTS)},
                                       "tail": {JOINT_NAMES[j]: _stat(("u0", "beta", "p0"), self.cond_tail[i, m, j])
                                                for j in range(N_JOINTS)}}
                                   for m, k in enumerate(CONDITIONS)} for i, c in enumerate(CHANNELS)},
                **({} if self.rest_targets is None else {"rest_targets": list(self.rest_targets)}),
                **({} if self.motion_max is None else
                   {"motion_max": {q: {JOINT_NAMES[j]: float(self.motion_max[i, j]) for j in range(N_JOINTS)}
                                   for i, q in enumerate(QUANTITIES)
                                   if np.isfinite(self.motion_max[i]).all()}}),  # not recorded: left out
                **({} if self.payloads_kg is None else {"payloads_kg": list(self.payloads_kg)}),
                **({} if self.samples_sha256 is None else {"samples_sha256": list(self.samples_sha256)})}

    @classmethod
    def from_json(cls, data: Any, where: str) -> Baseline:
        """Read a ``baseline.json`` written by :meth:`to_json`; anything else is refused with one line."""
        if not isinstance(data, dict) or "format" not in data:  # another file (a discrepancy's summary.json)
            raise ParameterError(f"{where}: not a monitor baseline (no format key): give --baseline-stats the "
                                 "baseline.json `ur5fault monitor --baseline-logs` writes")
        try:
            if data.get("format") != FORMAT:
                raise ParameterError(f"{where}: not a monitor baseline of this version (format "
                                     f"{data.get('format')!r}, expected {FORMAT!r}); write one with ur5fault "
                                     f"monitor --baseline-logs")
            for key, value in (("smooth_s", SMOOTH_S), ("level_s", LEVEL_S), ("block_s", BLOCK_S)):
                if data[key] != value:
                    raise ParameterError(f"{where}: written with {key} = {data[key]}, this version uses {value}; "
                                         f"rebuild it with --baseline-logs")
            ch = data["channels"]
            scale = np.array([[[json_float(ch[c]["scale"][j][f]) for f in FEATURES] for j in JOINT_NAMES]
                              for c in CHANNELS])
            tail = np.array([[[json_float(ch[c]["tail"][j][k]) for k in ("u0", "beta", "p0")] for j in JOINT_NAMES]
                             for c in CHANNELS])
            quantum = np.array([json_float(data["position_quantum_rad"][j]) for j in JOINT_NAMES])
            task = data["task_runs"]
            t_scale = np.array([np.full((N_JOINTS, len(FEATURES)), np.nan) if r["scale"] is None else
                                [[json_float(r["scale"][j][f]) for f in FEATURES] for j in JOINT_NAMES] for r in task])
            t_tail = np.array([np.full((N_JOINTS, 3), np.nan) if r["tail"] is None else
                               [[json_float(r["tail"][j][k]) for k in ("u0", "beta", "p0")] for j in JOINT_NAMES]
                               for r in task])
            runs = [(np.array(r["target_rad"], float).reshape(-1, N_JOINTS),
                     np.array(r["residual_A"], float).reshape(-1, N_JOINTS)) for r in task]
            cnd = data["conditions"]
            c_scale = np.array([[[_unstat(FEATURES, cnd[c][k]["scale"][j]) for j in JOINT_NAMES] for k in CONDITIONS]
                                for c in CHANNELS])
            c_tail = np.array([[[_unstat(("u0", "beta", "p0"), cnd[c][k]["tail"][j]) for j in JOINT_NAMES]
                                for k in CONDITIONS] for c in CHANNELS])
            if any(t.shape != r.shape for t, r in runs) or len(runs) != len(data["segments"]):
                raise ValueError("the task runs do not match the segments, or their targets and residuals differ "
                                 "in length")
            styles = data.get("rest_targets")  # absent: written before baseline.json recorded it
            if styles is not None and (len(styles) != len(runs) or any(v not in REST_TARGETS for v in styles)):
                raise ValueError(f"rest_targets {styles!r} is not one of {REST_TARGETS} per segment")
            motion = data.get("motion_max")  # absent: written before baseline.json recorded it, as the payloads
            if motion is not None:  # a quantity added since the file was written is NaN there (not compared)
                if not isinstance(motion, dict) or QUANTITIES[0] not in motion:
                    raise ValueError(f"motion_max does not hold {QUANTITIES[0]}")
                values = [motion[q][j] for q in QUANTITIES if q in motion for j in JOINT_NAMES]
                if not all(is_real(v) and np.isfinite(v) and v >= 0 for v in values):
                    raise ValueError("motion_max holds a value that is no finite number >= 0")
                motion = np.array([[motion[q][j] if q in motion else np.nan for j in JOINT_NAMES]
                                   for q in QUANTITIES], float)
            loads = data.get("payloads_kg")
            if loads is not None and (len(loads) != len(runs) or any(
                    p is not None and not (is_real(p) and np.isfinite(p) and p >= 0)
                    for p in loads)):
                raise ValueError(f"payloads_kg {loads!r} is not a payload [kg] or null per segment")
            shas = data.get("samples_sha256")  # absent: written before baseline.json recorded it
            if shas is not None and (len(shas) != len(runs) or any(
                    v is not None and not (isinstance(v, str) and len(v) == 64) for v in shas)):
                raise ValueError("samples_sha256 is not a SHA-256 or null per segment")
            if len(runs) < MIN_RUNS:  # written by a version that fitted one run
                raise ParameterError(f"{where}: built from {len(runs)} healthy run(s) ({', '.join(data['segments'])});"
                                     f" a baseline needs at least {MIN_RUNS}: {MIN_RUNS_WHY}; rebuild it with "
                                     f"--baseline-logs and at least {MIN_RUNS} runs")
            return cls(str(data["overlay_sha256"]), float(data["period_s"]), tuple(map(str, data["segments"])),
                       scale, tail, quantum,
                       {str(k): (json_float(v["mean"]), json_float(v["variance"]), int(v["n_blocks"]))
                        for k, v in data["candidates"].items()},
                       tuple(t for t, _ in runs), tuple(r for _, r in runs), t_scale, t_tail,
                       float(data["slow_rad_s"]), c_scale, c_tail,
                       {str(k): (json_float(v["mean"]), json_float(v["variance"]), json_float(v["n_blocks"]),
                                 json_float(v["design_effect"])) for k, v in data["paired_candidates"].items()},
                       None if styles is None else tuple(styles), motion,
                       None if loads is None else tuple(None if p is None else float(p) for p in loads),
                       None if shas is None else tuple(shas))
        except ParameterError:
            raise  # already one line saying what to do (ParameterError is a ValueError)
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise ParameterError(f"{where}: not a valid monitor baseline ({type(exc).__name__}: {exc})") from None

    @classmethod
    def load(cls, path: str | Path) -> Baseline:
        path = Path(path)
        check_whole(path, "rebuild it with `ur5fault monitor --baseline-logs ...`")
        why = verify_checksum(path) if checksum_path(path).exists() else None
        if why:  # a changed digit would move an event limit silently
            raise ParameterError(f"{path}: {why}; rebuild it with `ur5fault monitor --baseline-logs ...`")
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError:
            raise ParameterError(f"{path}: no such file") from None
        except (OSError, ValueError) as exc:
            raise ParameterError(f"{path}: cannot be read as JSON ({exc})") from None
        return cls.from_json(data, str(path))


def _stat(keys: Sequence[str], values: NDArray) -> dict | None:
    """One joint's coefficients as ``{key: value}``, ``None`` where they are not fitted (NaN)."""
    return None if not np.isfinite(values).all() else dict(zip(keys, map(float, values)))


def _unstat(keys: Sequence[str], entry: dict | None) -> list[float]:
    return [np.nan] * len(keys) if entry is None else [json_float(entry[k]) for k in keys]


def _nulls(x: NDArray) -> list:
    """``x`` as nested lists, NaN as ``None`` (JSON's null)."""
    return [[None if not np.isfinite(v) else float(v) for v in row] for row in x]


def fit_baseline(healthy: Sequence[Observed], overlay_sha: str) -> Baseline:
    """The baseline from healthy log parts replayed under the overlay: at least :data:`MIN_RUNS` with judged
    samples (a part of a log counts as one)."""
    if not healthy:
        raise ParameterError(f"a baseline needs at least {MIN_RUNS} healthy runs or log parts, got none")
    period = healthy[0].period_s
    for o in healthy[1:]:
        if not same_period(o.period_s, period):
            raise ParameterError(f"{o.name}: sample period {o.period_s:g} s differs from {healthy[0].name}'s "
                                 f"{period:g} s")
    slow = healthy[0].stribeck_speed_rad_s
    if slow is None or any(o.stribeck_speed_rad_s != slow for o in healthy):
        raise ParameterError("the baseline logs were not all replayed under one model (their friction laws' "
                             "Stribeck speeds differ or are unknown)")
    segs = [segment(o, slow) for o in healthy]
    judged = sum(bool(ok.any()) for _, _, ok, _ in segs)
    if judged < MIN_RUNS:
        raise ParameterError(f"a baseline needs at least {MIN_RUNS} healthy runs or log parts (observe(log, part_s="
                             f"...): a part counts) with judged samples, got {judged}: {MIN_RUNS_WHY}")
    if sum(int(ok.sum()) for _, _, ok, _ in segs) * period < 2 * WINDOW_S:
        raise ParameterError("the baseline logs hold too few judged samples (under 0.5 s after each replay's first "
                             "0.25 s) to fit the event limits")
    quantum = np.stack([o.position_quantum_rad for o in healthy])
    quantum = np.where(np.isnan(quantum).all(axis=0), np.nan, np.nanmax(np.nan_to_num(quantum, nan=-np.inf), axis=0))
    scale, tail, c_scale, c_tail = fit_events(segs, period, quantum)
    cands = spreads(block for o in healthy for block in block_estimates(o))
    t_scale, t_tail = fit_task(healthy, segs, period)
    refs = [(o.target_rad, task_residual(o)) for o in healthy]
    paired_cands = paired.baseline_spreads(healthy, refs)
    return Baseline(overlay_sha, period, tuple(o.name for o in healthy), scale, tail, quantum, cands,
                    tuple(o.target_rad for o in healthy), tuple(task_residual(o) for o in healthy), t_scale, t_tail,
                    float(slow), c_scale, c_tail, paired_cands, tuple(o.rest_target for o in healthy),
                    envelope(healthy), tuple(o.payload_kg for o in healthy), tuple(o.samples_sha256 for o in healthy))

"""A robot's own healthy baseline for ``ur5fault diagnose --baseline-logs``: each detector input of a diagnosed
window referred to the robot's healthy distribution instead of the simulated one.

Why: the classifiers learned "healthy" from simulated runs whose twin is the same model as the robot, so their
residuals hold sensor noise only; a real robot's residuals also hold the model's error on that robot (a
current residual at speed of 0.1-3 A against the simulation's 0.02 A, docs/diagnostics.md "Real logs"), and
every window of a healthy real log lies far outside what the classifiers saw.  Healthy logs of the same robot,
replayed through the same twin and windowed the same way, measure that error; per input ``k``::

    x'_k = m_k + (x_k - b_k) * s_k / max(r_k, s_k)

with ``b_k``, ``r_k`` the baseline windows' median and robust spread (1.4826 MAD) and ``m_k``, ``s_k`` the
healthy training runs' (:func:`ur5fault.health.diagnostics.saved.healthy_reference`).  A healthy window of the
robot thus lands where the healthy training runs lie, and a fault moves it from there by its own signature,
divided by how much more the robot's healthy windows vary than the simulated runs do.  The baseline's spread is
floored at the training runs' (the factor is never above 1): a spread from a handful of windows is uncertain
(the MAD of 5-20 normal values scatters by 58-26 % of its size: standard deviation over mean, simulated
with numpy), an underestimate would magnify healthy
scatter into alarms, and a robot that varies less than the simulation gives no reason to magnify a fault beyond
its size in the input's own unit.  Handled explicitly, each named in the diagnosis:

* fewer than :data:`MIN_SPREAD_WINDOWS` baseline values of an input: its spread is not estimated, the input is
  shifted only (factor 1);
* zero spread in the baseline (e.g. a spike count that is always 0): shifted only (factor 1 by the floor);
* zero spread in the healthy training runs (a spike count the simulated healthy runs never show): there is no
  training spread to map a z onto (a factor 0 would set the input to the training median whatever the window
  shows, hiding e.g. a backlash's spikes), so the input is shifted only;
* no baseline value (e.g. an encoder-mismatch input of a log without motor encoders) or no training value:
  left as measured;
* the operating conditions (:data:`~ur5fault.health.diagnostics.data.CONTEXT_COLUMNS`: payload, temperature):
  known for every log, not residuals, left as measured.

A map also carries the robot's own false-alarm threshold (:class:`RobotThreshold`), read off the same windows,
each held out from the map it is scored with (:mod:`.robot_threshold`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...errors import ConfigFileError, ParameterError
from ...sim.axes import JOINT_NAMES
from ...util.robust import robust_spread
from ..diagnostics.data import CONTEXT_COLUMNS
from ..diagnostics.saved import healthy_reference
from .windows import Window, window_inputs

#: the fewest baseline values of an input whose spread is estimated (a choice: the MAD of 5 normal values scatters
#: by 58 % of its size, of 4 by 57 %, of 20 by 26 %; with fewer values a spread says little, and below it the
#: input is shifted only)
MIN_SPREAD_WINDOWS = 5
#: how each input is mapped (:class:`BaselineMap`'s ``rule``)
SCALED, SHIFTED, SHIFTED_FEW, SHIFTED_ZERO, SHIFTED_TRAINING_ZERO, UNMAPPED, CONDITION = (
    "scaled", "shifted", "shifted_few_windows", "shifted_zero_spread", "shifted_training_zero_spread",
    "left_as_measured", "condition")
RULES = {SCALED: "baseline spread above the training runs': z against the baseline, mapped onto the training runs",
         SHIFTED: "baseline spread within the training runs': shifted by the baseline median (factor 1)",
         SHIFTED_FEW: f"fewer than {MIN_SPREAD_WINDOWS} baseline values: spread not estimated, shifted only",
         SHIFTED_ZERO: "zero spread in the baseline: shifted only",
         SHIFTED_TRAINING_ZERO: "the healthy training runs do not vary on this input (a spike count that is always "
                                "0 there): no training spread to map onto, shifted only (a fault keeps its size)",
         UNMAPPED: "no value in the baseline or the training runs: left as measured",
         CONDITION: "an operating condition, known for every log: left as measured"}


@dataclasses.dataclass(frozen=True)
class Reference:
    """The healthy training runs' median and robust spread per input, and where they were read."""

    names: tuple[str, ...]
    median: NDArray
    scale: NDArray
    source: str


def training_reference(detector_dir: str | Path, schema: dict[str, Any]) -> Reference:
    """The detector's healthy training runs' reference: saved in its schema, or (classifiers saved before it was)
    computed from the campaign's ``features.parquet`` beside the benchmark folder, checked against the schema's
    training-set hash.  Neither: refused in one line."""
    names = tuple(c["name"] for c in schema["inputs"])
    ref = schema.get("healthy_training_inputs")
    if ref is not None:
        try:
            med, scale = (np.array([np.nan if v is None else float(v) for v in ref[k]]) for k in ("median", "scale"))
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigFileError(f"{detector_dir}: its healthy_training_inputs are not readable ({exc})") from None
        if med.size != len(names) or scale.size != len(names):
            raise ConfigFileError(f"{detector_dir}: its healthy_training_inputs do not match its inputs")
        return Reference(names, med, scale, "the detector's schema (healthy training runs)")
    from ..diagnostics.data import load_dataset
    from ..diagnostics.saved import MODELS_DIR, training_hash

    folder = Path(detector_dir)
    bench = folder.parent if folder.name == MODELS_DIR else folder
    table = bench.parent / "features.parquet"
    if not table.is_file():
        raise ConfigFileError(f"{detector_dir}: saved without the healthy training runs' spread and no campaign "
                              f"feature table at {table}; run `ur5fault benchmark` on the campaign again")
    ds = load_dataset(table, schema.get("feature_set") or "paper")
    if training_hash(ds) != schema.get("training_set_sha256") or tuple(ds.inputs) != names:
        raise ConfigFileError(f"{table}: not the training set of {detector_dir} (its hash differs); run `ur5fault "
                              "benchmark` on the campaign again")
    ref = healthy_reference(ds.train, names)
    return Reference(names, np.array([np.nan if v is None else v for v in ref["median"]], float),
                     np.array([np.nan if v is None else v for v in ref["scale"]], float),
                     f"the campaign's feature table {table} (healthy training runs)")


@dataclasses.dataclass(frozen=True)
class RobotThreshold:
    """The robot's own threshold on the by-joint score (:mod:`.robot_threshold`), the held-out scores it was read
    from (one per baseline window, in the groups' order), how the windows were grouped, and the rank taken
    (``rank > n``: the largest held-out score); per joint the largest held-out score, and the joint (0-based) whose
    score in the window at the threshold is the threshold. A window's score is its joints' largest, so the joint
    whose healthy windows score highest sets the bar for all: a fault on a joint whose own healthy windows stay far
    below it is flagged only once its score passes that joint's healthy level (said in the report)."""

    score: float
    held_out_scores: NDArray
    groups: tuple[str, ...]
    alpha: float
    rank: int
    held_out_max_by_joint: tuple[float, ...] = ()
    set_by_joint: int | None = None

    @property
    def n(self) -> int:
        return int(self.held_out_scores.size)

    @property
    def false_alarm_bound(self) -> float:
        """The probability that a new healthy window exchangeable with the held-out ones exceeds the threshold:
        at most ``alpha`` where the rank exists, ``1 / (n + 1)`` where the largest score was taken."""
        return self.alpha if self.rank <= self.n else 1.0 / (self.n + 1)

    def summary(self) -> dict[str, Any]:
        return {"score": self.score, "alpha": self.alpha, "n_held_out_windows": self.n, "rank": self.rank,
                "false_alarm_bound": self.false_alarm_bound, "groups": list(self.groups),
                "held_out_scores": [float(v) for v in self.held_out_scores],
                "held_out_max_by_joint": {JOINT_NAMES[j]: v for j, v in enumerate(self.held_out_max_by_joint)},
                "set_by_joint": None if self.set_by_joint is None else JOINT_NAMES[self.set_by_joint],
                "method": "each baseline group scored against a baseline of the other groups only; the "
                          "split-conformal rank ceil((1 - alpha)(n + 1)) of the n held-out scores (the largest "
                          "where it exceeds n)"}


#: ``diagnosis.json``'s ``flag_threshold.from`` where the robot's own threshold is the bar (above the training runs')
ROBOT_THRESHOLD_FROM = "the robot's own healthy baseline windows, held out (baseline.robot_threshold)"


def set_by_sentence(threshold: dict[str, Any], calibrated: bool = True) -> str:
    """Which joint's healthy window the robot's threshold is, and each joint's largest held-out healthy score, from
    :meth:`RobotThreshold.summary` (empty where it does not say); ``calibrated``: whether the detector maps its raw
    score to p(fault) (a detector saved without a calibration does not)."""
    by_joint, joint = threshold.get("held_out_max_by_joint") or {}, threshold.get("set_by_joint")
    if not by_joint or joint is None:
        return ""
    listed = ", ".join(f"{n} {v:.2f}" for n, v in by_joint.items())
    what = ("the detector's score, before calibration to p(fault)" if calibrated else
            "the detector's own score: it was saved without a calibration to p(fault)")
    return (f"the raw-score threshold {threshold['score']:.3f} ({what}) "
            f"is {joint}'s raw score in a held-out healthy window; each joint's largest held-out healthy raw score: "
            f"{listed}; on a joint whose healthy windows stay far below the threshold a fault is flagged only once its "
            "score passes it")


@dataclasses.dataclass(frozen=True)
class BaselineMap:
    """Per input: the robot's healthy median ``robot_median``, spread ``robot_scale`` and number of baseline
    values ``robot_n``, the training reference, and the rule (:data:`RULES`) and factor it is mapped with."""

    logs: tuple[str, ...]
    period_s: float
    n_windows_per_log: tuple[int, ...]
    reference: Reference
    robot_median: NDArray
    robot_scale: NDArray
    robot_n: NDArray
    rule: tuple[str, ...]
    factor: NDArray
    #: :meth:`~ur5fault.logs.measured.MeasuredLog.content_sha256` of each baseline log (empty: not recorded)
    log_sha256: tuple[str, ...] = ()
    #: the robot's own false-alarm threshold read off these windows held out (None: not computed, or too few)
    threshold: RobotThreshold | None = None

    @property
    def n_windows(self) -> int:
        return int(sum(self.n_windows_per_log))

    def apply(self, x: NDArray) -> NDArray:
        """The inputs ``x`` ``(n_windows, n_inputs)`` (in the reference's order) referred to the training runs."""
        x = np.asarray(x, float)
        mapped = self.reference.median + (x - self.robot_median) * self.factor
        keep = np.array([r in (UNMAPPED, CONDITION) for r in self.rule])
        return np.where(keep, x, mapped)

    def summary(self, top: int = 5) -> dict[str, Any]:
        """What ``diagnosis.json`` says of the baseline: its logs and windows, how many inputs each rule took
        (with the names of the not scaled ones), and the inputs whose robot spread is the most times the
        training runs'."""
        names = self.reference.names
        with np.errstate(all="ignore"):
            ratio = self.robot_scale / self.reference.scale
        order = [k for k in np.argsort(-np.nan_to_num(ratio, nan=-1.0, posinf=np.inf)) if self.rule[k] == SCALED][:top]
        by_rule = {r: [n for n, q in zip(names, self.rule) if q == r] for r in RULES}
        return {"logs": list(self.logs), "log_period_s": self.period_s, "n_windows": self.n_windows,
                "n_windows_per_log": list(self.n_windows_per_log),
                "reference": self.reference.source,
                "mapping": "x' = training median + (x - baseline median) * training spread / max(baseline spread, "
                           "training spread); spread = 1.4826 MAD",
                "rules": {r: {"meaning": RULES[r], "n_inputs": len(v), **({"inputs": v} if r != SCALED else {})}
                          for r, v in by_rule.items()},
                # None: not a finite ratio (such inputs are shifted only, never scaled)
                "largest_spread_ratio": [{"input": names[k], "baseline_over_training":
                                          float(ratio[k]) if np.isfinite(ratio[k]) else None} for k in order],
                "robot_threshold": None if self.threshold is None else self.threshold.summary()}


def fit_map(reference: Reference, windows_by_log: Sequence[tuple[str, Sequence[Window]]], period_s: float,
            log_sha256: Sequence[str] = ()) -> BaselineMap:
    """The map from the healthy windows of each baseline log (``(source, windows)``, windowed as the diagnosed
    log is, sampled every ``period_s``).  A baseline without a single window is refused in one line."""
    names = reference.names
    counts = tuple(len(w) for _, w in windows_by_log)
    if not windows_by_log or sum(counts) == 0:
        raise ParameterError("the baseline logs give no whole window: each must be at least one window long")
    x = window_inputs([w for _, ws in windows_by_log for w in ws], names)
    med, scale, n = robust_spread(x)
    rule, factor = [], np.ones(len(names))
    for k, c in enumerate(names):
        if c in CONTEXT_COLUMNS:
            rule.append(CONDITION)
        elif n[k] == 0 or not np.isfinite(reference.median[k]):
            rule.append(UNMAPPED)
        elif n[k] < MIN_SPREAD_WINDOWS:
            rule.append(SHIFTED_FEW)
        elif scale[k] == 0:
            rule.append(SHIFTED_ZERO)
        elif not reference.scale[k] > 0:  # a factor 0 would set the input to the training median whatever it is
            rule.append(SHIFTED_TRAINING_ZERO)
        elif np.isfinite(reference.scale[k]) and scale[k] > reference.scale[k]:
            rule.append(SCALED)
            factor[k] = reference.scale[k] / scale[k]
        else:
            rule.append(SHIFTED)
    return BaselineMap(tuple(s for s, _ in windows_by_log), float(period_s), counts, reference, med, scale, n,
                       tuple(rule), factor, tuple(log_sha256))


__all__ = ["BaselineMap", "MIN_SPREAD_WINDOWS", "Reference", "RobotThreshold", "fit_map",
           "ROBOT_THRESHOLD_FROM", "set_by_sentence", "training_reference"]

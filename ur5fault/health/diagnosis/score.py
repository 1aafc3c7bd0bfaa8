"""Scoring a log's windows with the classifiers ``ur5fault benchmark`` saved: the schema check, the probability
of a fault per window and joint, the likeliest fault kinds with their size estimates, and "cannot tell" where
the window's motion does not exercise a kind.

Probabilities: ``p_fault`` is the probability that the window's robot is faulty - the fault-kind classifier by
joint's largest joint probability of a fault (:func:`ur5fault.health.diagnostics.joint_kind.fault_score`, the
benchmark's "by joint" detector) through the calibration map saved with it
(:mod:`ur5fault.health.diagnostics.calibration`: Platt scaling fitted on out-of-fold scores of the training
runs), or the score itself when the classifiers were saved without one; ``p_fault_score`` is the score itself.
``flagged`` compares the score with its threshold at 5 % false alarms on the training campaign's test split
(the benchmark's operating point, saved in the schema; the map is monotonic, so this is the same as the
calibrated ``p_fault`` against the mapped threshold).  Per joint, ``p_fault_joint`` is that joint's probability
of a fault through the same map (the largest of the six is ``p_fault``; each is a frequency only as far as the
map fitted on the largest carries over).  Kinds: the classifier by joint's probabilities for that joint (each
joint's own evidence), renormalised without ``none`` (the probability of each kind given a fault on that
joint; not calibrated); ``same_signature_as`` names the kinds whose current residual has the same shape (a
current-sensor gain and a torque-constant loss), which only the current-noise ratio at rest tells apart (twin
residuals format 9: a window where the joint never rests cannot tell them apart, whatever the split says); each
joint's ``current_noise_ratio_rest`` is that ratio (about g for a current gain g, 1 for a torque-constant loss;
null where the joint rests for under 100 samples of the window).  The run-level detector is kept as an auxiliary
reading: ``p_fault_run_level`` (its own probability, not calibrated) and ``flagged_run_level`` (against its
threshold at 5 % false alarms).

Size estimates are the twin features' least-squares projections (:mod:`ur5fault.health.twin_features`),
converted to the unit of the campaign's ``fault_size``; the interval is the range of the same estimate on the
window's two halves (an empirical spread, not a confidence interval: NaN where a half has no value). Each size
carries the variance inflation of its signature against the others of its fit; above :data:`MAX_VIF` it is
marked ``confounded`` (it holds only if the other faults of that fit are absent: in a window where wrist 1
turns one way only, a current offset and a Coulomb-friction change look alike).

Detection limits (with the calibration saved with the detector): per joint and kind the smallest size the
window's motion could show (:func:`ur5fault.health.diagnostics.limits.joint_limits`, at
:data:`~ur5fault.health.diagnostics.limits.DEFAULT_Z`), or none with why; a kind the window's own rules above say
it cannot tell gets none with that reason.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pandas as pd

from ...errors import ConfigFileError
from ...sim.axes import N_JOINTS
from ...util.checks import is_real
from ..diagnostics import calibration, joint_kind
from ..diagnostics.data import CONTEXT_COLUMNS, SIM_ONLY_PREFIX
from ..diagnostics.kind_call import MERGED_KINDS, NOISE_RATIO
from ..diagnostics.limits import (
    DEFAULT_Z,
    ESTIMATE_OF,
    FLANK_COLUMN,
    SIZE_UNIT,
    LimitCalibration,
    joint_limits,
    reverses,
    signed_size,
)
from ..diagnostics.saved import SCHEMA_FORMAT
from ..features import FEATURE_UNITS
from ..twin_features import FEATURE_UNITS as TWIN_FEATURE_UNITS
from .windows import Window, window_inputs

#: every input column ``ur5fault diagnose`` computes from a log
COMPUTABLE = frozenset([c for c in FEATURE_UNITS if not c.startswith(SIM_ONLY_PREFIX)]
                       + list(TWIN_FEATURE_UNITS) + list(CONTEXT_COLUMNS))
#: the least share of a window's samples in which a joint must move for Coulomb friction to be judged
#: (assumption: a tenth of the window gives the Coulomb projection a few hundred samples at 1 kHz)
MIN_SHARE_MOVING = 0.1
#: kinds a log without motor encoders (every UR log) cannot show, each with why.  The position loop closes on the
#: link-side resolver and the speed loop on the motor encoder (ur5fault/sim/drive/kernel.py), so what these
#: faults change lies between the motor and the link - the encoder mismatch - while the logged link position and
#: current stay a healthy robot's within their noise.  Measured on the UR-log benchmark (8 ms, no motor encoders,
#: docs/diagnostics.md "What a UR log can show"): detection by joint at chance for all three (AUC 0.42-0.51), the
#: resolver offset's former 0.99 having come from a simulated start that stepped the link by the offset
NEEDS_MOTOR_ENCODERS = {
    "backlash": "a clearance lets the motor turn against the link when the gear torque reverses; the loop holds "
                "the link reading, so the link and the current see only a short transient there (too small for "
                "the features: UR-log benchmark AUC 0.51); the motor encoder sees the jump",
    "resolver_offset": "the position loop holds the offset reading on the setpoint, so the logged link position "
                       "tracks as a healthy robot's; the true link sits off by the offset, which only the motor "
                       "encoder shows; the current changes only by the gravity torque's slope times the offset "
                       "(nothing on the base, whose axis is vertical; UR-log benchmark AUC 0.46)",
    "gear_stiffness": "a softer gear winds up more between motor and link at the same torque; the loop holds the "
                      "link and the current carries the same torque, so only the motor encoder sees the windup "
                      "(UR-log benchmark AUC 0.42)",
}
#: largest variance inflation factor at which a size estimate counts as told apart from the others of its fit
#: (the usual rule of thumb for collinear regressors: above 10 a coefficient's variance is ten times what
#: independent regressors would give, e.g. an offset and a gain in a window whose current hardly varies);
#: above it the size is still given, marked ``confounded``: it holds if the other faults of its fit are absent
MAX_VIF = 10.0
#: how many of the likeliest kinds are written per joint
N_KINDS = 3


def check_schema(schema: dict[str, Any], where: str) -> float:
    """The window length [s] of a saved detector whose schema ``ur5fault diagnose`` can serve; else one line."""
    if schema.get("schema_format") != SCHEMA_FORMAT:
        raise ConfigFileError(f"{where}: schema format {schema.get('schema_format')!r}, this version reads "
                              f"{SCHEMA_FORMAT}; run `ur5fault benchmark` again with this version")
    if schema.get("shuffled_labels"):
        raise ConfigFileError(f"{where}: these classifiers were trained on shuffled labels (a control); "
                              "they diagnose nothing")
    if "detector" not in schema.get("classes", {}):
        raise ConfigFileError(f"{where}: holds no detector")
    window = schema.get("window_s")
    if not is_real(window) or not math.isfinite(window) or window <= 0:
        raise ConfigFileError(f"{where}: the schema does not say the training runs' duration (window_s): saved "
                              "before `ur5fault diagnose` existed; run `ur5fault benchmark` on the campaign again")
    names = [c.get("name") for c in schema.get("inputs", [])]
    odd = [c for c in names if c not in COMPUTABLE]
    if not names or odd:
        raise ConfigFileError(f"{where}: its inputs do not match the features this version computes from a log "
                              f"({', '.join(map(str, odd[:5])) or 'no inputs'}); run `ur5fault benchmark` on the "
                              "campaign again with this version")
    return float(window)


def size_estimate(kind: str, est: dict[str, float], j: int) -> tuple[float, str]:
    """The size of ``kind`` on joint ``j`` (1-based) from the ``twin_est_*`` values in ``est``, in the unit of
    the campaign's ``fault_size`` (signed where the fault has a direction); NaN when there is none."""
    if kind not in ESTIMATE_OF:
        return float("nan"), "-"
    value = est.get(f"twin_est_{ESTIMATE_OF[kind]}_j{j}")
    return float(signed_size(kind, float("nan") if value is None else value)), SIZE_UNIT[kind]


def cannot_tell(w: Window, j: int, has_motor_encoders: bool) -> dict[str, str]:
    """Kinds the window cannot show on joint ``j`` (0-based), with why."""
    out = {}
    if not has_motor_encoders:
        for k, why in NEEDS_MOTOR_ENCODERS.items():
            out[k] = f"the log has no motor encoders: {why}"
    share = w.features.get(FLANK_COLUMN.format(j + 1), float("nan"))
    if "backlash" not in out and not (np.isfinite(share) and reverses(share)):
        out["backlash"] = "no gear-torque reversal in this window: the clearance is never crossed"
    if w.share_moving[j] < MIN_SHARE_MOVING:
        out["coulomb_friction"] = (f"the joint moves in {100 * w.share_moving[j]:.0f} % of this window "
                                   f"(needs {100 * MIN_SHARE_MOVING:.0f} %): friction is not exercised")
    if w.vif:
        for kind, est in ESTIMATE_OF.items():
            if kind not in out and not np.isfinite(w.vif[j][est]):
                out[kind] = ("its signature is absent from this window or the same as another's of its fit "
                             "(e.g. an offset and a backlash without a torque reversal)")
    return out


def same_signature(kind: str) -> list[str]:
    """The kinds whose current residual has the same shape as ``kind``'s (a current-sensor gain and a torque-constant
    loss: both a residual proportional to the current, :data:`ur5fault.health.diagnostics.kind_call.MERGED_KINDS`).
    Only the sensor's noise tells them apart (the current-noise ratio at rest, :mod:`ur5fault.health.twin_features`):
    where the joint never rests in the window the classifier's split between them is not evidence."""
    group = MERGED_KINDS.get(kind)
    return sorted(k for k, g in MERGED_KINDS.items() if group is not None and g == group and k != kind)


def _finite(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


def window_limits(w: Window, j: int, blind: dict[str, str], cal: LimitCalibration) -> dict[str, dict[str, Any]]:
    """The window's detection limits on joint ``j`` (0-based) per kind (module docstring); ``blind``: its
    :func:`cannot_tell`, which overrides a finite limit."""
    out = joint_limits(w.features, cal, j + 1, DEFAULT_Z)
    for kind, why in blind.items():
        if kind in out and out[kind]["detectable_from"] is not None:
            out[kind] = {"detectable_from": None, "unit": out[kind]["unit"], "cannot_tell": why}
    return out


def joint_scores(models, names: Sequence[str], x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The saved classifiers on inputs ``x`` ``(n_windows, n_inputs)``: each joint's score of a fault ``(n_windows,
    6)`` (1 - the kind classifier by joint's probability of none: the by-joint detector, whose largest is compared
    with the threshold), the classifier by joint's probabilities ``(n_windows, 6, n_classes)`` and the run-level
    detector's probability ``(n_windows,)``."""
    from ..diagnostics.classifier import single_threaded

    with single_threaded():
        p_run = models.detector.predict_proba(x)[:, list(models.detector.classes_).index(1)]
        by_joint = joint_kind.probabilities(models.joint_kind, pd.DataFrame(x, columns=list(names)), tuple(names))
    cls = [str(c) for c in models.joint_kind.classes_]
    return 1.0 - by_joint[:, :, cls.index(joint_kind.NONE)], by_joint, p_run


def score_windows(models, schema: dict[str, Any], windows: list[Window], has_motor_encoders: bool,
                  inputs_map: Callable[[np.ndarray], np.ndarray] | None = None,
                  limit_calibration: LimitCalibration | None = None,
                  threshold: float | None = None) -> list[dict[str, Any]]:
    """Per window: its times, ``p_fault``, ``flagged``, the run-level detector's reading, and per joint
    ``p_fault_joint``, the likeliest kinds with size estimates and intervals, and the kinds it cannot tell
    (module docstring).  ``inputs_map``: applied to the classifier inputs ``(n_windows, n_inputs)`` before they
    are scored (a robot's baseline, :mod:`.baseline`); the size estimates stay the window's own.
    ``limit_calibration``: each joint also gets ``detection_limits`` (:func:`window_limits`); None: left out.
    ``threshold``: the by-joint score above which a window is flagged (None: the schema's 5 % false-alarm point of
    the training runs; a robot's own, :mod:`.robot_threshold`, is never below it)."""

    names = [c["name"] for c in schema["inputs"]]
    x = window_inputs(windows, names)
    if inputs_map is not None:
        x = inputs_map(x)
    thr = float(schema["joint_kind_threshold_5pct_false_alarms"]) if threshold is None else float(threshold)
    run_thr = float(schema["detector_threshold_5pct_false_alarms"])
    score_joint, by_joint, p_run = joint_scores(models, names, x)
    cls = [str(c) for c in models.joint_kind.classes_]
    p_joint = score_joint if models.calibrator is None else calibration.apply(
        models.calibrator, score_joint.reshape(-1)).reshape(score_joint.shape)
    out = []
    for i, w in enumerate(windows):
        joints = []
        for j in range(N_JOINTS):
            blind = cannot_tell(w, j, has_motor_encoders)
            kinds = []
            faulty = [(c, by_joint[i, j, k]) for k, c in enumerate(cls) if c != joint_kind.NONE]
            total = sum(v for _, v in faulty) or 1.0
            for c, v in sorted(faulty, key=lambda cv: -cv[1])[:N_KINDS]:
                size, unit = size_estimate(c, w.features, j + 1)
                halves = [size_estimate(c, h, j + 1)[0] for h in w.halves]
                ok = c not in blind and np.isfinite(size)
                vif = w.vif[j].get(ESTIMATE_OF.get(c, ""), float("nan")) if w.vif else float("nan")
                kinds.append({"kind": c, "p_given_fault": float(v / total),
                              "variance_inflation": _finite(vif), "confounded": bool(ok and vif > MAX_VIF),
                              "size": _finite(size) if ok else None, "unit": unit,
                              "interval": [_finite(min(halves)), _finite(max(halves))]
                              if ok and all(np.isfinite(halves)) else None,
                              "cannot_tell": c in blind, "same_signature_as": same_signature(c)})
            noise = w.features.get(f"{NOISE_RATIO}_j{j + 1}", math.nan)
            joints.append({"joint": j + 1, "p_fault_joint": float(p_joint[i, j]), "kinds": kinds,
                           "cannot_tell": blind, "current_noise_ratio_rest": _finite(noise),
                           **({} if limit_calibration is None else
                              {"detection_limits": window_limits(w, j, blind, limit_calibration)})})
        score = float(score_joint[i].max())
        out.append({"start_s": w.start_s, "end_s": w.end_s, "p_fault": float(p_joint[i].max()),
                    "p_fault_score": score, "flagged": bool(score > thr),
                    "p_fault_run_level": float(p_run[i]), "flagged_run_level": bool(p_run[i] > run_thr),
                    "joints": joints})
    return out

"""``ur5fault diagnose LOG``: a measured log scored with the classifiers ``ur5fault benchmark`` saved.

The log's commands are replayed through its digital twin (:class:`ur5fault.twin.LogReplay`, under the model
overlay a user fitted to the robot, with the log's payload, tool and temperatures), the same features a
campaign computes for a run are taken over consecutive windows as long as the training runs
(:mod:`.windows`), and every window is scored (:mod:`.score`). Written: ``diagnosis.json``, ``report.md`` and
``diagnosis.png`` (:mod:`.report`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import ParameterError
from ...logs import MeasuredLog
from ...sim.effects import EffectSpec
from ...twin import LogReplay, Replayed
from .score import check_schema, score_windows
from .windows import Window, window_features

#: sensor-noise seed of the twin's replay (independent of the robot's: the robot's noise is its own)
TWIN_SEED = 1


def replay_twin(log: MeasuredLog, params_overrides: dict | None = None, base_effects: Sequence[EffectSpec] = (),
                *, seed: int = TWIN_SEED) -> tuple[LogReplay, Replayed]:
    """The log's digital twin: its commands replayed through the model (it depends on the log's commands,
    payload, tool and temperatures only, never on its measured signals)."""
    replay = LogReplay(log, params_overrides, base_effects, seed=seed)
    rep = replay.run([()])[0]
    if not rep.ok:
        raise ParameterError(f"{log.source}: the twin's replay failed ({rep.status}); check the log and the model")
    return replay, rep


def diagnose(log: MeasuredLog, detector_dir: str | Path, params_overrides: dict | None = None,
             base_effects: Sequence[EffectSpec] = (), *, seed: int = TWIN_SEED,
             twin: tuple[LogReplay, Replayed] | None = None) -> dict[str, Any]:
    """Diagnose ``log`` with the classifiers saved in ``detector_dir``; return the diagnosis (``diagnosis.json``'s
    content) with the windows' features under ``"_windows"``.  ``twin``: the :func:`replay_twin` of a log with
    the same commands, conditions and model (e.g. the same log before a fault was written into its measured
    signals), reused instead of replayed again."""
    from ..diagnostics.saved import load_models

    models, schema = load_models(detector_dir)
    window_s = check_schema(schema, str(detector_dir))
    replay, rep = twin if twin is not None else replay_twin(log, params_overrides, base_effects, seed=seed)
    temp = (np.mean(log.temperature_C) if log.temperature_C is not None
            else float(np.mean(replay.params.joint_temperature_C)))
    context = {"payload_kg": float(log.payload_kg), "temperature_C": float(temp)}
    windows: list[Window] = window_features(log, replay, rep, window_s, context)
    scored = score_windows(models, schema, windows, log.q_motor_rad is not None)
    notes = list(log.assumptions(replay.params.joint_temperature_C))
    if log.q_motor_rad is None:
        notes.append("no motor encoders in the log: every encoder-mismatch feature is missing (NaN) and the "
                     "detector scores without them; backlash, resolver offset and gear stiffness cannot be told")
    trained = schema.get("log_period_s")
    if trained and abs(log.period_s - trained) > 1e-9:
        notes.append(f"log sampled every {1e3 * log.period_s:g} ms, the training runs every {1e3 * trained:g} ms: "
                     "rate-dependent features (current spikes, kurtosis, crest factor, high-frequency energy, "
                     "residual RMS) are not on the scale the detector learned")
    thr = float(schema["joint_kind_threshold_5pct_false_alarms"])
    p_thr = thr
    if models.calibrator is None:
        notes.append("these classifiers were saved without a calibration: p_fault is the fault-kind classifier by "
                     "joint's own score, not a calibrated frequency (run `ur5fault benchmark` again to calibrate it)")
    else:
        from ..diagnostics.calibration import apply

        p_thr = float(apply(models.calibrator, np.array([thr]))[0])
    flagged = [w for w in scored if w["flagged"]]
    return {
        "log": log.source,
        "duration_s": float(log.t_s[-1] - log.t_s[0]),
        "log_period_s": log.period_s,
        "detector": {"folder": str(detector_dir), "feature_set": schema.get("feature_set"),
                     "training_set_sha256": schema.get("training_set_sha256"),
                     "p_fault_from": "fault-kind classifier by joint: largest joint probability of a fault",
                     "threshold_5pct_false_alarms": thr, "threshold_from": schema.get("joint_kind_threshold_from"),
                     "calibrated": models.calibrator is not None,
                     "calibration": schema.get("calibration", {}) and {
                         k: v for k, v in schema["calibration"].items()
                         if k in ("method", "score", "n_folds", "grouped_by")},
                     "run_level_threshold_5pct_false_alarms": float(schema["detector_threshold_5pct_false_alarms"]),
                     "p_fault_at_threshold": p_thr, "window_s": window_s,
                     "ur5fault_version": schema.get("ur5fault_version")},
        "conditions": context,
        "n_windows": len(scored),
        "n_flagged": len(flagged),
        "windows": scored,
        "notes": notes,
        "_windows": windows,
    }


__all__ = ["diagnose", "replay_twin"]

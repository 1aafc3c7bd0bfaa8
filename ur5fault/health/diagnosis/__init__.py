"""``ur5fault diagnose LOG``: a measured log scored with the classifiers ``ur5fault benchmark`` saved.

The log's commands are replayed through its digital twin (:class:`ur5fault.twin.LogReplay`, under the model
overlay a user fitted to the robot, with the log's payload, tool and temperatures), the same features a
campaign computes for a run are taken over consecutive windows as long as the training runs
(:mod:`.windows`), and every window is scored (:mod:`.score`), its inputs first referred to the robot's own
healthy baseline when one is given (:func:`robot_baseline`, :mod:`.baseline`). Written: ``diagnosis.json``,
``report.md`` and ``diagnosis.png`` (:mod:`.report`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import ParameterError
from ...logs import MeasuredLog
from ...logs.measured import same_period
from ...sim.effects import EffectSpec
from ...twin import LogReplay, Replayed
from ...twin.replay import refuse_log_owned
from ..diagnostics.limits import DEFAULT_Z, LimitCalibration
from .baseline import (
    MIN_SPREAD_WINDOWS,
    ROBOT_THRESHOLD_FROM,
    BaselineMap,
    fit_map,
    set_by_sentence,
    training_reference,
)
from .robot_threshold import threshold_from_baseline
from .score import check_schema, score_windows
from .windows import Window, window_features

#: sensor-noise seed of the twin's replay (independent of the robot's: the robot's noise is its own)
TWIN_SEED = 1


def replay_twin(log: MeasuredLog, params_overrides: dict | None = None, base_effects: Sequence[EffectSpec] = (),
                *, seed: int = TWIN_SEED, com_twins: bool = False) -> tuple[LogReplay, Replayed]:
    """The log's digital twin: its commands replayed through the model (it depends on the log's commands,
    payload, tool and temperatures only, never on its measured signals).  Its readings ``y`` carry its own sensor
    noise (seed ``seed``); its motor current ``current_true_A`` and gear torque ``torque_gear_Nm``, the twin fits'
    regressors, are those of the same replay without sensor noise (:mod:`ur5fault.health.twin_regressors`), as a
    campaign's twin features take them; with ``com_twins`` (a detector trained on a campaign with
    ``twin_com_twins``) its ``com_A_per_m``, the current fit's payload centre-of-mass columns, from three more
    noise-free replays with the payload's centre of mass shifted (zero without a payload)."""
    from ..twin_regressors import COM_AXES, REGRESSOR_EFFECTS, com_difference, com_effects

    refuse_log_owned(params_overrides, base_effects, [log])
    replay = LogReplay(log, params_overrides, base_effects, seed=seed)
    shifted = [REGRESSOR_EFFECTS + e for e in com_effects()] if com_twins and log.payload_kg > 0 else []
    rep, quiet, *com = replay.run([(), REGRESSOR_EFFECTS, *shifted])
    for r, what in ((rep, "twin's replay"), (quiet, "noise-free twin's replay"),
                    *((c, f"noise-free twin's replay with the payload CoM shifted along {ax}")
                      for c, ax in zip(com, COM_AXES))):
        if not r.ok:
            raise ParameterError(f"{log.source}: the {what} failed ({r.failure})")
    columns = (com_difference(np.stack([c.current_true_A for c in com]), quiet.current_true_A) if com
               else np.zeros((*quiet.current_true_A.shape, len(COM_AXES))) if com_twins else None)
    return replay, dataclasses.replace(rep, current_true_A=quiet.current_true_A, torque_gear_Nm=quiet.torque_gear_Nm,
                                       com_A_per_m=columns)


def log_windows(log: MeasuredLog, window_s: float, twin: tuple[LogReplay, Replayed]) -> list[Window]:
    """The classifier inputs of every whole window of ``log`` (:func:`.windows.window_features`), with its
    operating conditions (payload, mean temperature: the log's, else the model's)."""
    replay, rep = twin
    temp = (np.mean(log.temperature_C) if log.temperature_C is not None
            else float(np.mean(replay.params.joint_temperature_C)))
    context = {"payload_kg": float(log.payload_kg), "temperature_C": float(temp)}
    return window_features(log, replay, rep, window_s, context)


def robot_baseline(healthy: Sequence[MeasuredLog], detector_dir: str | Path, params_overrides: dict | None = None,
                   base_effects: Sequence[EffectSpec] = (), *, seed: int = TWIN_SEED,
                   windows: Sequence[Sequence[Window]] | None = None) -> BaselineMap:
    """The robot's own healthy baseline (:mod:`.baseline`): ``healthy`` logs of the robot replayed through the
    same twin (model overlay) and windowed as a diagnosed log is, with the robot's own false-alarm threshold read
    off them held out (:mod:`.robot_threshold`); ``windows``: their windows, when already computed (one sequence
    per log, in order)."""
    from ..diagnostics.saved import load_models

    models, schema = load_models(detector_dir)
    window_s = check_schema(schema, str(detector_dir))
    if not healthy:
        raise ParameterError("a baseline needs at least one healthy log of the robot")
    odd = [g.source for g in healthy if not same_period(g.period_s, healthy[0].period_s)]
    if odd:
        raise ParameterError(f"{odd[0]}: sampled every {1e3 * healthy[0].period_s:g} ms in {healthy[0].source}, "
                             "otherwise here; a baseline's logs must share one sample period")
    if windows is None:
        com = bool(schema.get("twin_com_twins", False))
        windows = [log_windows(g, window_s, replay_twin(g, params_overrides, base_effects, seed=seed, com_twins=com))
                   for g in healthy]
    reference = training_reference(detector_dir, schema)
    by_log = [(g.source, w) for g, w in zip(healthy, windows)]
    bmap = fit_map(reference, by_log, healthy[0].period_s, [g.content_sha256() for g in healthy])
    return dataclasses.replace(bmap, threshold=threshold_from_baseline(models, reference, by_log, healthy[0].period_s))


def diagnose(log: MeasuredLog, detector_dir: str | Path, params_overrides: dict | None = None,
             base_effects: Sequence[EffectSpec] = (), *, seed: int = TWIN_SEED,
             twin: tuple[LogReplay, Replayed] | None = None, baseline: BaselineMap | None = None,
             windows: list[Window] | None = None) -> dict[str, Any]:
    """Diagnose ``log`` with the classifiers saved in ``detector_dir``; return the diagnosis (``diagnosis.json``'s
    content) with the windows' features under ``"_windows"``.  ``twin``: the :func:`replay_twin` of a log with
    the same commands, conditions and model (e.g. the same log before a fault was written into its measured
    signals), reused instead of replayed again; ``windows``: the log's :func:`log_windows` under that twin,
    reused likewise; ``baseline``: the robot's own healthy baseline (:func:`robot_baseline`), which every input
    is referred to before it is scored (None: the inputs are scored as they are)."""
    from ..diagnostics.envelope import outside_notes
    from ..diagnostics.saved import NEAR_CHANCE_AUC, detector_test_auc, load_models, twin_format_notes, unverified_notes

    models, schema = load_models(detector_dir)
    window_s = check_schema(schema, str(detector_dir))
    com = bool(schema.get("twin_com_twins", False))
    replay, rep = twin if twin is not None else replay_twin(log, params_overrides, base_effects, seed=seed,
                                                             com_twins=com)
    if com != (rep.com_A_per_m is not None):
        raise ParameterError(f"{log.source}: the twin given was replayed {'without' if com else 'with'} the payload "
                             f"CoM twins the detector's campaign {'had' if com else 'did not have'} "
                             f"(replay_twin(..., com_twins={com}))")
    if windows is None:
        windows = log_windows(log, window_s, (replay, rep))
    context = {k: windows[0].features[k] for k in ("payload_kg", "temperature_C")}
    if baseline is not None:
        same = (log.content_sha256() in baseline.log_sha256 if baseline.log_sha256  # by content: a file name
                else log.source in baseline.logs)                                # says nothing across folders
        if same:
            raise ParameterError(f"{log.source} is both diagnosed and a baseline log; a run cannot judge itself")
        if baseline.reference.names != tuple(c["name"] for c in schema["inputs"]):
            raise ParameterError("the baseline was built for another detector's inputs")
        if not same_period(baseline.period_s, log.period_s):
            raise ParameterError(f"{log.source}: sampled every {1e3 * log.period_s:g} ms, its baseline logs every "
                                 f"{1e3 * baseline.period_s:g} ms; the features depend on the rate: give a baseline "
                                 "logged like the diagnosed log")
    cal = schema.get("detection_limit_calibration")
    thr = float(schema["joint_kind_threshold_5pct_false_alarms"])
    robot = None if baseline is None else baseline.threshold
    flag_thr = thr if robot is None else max(thr, robot.score)
    scored = score_windows(models, schema, windows, log.q_motor_rad is not None,
                           None if baseline is None else baseline.apply,
                           None if not cal else LimitCalibration.from_dict(cal), flag_thr)
    notes = list(log.assumptions(replay.params.joint_temperature_C))
    unscored = float(log.t_s[-1] - log.t_s[0]) - (windows[-1].end_s - windows[0].start_s)
    if unscored > log.period_s * 1.5:  # whole windows only: the rest of the log is left out, and said so
        notes.append(f"only whole windows are scored: the last {unscored:.2g} s of the log (less than a "
                     f"{window_s:.3g} s window) are not")
    if not cal:
        notes.append("these classifiers were saved without the detection-limit calibration: no detection_limits "
                     "per joint (run `ur5fault benchmark` again with this version to add them)")
    if baseline is not None:
        n = {r: v["n_inputs"] for r, v in baseline.summary()["rules"].items()}
        few = n["shifted_few_windows"]
        notes.append(f"inputs referred to the robot's healthy baseline ({baseline.n_windows} windows of "
                     f"{len(baseline.logs)} log(s)): {n['scaled']} scaled by the baseline's larger spread, "
                     f"{n['shifted'] + n['shifted_zero_spread'] + n['shifted_training_zero_spread']} shifted by "
                     "its median"
                     + (f", {few} shifted only (fewer than {MIN_SPREAD_WINDOWS} baseline values)" if few else "")
                     + f", {n['left_as_measured']} left as measured (no baseline or training "
                     "value); p(fault) is calibrated on simulated runs, not on this robot's baseline")
    if log.q_motor_rad is None:
        notes.append("no motor encoders in the log: every encoder-mismatch feature is missing (NaN) and the "
                     "detector scores without them; backlash, resolver offset and gear stiffness cannot be told")
    notes.extend(unverified_notes(detector_dir))
    notes.extend(twin_format_notes(schema))
    notes.extend(outside_notes(schema, context, log.source))
    auc = detector_test_auc(detector_dir)
    if auc is not None and auc < NEAR_CHANCE_AUC:
        notes.append(f"this detector's by-joint detection AUC on its own campaign's test split is {auc:.2f} (0.5 is "
                     "chance; `ur5fault benchmark` prints it beside the run-level AUC): "
                     "its flags say little; train it on a larger or more varied campaign")
    trained = schema.get("log_period_s")
    if trained and not same_period(log.period_s, trained):
        notes.append(f"log sampled every {1e3 * log.period_s:g} ms, the training runs every {1e3 * trained:g} ms: "
                     "rate-dependent features (current spikes, kurtosis, crest factor, high-frequency energy, "
                     "residual RMS) are not on the scale the detector learned")
    if baseline is not None and robot is None:
        notes.append("the baseline carries no threshold of its own (a single window cannot be held out against "
                     "another), so windows are flagged at the training runs' 5 % point alone")
    elif robot is not None:
        notes.append(f"a window counts as flagged only where it exceeds the robot's own threshold as well as the "
                     f"training runs': the robot's is read off its {robot.n} baseline windows, each "
                     f"scored against a baseline of the others ({len(robot.groups)} groups); a healthy window like "
                     f"them exceeds it with probability {robot.false_alarm_bound:.2g}"
                     + ("" if robot.rank <= robot.n else
                        f" (fewer than {int(round(1 / robot.alpha)) - 1} windows: the largest held-out score)")
                     + ("; it is below the training runs' threshold, which is kept" if robot.score <= thr else
                        f"; {set_by}" if (set_by := set_by_sentence(robot.summary(), models.calibrator is not None))
                        else ""))
    p_thr = thr
    p_flag = flag_thr
    if models.calibrator is None:
        notes.append("these classifiers were saved without a calibration: p_fault is the fault-kind classifier by "
                     "joint's own score, not a calibrated frequency (run `ur5fault benchmark` again to calibrate it)")
    else:
        from ..diagnostics.calibration import apply

        p_thr, p_flag = (float(v) for v in apply(models.calibrator, np.array([thr, flag_thr])))
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
        # what a window is flagged above: the training runs' 5 % point, or the robot's own where it is higher
        "flag_threshold": {"score": flag_thr, "p_fault": p_flag,
                           "from": "the training runs' 5 % false-alarm point" if flag_thr == thr else
                           ROBOT_THRESHOLD_FROM},
        "conditions": context,
        # None: the inputs were scored as they are, against the simulated healthy runs only
        "baseline": None if baseline is None else baseline.summary(),
        # the z of every joint's detection_limits (None: the detector saved no calibration, and they are left out)
        "detection_limit_z": DEFAULT_Z if cal else None,
        "n_windows": len(scored),
        "n_flagged": len(flagged),
        "windows": scored,
        "notes": notes,
        "_windows": windows,
    }


__all__ = ["diagnose", "log_windows", "replay_twin", "robot_baseline"]

"""The trained classifiers saved beside the report, in a format a user can load safely.

``<out>/models/``:

* ``classifiers.skops``: the run-level detector, the localiser, the fault-kind classifier, the fault-kind
  classifier by joint (:mod:`.joint_kind`: its largest joint probability of a fault is the p(fault) of
  ``ur5fault diagnose``) and the calibration map of that score (:mod:`.calibration`; absent when the benchmark
  did not calibrate, e.g. on shuffled labels: ``ur5fault diagnose`` then says that its p(fault) is not
  calibrated) - scikit-learn objects in skops' format: loading it runs no code from the file;
  :func:`load_models` refuses any type outside scikit-learn and numpy;
* ``schema.json``: the input columns in order with their units, the feature set, the classes of each
  classifier, the thresholds at 5 % false alarms of the run-level detector and of the by-joint score (on the
  training campaign's test split), a
  SHA-256 of the training rows (inputs and labels), the package, scikit-learn and skops versions, and the
  training runs' duration and log period (``window_s``, ``log_period_s``: ``ur5fault diagnose`` cuts a log
  into windows of that length, so that its features are taken over as long a stretch as the training
  runs'; ``None`` when the campaign's manifest does not say them), and the healthy training runs' median and
  robust spread of every input (``healthy_training_inputs``, :func:`healthy_reference`: ``ur5fault diagnose
  --baseline-logs`` refers a robot's windows to it; absent from classifiers saved before it, which then read it
  from the campaign's feature table beside the benchmark folder), and the robust spread of each twin size
  estimate's t value per joint on the healthy training runs (``detection_limit_calibration``,
  :class:`.limits.LimitCalibration`: the detection limits of ``ur5fault diagnose``; absent from classifiers saved
  before it, whose diagnosis then leaves the limits out), and the range of the payload and the temperature over the
  training runs (``training_ranges``, :mod:`.envelope`: ``diagnose`` and ``benchmark --test`` say where they leave
  it by more than half the largest gap between neighbouring training values, ``training_range_gaps``).

Both files are written with SHA-256 sidecars (``<name>.sha256``) and ``schema.json`` records the SHA-256 of
the ``classifiers.skops`` it was saved with (``classifiers_sha256``): :func:`load_models` refuses, in one line
naming the file, a file whose bytes changed since it was written and a folder mixed from two benchmarks (an
interrupted save).  Folders saved before the sidecars load unverified.

Scoring another campaign with them (``ur5fault benchmark TRAIN_DIR --test OTHER_DIR``) needs its
table to hold every input column; a missing one is named.
"""

from __future__ import annotations

import hashlib
import json
import math
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ...errors import ConfigFileError
from ...util import provenance
from ...util.io import (
    StoredFileError,
    check_stored,
    checksum_path,
    file_sha256,
    read_json_stored,
    remove_stale_temporaries,
    write_bytes_atomic,
    write_json_atomic,
)
from ...util.robust import robust_spread
from .data import Dataset
from .envelope import training_range_gaps, training_ranges
from .metrics import FROM_OUT_OF_FOLD, FROM_TEST_SPLIT
from .models import Models

MODELS_DIR = "models"
CLASSIFIERS_FILE = "classifiers.skops"
SCHEMA_FILE = "schema.json"
#: 2: the twin features' current estimates are fitted with the payload CoM and latency held out and carry
#: standard errors and t values; 3: p(fault) is the fault-kind classifier by joint's score, and the calibration
#: map saved is that score's (formats 1-2 calibrated the run-level detector: refused in one line); 4: the twin fits'
#: regressors come from noise-free twins (twin residuals format 3, health/twin_regressors.py), so the twin
#: estimates a format-3 classifier learnt do not mean what ``ur5fault diagnose`` now computes (refused likewise)
SCHEMA_FORMAT = 4
#: what to run when the saved classifiers fail their checksums
RESAVE = "run `ur5fault benchmark` on the training campaign again to save them anew"
#: module prefixes of the types a saved file may hold (anything else is refused on loading)
TRUSTED_PREFIXES = ("sklearn.", "numpy.", "builtins.")


def training_hash(ds: Dataset) -> str:
    """SHA-256 of the training rows: run ids (when present), inputs and labels, in order."""
    cols = [c for c in ("run_id",) if c in ds.train] + list(ds.inputs) + ["fault", "fault_joint"]
    h = hashlib.sha256(json.dumps(cols).encode())
    h.update(pd.util.hash_pandas_object(ds.train[cols].astype(str), index=False).to_numpy().tobytes())
    return h.hexdigest()


def healthy_reference(train: pd.DataFrame, inputs: list[str] | tuple[str, ...]) -> dict[str, list]:
    """Per input (in ``inputs``' order), over the healthy rows of ``train`` (``fault == "healthy"``): the median,
    the robust spread (:func:`ur5fault.util.robust.robust_spread`) and the number of finite values
    (NaN where there is none)."""
    h = train.loc[train["fault"] == "healthy", list(inputs)].apply(pd.to_numeric, errors="coerce").to_numpy(float)
    med, scale, n = robust_spread(h.reshape(len(h), len(inputs)))
    return {"median": [None if not np.isfinite(v) else float(v) for v in med],
            "scale": [None if not np.isfinite(v) else float(v) for v in scale], "n": [int(v) for v in n]}


def save_models(models: Models, ds: Dataset, feature_set: str, threshold_score: float, out: Path,
                window_s: float | None = None, log_period_s: float | None = None,
                calibration: dict[str, Any] | None = None, joint_kind_threshold: float | None = None,
                joint_kind_threshold_from: str | None = None, limit_calibration: dict[str, Any] | None = None,
                twin_com_twins: bool = False, twin_residuals_format: int | None = None) -> Path:
    """Write the classifiers and their schema into ``out/models``; return that folder (``window_s``,
    ``log_period_s``: the training runs' simulated duration and log period, from the campaign manifest;
    ``calibration``: how ``models.calibrator`` was fitted, recorded in the schema; ``joint_kind_threshold_from``:
    where the by-joint operating point was read, :data:`.metrics.FROM_OUT_OF_FOLD` for ``ur5fault benchmark``;
    ``limit_calibration``: :meth:`.limits.LimitCalibration.to_dict` of the training runs, for the detection limits
    of ``ur5fault diagnose``; ``twin_com_twins``: the campaign's twin fits took their payload CoM columns from
    CoM-shifted noise-free twins, which ``ur5fault diagnose`` must then replay too; ``twin_residuals_format``: the
    version of the twin residual features the campaign computed, from its manifest, None where not recorded)."""
    import sklearn
    import skops
    import skops.io as sio

    from ...campaign.store import column_units

    folder = Path(out) / MODELS_DIR
    folder.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(folder)  # of a writer killed mid-write over an hour ago
    objs = {"detector": models.detector, "localiser": models.localiser, "kind": models.kind,
            "joint_kind": models.joint_kind}
    stored = {**objs, "calibrator": models.calibrator}
    classifiers = write_bytes_atomic(folder / CLASSIFIERS_FILE,
                                     sio.dumps({k: v for k, v in stored.items() if v is not None}), checksum=True)
    units = column_units(ds.inputs)
    schema = {
        "schema_format": SCHEMA_FORMAT,
        # binds this schema to the classifiers saved with it (a folder mixed from two saves is refused)
        "classifiers_sha256": file_sha256(classifiers),
        "feature_set": feature_set,
        "inputs": [{"name": c, "unit": units.get(c, "-")} for c in ds.inputs],
        "classes": {k: [v.item() if hasattr(v, "item") else v for v in m.classes_] for k, m in objs.items()
                    if m is not None},
        "detector_threshold_5pct_false_alarms": float(threshold_score),
        # the same operating point of the kind classifier by joint's p(fault on any joint); None without it
        "joint_kind_threshold_5pct_false_alarms": None if joint_kind_threshold is None else float(joint_kind_threshold),
        "joint_kind_threshold_from": joint_kind_threshold_from or FROM_TEST_SPLIT,
        "n_train": len(ds.train),
        "training_set_sha256": training_hash(ds),
        "shuffled_labels": models.shuffled_labels,
        "ur5fault_version": provenance.package_version(),
        "sklearn_version": sklearn.__version__,
        "skops_version": skops.__version__,
        "window_s": None if window_s is None else float(window_s),
        "log_period_s": None if log_period_s is None else float(log_period_s),
        # the twin fits' payload CoM columns: from CoM-shifted noise-free twins (true; the campaign's twin_com_twins)
        # or the CoM's gravity torque (false, and absent in files saved before the option)
        "twin_com_twins": bool(twin_com_twins),
        # the version of the twin features trained on (campaign identity.TWIN_RESIDUALS_FORMAT); absent or None: not
        # recorded (campaigns before 2026-11-30's format 11); twin_format_notes compares it with this version's
        "twin_residuals_format": twin_residuals_format,
        # None: p(fault) is the detector's own probability, not calibrated (classifiers saved before calibration)
        "calibration": None if models.calibrator is None else (calibration or {"method": "unrecorded"}),
        # the reference a robot's own healthy baseline is referred to (ur5fault diagnose --baseline-logs)
        "healthy_training_inputs": healthy_reference(ds.train, ds.inputs),
        # each known condition's range over the training runs (envelope.py: a log or campaign beyond it is said)
        "training_ranges": training_ranges(ds.train),
        # and its largest gap between neighbouring values: a value beyond the range by less than half is not said
        "training_range_gaps": training_range_gaps(ds.train),
        # the spread of the twin estimates' t values on the healthy training runs (ur5fault diagnose's detection
        # limits, limits.py); absent: saved before it, or a table without the estimates' SEs
        **({"detection_limit_calibration": limit_calibration} if limit_calibration else {}),
    }
    write_json_atomic(folder / SCHEMA_FILE, schema, checksum=True)
    return folder


#: a saved detector whose own test-split AUC is below this is said to be near chance when it diagnoses a log
NEAR_CHANCE_AUC = 0.7


def detector_test_auc(folder: str | Path) -> float | None:
    """The by-joint detection AUC the saved classifiers reached on their own campaign's test split, from the
    ``metrics.json`` beside them (``folder`` as :func:`load_models` takes it), or None where it cannot be read (a
    note only reads it: the file is a report, not verified)."""
    auc = (_benchmark_report(Path(folder)).get("detection_by_joint") or {}).get("auc_all")
    return float(auc) if isinstance(auc, (int, float)) and math.isfinite(auc) else None


def _benchmark_report(folder: Path) -> dict[str, Any]:
    """The ``metrics.json`` of the benchmark in ``folder`` or beside it (``folder`` as :func:`load_models` takes
    it), for notes only (a report, not verified); empty where there is none or it cannot be read."""
    for path in (folder / "metrics.json", folder.parent / "metrics.json"):
        if path.is_file():
            try:
                data = json.loads(path.read_text())
            except (OSError, ValueError):
                return {}
            return data if isinstance(data, dict) else {}
    return {}


def unverified_notes(folder: str | Path) -> list[str]:
    """A note when the saved classifiers' schema (which holds the classifiers' SHA-256, the operating point and the
    inputs) has no checksum file beside it: copied without it, or edited by hand, it is read unverified (as
    ``monitor --baseline-stats`` says of a baseline.json)."""
    folder = Path(folder)
    if not (folder / SCHEMA_FILE).exists() and (folder / MODELS_DIR / SCHEMA_FILE).exists():
        folder = folder / MODELS_DIR
    schema = folder / SCHEMA_FILE
    if not schema.exists() or checksum_path(schema).exists():
        return []
    return [f"{schema}: no {checksum_path(schema).name} beside it; read unverified (its operating point, inputs and "
            f"the classifiers' checksum as they are in the file); {RESAVE} to have it checked"]


def models_folder(folder: str | Path) -> Path:
    """The ``models`` folder of ``folder`` (itself, or the report folder holding one), refused in one line where
    it holds no saved classifiers (what :func:`load_models` reads; cheap: ``diagnose`` checks it before --out)."""
    folder = Path(folder)
    if not (folder / SCHEMA_FILE).exists() and (folder / MODELS_DIR / SCHEMA_FILE).exists():
        folder = folder / MODELS_DIR
    path, schema_path = folder / CLASSIFIERS_FILE, folder / SCHEMA_FILE
    if not path.exists() or not schema_path.exists():
        if _benchmark_report(folder).get("shuffled_labels") is True:  # the control run saves none
            raise ConfigFileError(f"{folder}: a shuffled-label control (`benchmark --shuffle-labels`), which saves no "
                                  "classifiers; give the folder of the benchmark run without it")
        inner = Path(folder) / "benchmark"  # a campaign folder given for its report folder
        if (inner / MODELS_DIR / CLASSIFIERS_FILE).exists() and (inner / MODELS_DIR / SCHEMA_FILE).exists():
            raise ConfigFileError(f"{folder}: no saved classifiers ({CLASSIFIERS_FILE} and {SCHEMA_FILE}); "
                                  f"did you mean {inner} (where `ur5fault benchmark` saved them)?")
        raise ConfigFileError(f"{folder}: no saved classifiers ({CLASSIFIERS_FILE} and {SCHEMA_FILE}); "
                              "run `ur5fault benchmark` on a campaign first")
    return folder


def check_saved_inputs(folder: str | Path, features: pd.DataFrame, where: str) -> None:
    """:func:`check_inputs` of ``features`` against the schema in ``folder`` (as :func:`models_folder` takes it)
    before the classifiers are loaded (about 30 s for the diagnostics campaign's): a campaign without their inputs
    is refused at once.  A schema of another format, or one this cannot read, is left to :func:`load_models`, which
    refuses it with its own reason."""
    schema = read_json_stored(models_folder(folder) / SCHEMA_FILE, RESAVE)
    if not isinstance(schema, dict) or schema.get("schema_format", 1) != SCHEMA_FORMAT:
        return  # another format's inputs are not this version's: load_models says so
    inputs = schema.get("inputs")
    if isinstance(inputs, list) and all(isinstance(c, dict) and isinstance(c.get("name"), str) for c in inputs):
        check_inputs(features, schema, where)


def load_models(folder: str | Path) -> tuple[Models, dict[str, Any]]:
    """The saved classifiers and their schema from a ``models`` folder (or the report folder holding one).

    Raises:
        ConfigFileError: no saved models there, or the file holds a type outside scikit-learn and numpy.
        StoredFileError: a file changed since it was saved, or the two files come from different saves.
    """
    import skops.io as sio

    folder = models_folder(folder)
    path, schema_path = folder / CLASSIFIERS_FILE, folder / SCHEMA_FILE
    schema = read_json_stored(schema_path, RESAVE)
    if not isinstance(schema, dict):
        raise ConfigFileError(f"{schema_path}: not a schema of saved classifiers (not a JSON object); {RESAVE}")
    check_stored(path, RESAVE)
    data = path.read_bytes()
    recorded = schema.get("classifiers_sha256")
    if recorded is not None and recorded != hashlib.sha256(data).hexdigest():
        raise StoredFileError(f"{path}: not the classifiers {SCHEMA_FILE} was saved with (the folder is mixed from "
                              f"two saves, or the file changed); {RESAVE}")
    try:
        types = sio.get_untrusted_types(data=data)
        untrusted = [t for t in types if not t.startswith(TRUSTED_PREFIXES)]
        if untrusted:
            raise ConfigFileError(f"{path}: holds types outside scikit-learn and numpy ({', '.join(untrusted[:5])}); "
                                  "not loaded")
        objs = sio.loads(data, trusted=types)
    except ConfigFileError:
        raise
    except (zipfile.BadZipFile, OSError, ValueError, LookupError, TypeError, AttributeError) as exc:
        raise StoredFileError(f"{path}: unreadable as saved classifiers ({type(exc).__name__}: "
                              f"{' '.join(str(exc).split())[:100]}); {RESAVE}") from None
    fmt = schema.get("schema_format", 1)
    if not isinstance(fmt, int) or fmt < SCHEMA_FORMAT:
        why = ("whose twin estimates took their regressors from the noisy twin" if fmt == 3
               else "whose p(fault) is the run-level detector's")
        raise ConfigFileError(f"{folder}: saved with schema format {fmt}, {why} (this version reads format "
                              f"{SCHEMA_FORMAT}: p(fault) from the fault-kind classifier by joint, calibrated, on twin "
                              "estimates with noise-free regressors); run the campaign and `ur5fault benchmark` again")
    if fmt > SCHEMA_FORMAT:
        raise ConfigFileError(f"{folder}: schema format {fmt} is newer than this version reads ({SCHEMA_FORMAT}); "
                              "update ur5fault")
    if objs.get("joint_kind") is None or schema.get("joint_kind_threshold_5pct_false_alarms") is None:
        raise ConfigFileError(f"{folder}: holds no fault-kind classifier by joint with its 5 % false-alarm "
                              "threshold, the source of p(fault); run `ur5fault benchmark` on the campaign again")
    if (objs.get("calibrator") is None) != (schema.get("calibration") is None):
        raise ConfigFileError(f"{folder}: {CLASSIFIERS_FILE} and {SCHEMA_FILE} disagree on the calibration of "
                              "p(fault); the folder is mixed from two runs: run `ur5fault benchmark` again")
    return Models(objs.get("detector"), objs.get("localiser"), objs.get("kind"),
                  bool(schema.get("shuffled_labels")), objs.get("calibrator"), objs.get("joint_kind")), \
        operating_point(schema)


def twin_format_notes(schema: dict[str, Any], other: int | None = None, where: str | None = None) -> list[str]:
    """A note where the twin residual features the saved classifiers were trained on are of another version than
    those they are about to score: ``other``, another campaign's from its manifest (``where``: that campaign), or,
    without ``where``, the ones this version computes (``ur5fault diagnose``).  Nothing is said where either side
    did not record it."""
    from ...campaign.identity import twin_format_of

    trained = schema.get("twin_residuals_format")
    if where is None:
        other, where = twin_format_of(bool(schema.get("twin_com_twins"))), "this version of ur5fault"
    if trained is None or other is None or int(trained) == int(other):
        return []
    return [f"the classifiers were trained on twin residual features of format {trained}, {where} computes format "
            f"{other}: inputs of the same name may be computed differently (campaign/identity.py lists the formats); "
            "re-run the training campaign with --replace-changed and `ur5fault benchmark` to train on the same"]


def operating_point(schema: dict[str, Any]) -> dict[str, Any]:
    """``schema`` with the by-joint operating point one that no scored run has set.  Classifiers saved before the
    schema said where it came from (``joint_kind_threshold_from``) saved the threshold read off the training
    campaign's test split; their calibration records the training runs' out-of-fold 5 % threshold, which then
    becomes the operating point (the test split's is kept as ``joint_kind_threshold_test_split``).  Without that
    record the test split's stays, labelled as such."""
    if "joint_kind_threshold_from" in schema:
        return schema
    oof = (schema.get("calibration") or {}).get("threshold_out_of_fold")
    if oof is None:
        return {**schema, "joint_kind_threshold_from": FROM_TEST_SPLIT}
    return {**schema, "joint_kind_threshold_test_split": schema["joint_kind_threshold_5pct_false_alarms"],
            "joint_kind_threshold_5pct_false_alarms": float(oof),
            "joint_kind_threshold_from": FROM_OUT_OF_FOLD + " (from the calibration record)"}


def check_inputs(features: pd.DataFrame, schema: dict[str, Any], where: str) -> list[str]:
    """The schema's input columns, all present in ``features`` (else the missing ones are named)."""
    names = [c["name"] for c in schema["inputs"]]
    missing = [c for c in names if c not in features.columns]
    if missing:
        raise ConfigFileError(f"{where}: lacks {len(missing)} input column(s) of the saved classifiers "
                              f"({', '.join(missing[:5])}{', ...' if len(missing) > 5 else ''}; feature set "
                              f"{schema.get('feature_set')!r})")
    return names

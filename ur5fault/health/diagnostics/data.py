"""The benchmark's data: a campaign's feature table split into train and test by its ``split``
column, with the inputs a classifier may see.

Inputs are the health features a real robot can compute from its own signals (both encoders and
the motor current: ``track_err_*``, ``enc_mismatch_*``, ``current_*``) and two operating conditions
the controller knows (the configured payload, the logged joint temperature).  Left out: the
``tcp_*`` features (they need the true joint angles or the simulated healthy twin, which a robot
does not have - and the twin exists only for some runs, so they would leak the label), every
label column, and the nuisance a robot does not know (payload centre of mass, latency, the
trajectory itself).

Feature sets (``--features``): ``paper`` (the health features above), ``twin`` (the twin residual features
of :mod:`ur5fault.health.twin_features`, from a campaign with ``twin_residuals: true``), ``both``.  The
two known conditions are inputs of every set.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from ...errors import ConfigFileError
from ..features import FEATURE_UNITS
from ..twin_features import FEATURE_UNITS as TWIN_FEATURE_UNITS

#: operating conditions a UR controller knows and logs, used as inputs beside the features
CONTEXT_COLUMNS = ("payload_kg", "temperature_C")
#: features that need the simulation's ground truth (true joint angles, healthy twin)
SIM_ONLY_PREFIX = "tcp_"
#: the feature sets the benchmark compares
FEATURE_SETS = ("paper", "twin", "both")
LABEL_COLUMNS = ("fault", "fault_joint", "fault_scope", "fault_size", "fault_size_unit", "split", "split_group")


def input_columns(features: pd.DataFrame, feature_set: str = "paper") -> list[str]:
    """The classifier inputs of ``feature_set`` present in ``features`` (see the module docstring)."""
    paper = [c for c in FEATURE_UNITS if not c.startswith(SIM_ONLY_PREFIX) and c in features.columns]
    twin = [c for c in TWIN_FEATURE_UNITS if c in features.columns]
    chosen = {"paper": paper, "twin": twin, "both": paper + twin if paper and twin else []}[feature_set]
    return chosen + [c for c in CONTEXT_COLUMNS if c in features.columns] if chosen else []


def has_twin_features(features: pd.DataFrame) -> bool:
    return any(c in features.columns for c in TWIN_FEATURE_UNITS)


def load_features(path: Path) -> pd.DataFrame:
    """A campaign folder's (or a file's) feature table."""
    import pyarrow as pa

    from ...campaign.store import REBUILD_FEATURES, check_table_of_manifest
    from ...util.io import DAMAGED_PARQUET_ERRORS, check_stored

    p = path / "features.parquet" if path.is_dir() else path
    if not p.exists():
        refuse_life_folder(path)
        raise ConfigFileError(f"{p}: no such feature table (run `ur5fault campaign run` first)")
    check_stored(p, REBUILD_FEATURES)  # a changed byte would change features silently: refused before reading
    check_table_of_manifest(p, REBUILD_FEATURES)  # an earlier campaign's table left by a rerun that stopped
    try:
        return pd.read_parquet(p)
    except (*DAMAGED_PARQUET_ERRORS, pa.ArrowException) as exc:
        raise ConfigFileError(f"{p}: not a campaign folder, and cannot read it as a feature table "
                              f"({' '.join(str(exc).split())[:120]})") from None


@dataclasses.dataclass(frozen=True)
class Dataset:
    """Train and test rows of a campaign (status ``ok`` only).

    Attributes:
        train, test: the feature-table rows of each side.
        inputs: classifier input columns.
        n_dropped: rows left out because their run was not ``ok``, per fault kind.
        inputs_left_out: input columns left out (all NaN on a side) and why.
    """

    train: pd.DataFrame
    test: pd.DataFrame
    inputs: tuple[str, ...]
    n_dropped: dict[str, int]
    inputs_left_out: dict[str, str] = dataclasses.field(default_factory=dict)

    def x(self, side: str) -> np.ndarray:
        """Inputs of ``side`` (``"train"`` or ``"test"``), ``(n_rows, n_inputs)``."""
        return getattr(self, side)[list(self.inputs)].to_numpy(dtype=float)


def _missing_labels(features: pd.DataFrame) -> list[str]:
    return [c for c in LABEL_COLUMNS + ("status",) if c not in features and c != "fault_size_unit"]


def refuse_time_series(features: pd.DataFrame, where: str = "") -> None:
    """Refuse a run's time series (``ur5fault simulate``'s file) given for a campaign's feature table, in one line
    (``where``: its prefix, e.g. ``"--test run.parquet: "``)."""
    if "t_s" in features and _missing_labels(features):
        raise ConfigFileError(f"{where}a run's time series (`ur5fault simulate`), not a campaign's feature table: "
                              "give a campaign folder, e.g. results/diagnostics")


def load_dataset(features: pd.DataFrame | str | Path, feature_set: str = "paper") -> Dataset:
    """Split a feature table (or a campaign folder / features.parquet path) into a :class:`Dataset` with the
    inputs of ``feature_set`` (one of :data:`FEATURE_SETS`).

    Raises:
        ConfigFileError: no ``split`` column, one side empty, a group on both sides, no healthy
            or no faulty run in train or test, or an infinite feature value.
    """
    if not isinstance(features, pd.DataFrame):
        features = load_features(Path(features))
    refuse_time_series(features)
    missing = _missing_labels(features)
    if missing:
        raise ConfigFileError(f"feature table lacks {', '.join(missing)}: made before the label columns; "
                              f"rerun the campaign into a new folder")
    bad = features["status"] != "ok"
    n_dropped = features.loc[bad, "fault"].value_counts().to_dict()
    df = features[~bad]
    both = set(df.loc[df["split"] == "train", "split_group"]) & set(df.loc[df["split"] == "test", "split_group"])
    if both:
        raise ConfigFileError(f"split groups on both sides: {', '.join(sorted(both)[:5])}")
    train, test = df[df["split"] == "train"].reset_index(drop=True), df[df["split"] == "test"].reset_index(drop=True)
    if test.empty:  # e.g. one fixed motion: the split by motion puts its one group on the train side
        n_groups = train["split_group"].nunique()
        failed = int((features["split"] == "test").sum())
        raise ConfigFileError(f"no test runs: the {len(train)} runs with status ok are in {n_groups} split group(s), "
                              "all on the train side"
                              + (f", and the {failed} test run(s) did not finish ok" if failed else
                                 " (a campaign of one motion cannot be split by motion)")
                              + "; benchmark a campaign that splits its runs, e.g. diagnostics_reduced or diagnostics")
    for name, side in (("train", train), ("test", test)):
        healthy = (side["fault"] == "healthy").sum()
        if healthy == 0 or healthy == len(side):
            raise ConfigFileError(f"the {name} split needs healthy and faulty runs (has {len(side)} runs, "
                                  f"{healthy} healthy); check the campaign's split and faults")
    inputs = input_columns(df, feature_set)
    if not inputs:
        what = "health-feature" if feature_set == "paper" else (
            "twin residual feature (twin_*: a campaign with twin_residuals: true)")
        raise ConfigFileError(f"feature table has no {what} columns")
    values = df[inputs].apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    inf = np.isinf(values)
    if inf.any():
        col = int(np.flatnonzero(inf.any(axis=0))[0])
        rows = np.flatnonzero(inf[:, col])
        rid = df["run_id"].iloc[rows[0]] if "run_id" in df else f"row {rows[0]}"
        raise ConfigFileError(f"feature {inputs[col]} is infinite in {rows.size} run(s) with status ok (e.g. {rid}); "
                              "an infinite feature is a broken result, not a measurement: simulate those runs again "
                              "or leave them out")
    # a column without a single value on a side carries nothing to learn or test: left out, and said so
    empty: dict[str, str] = {}
    for name, side in (("train", train), ("test", test)):
        for c in inputs:
            if side[c].isna().all():
                empty.setdefault(c, f"no value in the {name} split")
    inputs = [c for c in inputs if c not in empty]
    if not inputs:
        raise ConfigFileError("feature table has no health-feature columns with values")
    return Dataset(train, test, tuple(inputs), {str(k): int(v) for k, v in n_dropped.items()}, empty)


def refuse_life_folder(path: Path) -> None:
    """Refuse a life campaign's output folder (its inspections, or a manifest of kind ``life``) in one line naming
    the command that benchmarks it: it holds no feature table of runs."""
    import json

    if not path.is_dir() or (path / "features.parquet").exists():
        return
    life = (path / "inspections.parquet").exists()
    try:
        life = life or json.loads((path / "manifest.json").read_text()).get("kind") == "life"
    except (OSError, ValueError, AttributeError):
        pass
    if life:
        raise ConfigFileError(f"{path}: a life campaign's folder (inspections over the units' lives, no feature "
                              f"table of runs); `ur5fault prognose {path}` benchmarks it")

"""What a life-campaign folder holds, built on the campaign store (ur5fault/campaign/store.py).

- ``OUT/runs/<unit_id>_i<k>.parquet``: one inspection (one row), written atomically with its
  identity in the schema metadata and verified before use (``store.check_run_file``);
- ``OUT/reference/<unit_id>.parquet``: the TCP path of the unit's inspection 0 (no wear), the
  healthy reference of its ``tcp_dev_*`` features (``store.check_timeseries_file``);
- ``OUT/inspections.parquet``: every inspection of every unit, with ``rul_cycles`` and ``failed``;
- ``OUT/manifest.json``, ``OUT/.lock`` as for any campaign.

The identity of an inspection covers the versions, model and parameter set of the simulator,
the log period, the fleet seed, the wear law, the inspection interval, the failure criterion, the
unit's task and the inspection's number: a unit's state at inspection k follows from these alone
(its earlier inspections are recomputed from the same inputs), so equal identities mean equal rows.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ...campaign.identity import DRIVE, STEPPER, digest, file_sha256
from ...campaign.store import FileCheck, check_run_file, check_timeseries_file, run_path, write_run_file
from ...sim import SIM_REVISION
from ...util import provenance
from ...util.io import write_parquet_atomic
from .spec import LifeCampaign, Unit

IDENTITY_FORMAT = 1
#: units of the columns a life campaign adds to the health features
LIFE_UNITS = {
    "unit_id": "-", "inspection": "-", "cycles": "cycles", "split": "-", "trajectory": "-", "payload_kg": "kg",
    "temperature_C": "degC", "seed": "-", "failed": "-", "status": "-", "reason": "-", "rul_cycles": "cycles",
    "eol_cycles": "cycles", "censored": "-", "life_fraction": "-",
    **{f"{c}_j{j}": u for j in range(1, 7) for c, u in (("backlash_deg", "deg"), ("friction_scale", "-"),
                                                          ("stiffness_scale", "-"), ("gear_work_J", "J"))},
}


#: the subfolders a life campaign writes (as :data:`ur5fault.campaign.store.SUBFOLDERS` a fault campaign's)
SUBFOLDERS = ("runs", "reference")


def run_id(unit: Unit, k: int) -> str:
    return f"{unit.unit_id}_i{k:04d}"


def reference_path(out: Path, unit: Unit) -> Path:
    return Path(out) / "reference" / f"{unit.unit_id}.parquet"


class LifeIdentities:
    """Identity records of a life campaign's inspections (the shared part hashed once)."""

    def __init__(self, camp: LifeCampaign) -> None:
        import mujoco

        from ...sim.engine import DEFAULT_MODEL_PATH
        from ...sim.params import load_params

        self.common = {
            "identity_format": IDENTITY_FORMAT, "ur5fault_version": provenance.package_version(),
            "sim_revision": SIM_REVISION, "mujoco_version": mujoco.__version__,
            "model_sha256": file_sha256(Path(DEFAULT_MODEL_PATH)), "drive": DRIVE, "stepper": STEPPER,
            "log_period_s": camp.log_period_s, "duration_s": camp.duration_s, "params": load_params().to_dict(),
            "fleet_seed": camp.seed,
            "interval_cycles": camp.interval_cycles, "failure": dataclasses.asdict(camp.failure),
            "wear": dataclasses.asdict(camp.wear),
        }
        self._common_digest = digest(self.common)

    @staticmethod
    def _own(unit: Unit, k: int) -> dict[str, Any]:
        return {"unit": {"index": unit.index, "trajectory": unit.trajectory, "payload_kg": unit.payload_kg,
                         "temperature_C": unit.temperature_C}, "inspection": k}

    def identity(self, unit: Unit, k: int) -> str:
        return digest({"common": self._common_digest, **self._own(unit, k)})

    def record(self, unit: Unit, k: int) -> dict[str, Any]:
        return {"run_id": run_id(unit, k), "identity": self.identity(unit, k),
                "inputs": {**self.common, **self._own(unit, k)}}


def check_inspection(out: Path, ids: LifeIdentities, unit: Unit, k: int) -> FileCheck:
    return check_run_file(run_path(out, run_id(unit, k)), ids.record(unit, k))


def read_inspection(out: Path, unit: Unit, k: int) -> dict[str, Any]:
    import pyarrow.parquet as pq

    return pq.read_table(run_path(out, run_id(unit, k))).to_pylist()[0]


def write_inspection(out: Path, ids: LifeIdentities, unit: Unit, row: Mapping[str, Any]) -> None:
    write_run_file(out, row, ids.record(unit, int(row["inspection"])))


def write_reference(out: Path, ids: LifeIdentities, unit: Unit, t_s: np.ndarray, tcp_m: np.ndarray) -> None:
    df = pd.DataFrame({"t_s": t_s, "tcp_x_m": tcp_m[:, 0], "tcp_y_m": tcp_m[:, 1], "tcp_z_m": tcp_m[:, 2]})
    meta = {"run_identity": ids.identity(unit, 0), "units": {"t_s": "s", "tcp_x_m": "m", "tcp_y_m": "m",
                                                             "tcp_z_m": "m"}}
    write_parquet_atomic(df, reference_path(out, unit), {"ur5fault": json.dumps(meta)}, checksum=True)


def check_reference(out: Path, ids: LifeIdentities, unit: Unit, n_log: int) -> FileCheck:
    return check_timeseries_file(reference_path(out, unit), ids.identity(unit, 0), n_log)


def read_reference(out: Path, ids: LifeIdentities, unit: Unit, n_log: int) -> np.ndarray | None:
    """The unit's reference TCP path ``(n_log, 3)`` [m], or None when absent, bad or made under other settings."""
    path = reference_path(out, unit)
    if check_reference(out, ids, unit, n_log).state != "ok":
        return None
    df = pd.read_parquet(path)
    return df[["tcp_x_m", "tcp_y_m", "tcp_z_m"]].to_numpy()


def add_life_labels(df: pd.DataFrame) -> pd.DataFrame:
    """Ground truth per unit: ``eol_cycles`` (cycles at its first failed inspection), ``rul_cycles`` =
    eol - cycles, ``life_fraction`` = cycles / eol; a unit that never failed is ``censored`` (NaN labels)."""
    df = df.sort_values(["unit_id", "inspection"]).reset_index(drop=True)
    eol = df[df["failed"]].groupby("unit_id")["cycles"].min()
    df["eol_cycles"] = df["unit_id"].map(eol).astype(float)
    df["censored"] = df["eol_cycles"].isna()
    df["rul_cycles"] = df["eol_cycles"] - df["cycles"]
    df["life_fraction"] = df["cycles"] / df["eol_cycles"]
    return df


def consolidate_life(out: Path, ids: LifeIdentities, done: Mapping[Unit, int]) -> pd.DataFrame:
    """Gather inspections 0..k of every unit (``done``: unit -> its last inspection), each file
    verified, into ``OUT/inspections.parquet`` with the ground-truth labels.  The split is a label,
    not a result: it follows the campaign's current split (fleet size, fraction, seed)."""
    import pyarrow.parquet as pq

    from ...campaign.store import CampaignChangedError, column_units

    frames, identities = [], {}
    for unit in sorted(done, key=lambda u: u.index):
        for k in range(done[unit] + 1):
            check = check_inspection(out, ids, unit, k)
            path = run_path(out, run_id(unit, k))
            if check.state != "ok":
                raise CampaignChangedError(f"{path}: {check.state}{': ' + check.detail if check.detail else ''}; "
                                           "run the life campaign again to re-simulate it")
            frames.append(pq.read_table(path).to_pandas())
            identities[run_id(unit, k)] = ids.identity(unit, k)
    df = pd.concat(frames, ignore_index=True)
    df["split"] = df["unit_id"].map({u.unit_id: u.split for u in done})
    df = add_life_labels(df)
    units = {**column_units(df.columns), **{c: u for c, u in LIFE_UNITS.items() if c in df.columns}}
    meta = {"units": units, "campaign_identity": digest(identities), "run_identities": identities}
    write_parquet_atomic(df, Path(out) / "inspections.parquet", {"ur5fault": json.dumps(meta, sort_keys=True)},
                         checksum=True)
    return df

def life_stats(eol: pd.Series) -> dict[str, float | None]:
    """Median, least and largest end of life [cycles] of the units that failed; None each when none did (strict
    JSON has no NaN, and a fleet censored at max_cycles has no life to state)."""
    failed = eol.dropna()
    if failed.empty:
        return {"median": None, "min": None, "max": None}
    return {"median": float(failed.median()), "min": float(failed.min()), "max": float(failed.max())}

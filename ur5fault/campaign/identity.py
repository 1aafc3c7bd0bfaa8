"""Run identity: everything that decides a run's result, taken from *resolved* values and hashed.

The identity of a campaign run covers the ur5fault and MuJoCo versions, the simulator's revision
(``ur5fault.sim.SIM_REVISION``), the SHA-256 of the MJCF
model file, the drive implementation and stepper, the trajectory (its options and a hash of the
setpoints it produces), the simulated duration, the log period, the noise seed, the full list of
effects the run carries (base effects, swept faults, payload, temperature; in the order applied)
and the full resolved robot parameter set (packaged defaults + campaign ``base.params`` + ``--model``
overlay, which includes the physics step).  A run's features also depend on its healthy twin,
whose inputs are the run's minus its swept faults, so the run's identity covers the twin's too; the
same holds for the digital twin of ``twin_residuals`` (campaign/digital_twin.py), whose format is
recorded.

``run_id`` (the file name, a hash of the run's conditions and faults) names a run within a
campaign; the identity says whether a stored result was made under the same settings.  Both are
recorded in each per-run file (Parquet schema metadata, key ``ur5fault``) with the inputs, so a
mismatch can be explained by naming the first input that differs.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..config import parse_trajectory
from ..sim import SIM_REVISION
from ..sim.effects import EffectSpec, effects_of_keys, make_effect
from ..sim.params import load_params
from ..util import provenance
from ..util.checks import short
from .runs import CampaignRun
from .spec import Campaign

IDENTITY_FORMAT = 1
#: how inputs are compared, in this order, to name the first difference
INPUT_ORDER = ("identity_format", "ur5fault_version", "sim_revision", "mujoco_version", "model_sha256", "drive",
               "stepper", "trajectory", "duration_s", "log_period_s", "seed", "effects", "params", "twin_residuals",
               "motor_encoders")
#: version of the digital twin and its features (health/twin_features.py), recorded when a campaign has them
#: (2: the current fit over all joints with the payload CoM and latency held out, standard errors and t values;
#: 3: the fits' current and gear-torque regressors from noise-free twins, health/twin_regressors.py; 4: the current
#: fit's payload CoM columns from noise-free twins with the CoM shifted, not the gravity torque in closed form: the
#: campaign option ``twin_com_twins``, recorded as format 4 where it is on; campaigns without it stay format 3;
#: 5 (6 with ``twin_com_twins``): format 3 (4) plus each joint's gear-torque flank share,
#: ``twin_gear_flank_share_j<k>``: where the motion reverses the gear torque; 7 (8 with ``twin_com_twins``):
#: format 5 (6) with the fits' columns kept or left out by their singular values from a QR factorisation, not by
#: the eigenvalues of the normal matrix, which rounding decided at the mismatch fit's ``rcond``: health/twin_fit.py;
#: 9 (10 with ``twin_com_twins``): format 7 (8) plus each joint's current-noise ratio at rest,
#: ``twin_current_noise_ratio_rest_j<k>``, which tell a current-sensor gain from a torque-constant loss;
#: 11 (12 with ``twin_com_twins``): format 9 (10) with the mismatch fit's columns and the flank shares read off the
#: twin's gear torque with the payload CoM the current fit found fed back, twin_fit.com_corrected_torque)
TWIN_RESIDUALS_FORMAT = 11
TWIN_RESIDUALS_FORMAT_COM_TWINS = 12


def twin_format_of(com_twins: bool) -> int:
    """The twin residual features' version this ur5fault computes, with or without CoM twins."""
    return TWIN_RESIDUALS_FORMAT_COM_TWINS if com_twins else TWIN_RESIDUALS_FORMAT


def twin_format(camp: Campaign) -> int | None:
    """The twin residual features' version a campaign computes; None without them."""
    return twin_format_of(camp.twin_com_twins) if camp.twin_residuals else None
#: the simulator configuration campaigns run with: passed to the engine by every campaign kind
#: (campaign/execute.py, health/prognostics/life_inspection.py) and recorded here, so the identity names what ran
DRIVE, STEPPER = "numba", "compiled"


def run_effects(camp: Campaign, rc: CampaignRun) -> tuple[EffectSpec, ...]:
    """Every effect a campaign run carries, in the order they are applied."""
    c = rc.cond
    return camp.base_effects + rc.fault_effects() + (
        make_effect("payload", mass_kg=c["payload_kg"]),
        make_effect("temperature", temperature_C=c["temperature_C"]),
    ) + condition_effects(c)


def condition_effects(cond: Mapping[str, Any]) -> tuple[EffectSpec, ...]:
    """Whole-robot effects held as run conditions (``<effect>.<param>`` keys, e.g. a sampled campaign's
    ``payload_com.dz_m`` or ``delay.delay_ms``): shared with the healthy twin, not faults."""
    return effects_of_keys(cond.items())


def file_sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def digest(inputs: Mapping[str, Any]) -> str:
    """SHA-256 of the canonical JSON of ``inputs``."""
    return hashlib.sha256(json.dumps(inputs, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


class Identities:
    """Identity inputs and hashes of the runs of one campaign (trajectories resolved once)."""

    def __init__(self, camp: Campaign) -> None:
        import mujoco

        from ..sim.engine import DEFAULT_MODEL_PATH

        self.camp = camp
        model = Path(DEFAULT_MODEL_PATH)
        self.common = {
            "identity_format": IDENTITY_FORMAT,
            "ur5fault_version": provenance.package_version(),
            "sim_revision": SIM_REVISION,
            "mujoco_version": mujoco.__version__,
            "model_sha256": file_sha256(model),
            "drive": DRIVE,
            "stepper": STEPPER,
            "log_period_s": camp.log_period_s,
            "params": load_params(overrides=dict(camp.base_params)).to_dict(),
        }
        if camp.twin_residuals:  # only then: the identities of campaigns without twins stay as they were
            self.common["twin_residuals"] = twin_format(camp)
        if not camp.motor_encoders:  # likewise: recorded only when the runs are logged without them
            self.common["motor_encoders"] = False
        self._common_digest = digest(self.common)
        self._traj: dict[str, tuple[dict[str, Any], float]] = {}

    def _trajectory(self, spec: Any) -> tuple[dict[str, Any], float]:
        key = json.dumps(spec, sort_keys=True)
        if key not in self._traj:
            traj = parse_trajectory(spec, "trajectory")
            h = hashlib.sha256(traj.q_set_rad.tobytes())
            h.update(json.dumps([traj.setpoint_period_s, traj.payload_events, traj.payload_gripped_at_start,
                                 traj.default_payload_kg]).encode())
            self._traj[key] = ({"spec": spec, "setpoints_sha256": h.hexdigest()}, traj.duration_s)
        return self._traj[key]

    def _own(self, rc: CampaignRun) -> dict[str, Any]:
        traj, traj_duration = self._trajectory(rc.cond["trajectory"])
        return {
            "trajectory": traj,
            "duration_s": self.camp.duration_s if self.camp.duration_s is not None else traj_duration,
            "seed": rc.cond["seed"],
            "effects": [[e.name, e.joint, dict(e.values)] for e in run_effects(self.camp, rc)],
        }

    def inputs(self, rc: CampaignRun) -> dict[str, Any]:
        """Everything that decides ``rc``'s result (JSON-able)."""
        return {**self.common, **self._own(rc)}

    def identity(self, rc: CampaignRun) -> str:
        """SHA-256 of the inputs (the shared part hashed once per campaign)."""
        return digest({"common": self._common_digest, **self._own(rc)})

    def duration_s(self, rc: CampaignRun) -> float:
        return float(self._own(rc)["duration_s"])

    def record(self, rc: CampaignRun) -> dict[str, Any]:
        """What a per-run file records about its run: run_id, identity and the inputs."""
        own = self._own(rc)
        return {"run_id": rc.run_id, "identity": digest({"common": self._common_digest, **own}),
                "inputs": {**self.common, **own}}


def first_difference(recorded: Any, expected: Any, path: str = "", was: str = "the file") -> str | None:
    """``"duration_s: 1.5 in the file, 0.7 now"`` for the first input that differs, else None; ``was`` names where
    ``recorded`` is kept (a run file; or a folder's manifest, for the campaigns themselves)."""
    if isinstance(recorded, Mapping) and isinstance(expected, Mapping):
        keys = [k for k in INPUT_ORDER if k in recorded or k in expected] if not path else []
        keys += sorted((set(recorded) | set(expected)) - set(keys), key=str)
        for k in keys:
            if k not in recorded or k not in expected:
                side = was if k not in recorded else "this campaign"
                return f"{path}{k}: absent from {side}"
            d = first_difference(recorded[k], expected[k], f"{path}{k}.", was)
            if d:
                return d
        return None
    if isinstance(recorded, list) and isinstance(expected, list):
        base = 1 if path.startswith(("params.", "base.params.")) else 0  # per-joint parameters count joints from 1
        for i, (a, b) in enumerate(zip(recorded, expected)):
            d = first_difference(a, b, f"{path.rstrip('.')}[{i + base}].", was)
            if d:
                return d
        if len(recorded) != len(expected):
            return f"{path.rstrip('.')}: {len(recorded)} entries in {was}, {len(expected)} now"
        return None
    if json.dumps(recorded, sort_keys=True) != json.dumps(expected, sort_keys=True):
        return f"{path.rstrip('.')}: {short(recorded)} in {was}, {short(expected)} now"
    return None

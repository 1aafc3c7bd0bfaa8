"""The campaign manifest: provenance of a campaign folder (see docs/outputs.md)."""

from __future__ import annotations

import hashlib
import json
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..sim.params import load_params
from ..util import provenance
from .identity import Identities, file_sha256, twin_format
from .spec import Campaign


def build_manifest(camp: Campaign, ids: Identities, features, state: str, backend: str, jobs: int, save_ts: bool,
                   t0: float, earlier: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """``OUT/manifest.json``: what was run (the campaign's text and validated mapping, its identity),
    with what (model hash, parameter hash, ur5fault version, git revision, every dependency's
    version), and how (backend, jobs, wall time); ``state`` is ``running`` until the end.

    ``earlier``: this invocation's manifest written at the start; its git revision and dependency versions are
    kept (the software that ran is the one imported at the start) instead of being looked up again: walking the
    installed packages' metadata costs about 60 ms of CPU and the revision two ``git`` processes."""
    import mujoco

    from ..health.features import FEATURE_UNITS
    from ..sim.engine import DEFAULT_MODEL_PATH
    from ..util.provenance import dependency_versions, git_revision
    from .identity import digest

    p = load_params(overrides=dict(camp.base_params))
    durations = [ids.duration_s(rc) for rc in camp.runs]
    identities = {rc.run_id: ids.identity(rc) for rc in sorted(camp.runs, key=lambda r: r.run_id)}
    m: dict[str, Any] = {
        "name": camp.name,
        "state": state,
        "campaign_file": str(Path(camp.path).resolve()) if camp.path else None,  # from any folder: the advice's
        # command-line options beyond the file (--model, --duration-s): what a rerun must repeat
        "command_options": dict(camp.command_options),
        "campaign_sha256": camp.sha256,
        "campaign_text": camp.text,
        "campaign_data": camp.data,
        "campaign_identity": digest(identities),
        "model_file": str(DEFAULT_MODEL_PATH),
        "model_sha256": file_sha256(DEFAULT_MODEL_PATH),
        "params_sha256": hashlib.sha256(json.dumps(p.to_dict(), sort_keys=True).encode()).hexdigest(),
        "ur5fault_version": provenance.package_version(),
        "git_revision": earlier["git_revision"] if earlier is not None else git_revision(),
        "mujoco_version": mujoco.__version__,
        "numpy_version": np.__version__,
        "python": sys.version.split()[0],
        "dependencies": earlier["dependencies"] if earlier is not None else dependency_versions(),
        # the machine's CPU and BLAS kernel: the twin residual fits' last bits depend on them (provenance.numerics)
        "numerics": earlier["numerics"] if earlier is not None else provenance.numerics(),
        "n_runs": len(camp.runs) if features is None else int(len(features)),
        "physics_dt_s": p.physics_dt_s,
        "duration_s": max(durations),
        "n_steps_total": int(sum(round(d / p.physics_dt_s) for d in durations)),
        "log_period_s": camp.log_period_s,
        "motor_encoders": camp.motor_encoders,
        # the version of the twin residual features (identity.TWIN_RESIDUALS_FORMAT); None without them
        "twin_residuals_format": twin_format(camp),
        "threshold_mm": camp.threshold_mm,
        "swept_keys": list(camp.swept_keys),
        "save_timeseries": save_ts,
        "wall_s_this_invocation": time.perf_counter() - t0,
        "backend": backend,
        "jobs": jobs,
        "feature_units": dict(FEATURE_UNITS),
    }
    if features is not None:
        m["status_counts"] = {str(k): int(v) for k, v in features["status"].value_counts().items()}
    return m


def recorded_campaign(manifest: Mapping[str, Any], out: str | Path | None = None) -> Campaign | None:
    """The campaign a folder's manifest records, rebuilt and validated by this ur5fault (the one place that does:
    the scan of an edited campaign, ``campaign verify`` and a re-simulation for ``plot`` / ``show --campaign``).

    From its validated mapping ``campaign_data``, else (older manifests) its YAML text ``campaign_text``; None
    where it holds neither. A campaign that does not validate raises its own one-line error (Ur5FaultError)."""
    from ..util import yamlsafe
    from .spec import build_campaign

    text = manifest.get("campaign_text")
    text = text if isinstance(text, str) else ""
    data = manifest.get("campaign_data")
    if not isinstance(data, dict):
        if not text.strip():
            return None
        data = yamlsafe.loads(text, "manifest.json: campaign_text")
    return build_campaign(data, "manifest.json", text, None, out, model_effects=None)

"""A synthetic fleet whose clearances grow linearly and whose failure boundary is known in closed form,
shared by the clearance- and twin-boundary RUL tests."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ur5fault.health.prognostics.joint_index import JOINTS

STEP = 500.0
#: failure boundary of the synthetic fleet: b2 + 5 b3 >= 1 [deg] (the elbow weighs more, as a lever arm)
LEVER = {2: 1.0, 3: 5.0}
NOISE_DEG = 2e-3


def linear_wear_fleet(n_units: int, seed: int, prefix: str) -> pd.DataFrame:
    """Units whose clearances of joints 2 and 3 grow linearly, b_j = r_j N, at lognormal rates (sigma 0.3,
    independent per joint, so some units are shoulder-led and some elbow-led); the feature of joint j reads
    2 b_j plus Gaussian noise (sd 2 NOISE_DEG); a unit fails at the first inspection with b2 + 5 b3 >= 1,
    that is after N* = 1 / (r2 + 5 r3) cycles, so its true RUL is known in closed form."""
    rng = np.random.default_rng(seed)
    rows = []
    for u in range(n_units):
        r = {2: 1e-5 * np.exp(0.3 * rng.standard_normal()), 3: 1e-5 * np.exp(0.3 * rng.standard_normal())}
        n_star = 1.0 / sum(LEVER[j] * r[j] for j in LEVER)
        eol = np.ceil(n_star / STEP) * STEP
        for k in range(int(eol / STEP) + 1):
            n = k * STEP
            row = {"unit_id": f"{prefix}{u:03d}", "inspection": k, "cycles": n, "trajectory": "task",
                   "eol_cycles": eol, "rul_cycles": eol - n}
            for j in JOINTS:
                b = r.get(j, 0.0) * n
                row[f"backlash_deg_j{j}"] = b
                row[f"enc_mismatch_hyst_rad_j{j}"] = 2.0 * b + 2.0 * NOISE_DEG * rng.standard_normal()
            rows.append(row)
    return pd.DataFrame(rows)

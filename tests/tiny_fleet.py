"""The tiny life campaign the fleet and status tests share: 3 units on the first 1.5 s of the pick-and-place
(the shoulder's first move), a fast wear rate and a 0.05 mm criterion, so each unit fails within a few
inspections."""

from __future__ import annotations

import pyarrow.parquet as pq

TINY = {"name": "tiny", "duration_s": 1.5, "batch_size": 4,
        "life": {"units": 3, "seed": 4, "interval_cycles": 100_000, "max_cycles": 1_500_000,
                 "failure": {"feature": "tcp_dev_max_mm", "threshold": 0.05},
                 "wear": {"backlash_rate_deg_per_MJ": 0.01},
                 "duty": {"trajectories": ["pick_and_place"], "payload_kg": [0.5, 2.0]}},
        "split": {"test_fraction": 0.34, "seed": 0}}


def run_tables(folder):
    """Every stored inspection and reference file of a fleet folder, by name, as Arrow tables."""
    return {p.name: pq.read_table(p) for p in sorted((folder / "runs").glob("*.parquet"))}

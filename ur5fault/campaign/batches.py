"""The lockstep batches of a campaign: which runs are simulated together (a batch shares one trajectory)."""

from __future__ import annotations

import json
from collections.abc import Sequence

from .runs import CampaignRun
from .spec import Campaign


def plan_batches(camp: Campaign, todo: Sequence[CampaignRun], n_workers: int = 1) -> list[list[CampaignRun]]:
    """Group runs by trajectory, cut into lockstep batches (at most ``batch_size`` runs, and at
    least ``n_workers`` batches when there are enough runs), and add each batch's missing twins
    (those the campaign lists: every twin of a swept campaign, the chosen ones of a sampled one)."""
    listed = {rc.run_id for rc in camp.runs}  # a twin is simulated when the campaign lists it
    by_traj: dict[str, list[CampaignRun]] = {}
    for rc in todo:
        by_traj.setdefault(json.dumps(rc.cond["trajectory"], sort_keys=True), []).append(rc)
    batches = []
    for runs in by_traj.values():
        runs = sorted(runs, key=lambda r: (json.dumps(r.conditions, default=str), r.run_id))
        size = max(1, min(camp.batch_size - 1, -(-len(runs) // max(1, n_workers))))
        for i in range(0, len(runs), size):
            chunk = runs[i : i + size]
            ids = {r.run_id for r in chunk}
            for r in list(chunk):
                t = r.twin()
                if t.run_id not in ids and t.run_id in listed:
                    chunk.append(t)
                    ids.add(t.run_id)
            batches.append(chunk)
    return batches

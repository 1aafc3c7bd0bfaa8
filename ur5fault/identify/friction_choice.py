"""How the friction defaults that only a simulation can decide were chosen on a real log: replay the
log's targets under the nominal model with each candidate and compare the simulated motor current with
the measured one (RMS of the difference over the held-out last 40 %, at rest, near velocity reversals;
:mod:`ur5fault.twin`'s replay and conditions).

Decided this way (``data/ur5_drive.yaml``, tagged [nist]): the friction law (``friction.model``), the
motor-side share of friction (``friction.motor_side_share``) and the presliding stiffness
(``friction.presliding_stiffness_Nm_per_rad``, as a multiple of the default).  ``bench/nist_friction_choice.py``
prints the full tables; ``tests/identify/test_friction_choice.py`` re-derives the choices.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..logs import MeasuredLog
from ..sim.effects import make_effect
from ..twin.replay import LogReplay
from ..twin.residuals import conditions, held_out_mask, masked_rms

#: noise seed of the replays
REPLAY_SEED = 1


def _masks(log: MeasuredLog, n: int) -> dict[str, np.ndarray]:
    masks = conditions(log, n, log.current_A[1 : n + 1])
    return {"held_out": held_out_mask(n), "at_rest": masks["at rest"],
            "near_reversals": masks["near velocity reversals"]}


def replay(log: MeasuredLog, friction: Mapping[str, Any] | None, cases: Sequence[Mapping[str, float]]
           ) -> list[dict[str, Any]]:
    """Replay once per case (``{"s0": scale}`` presliding stiffness, ``{"share": value}`` motor-side share,
    on every joint) with ``friction`` overriding the packaged friction parameters; per case the current
    RMS [A] per joint under each condition, and the same for UR's own model as the last entry."""
    rp = LogReplay(log, {"friction": dict(friction)} if friction else None, seed=REPLAY_SEED)
    effect_sets = []
    for c in cases:
        eff = []
        for j in range(1, 7):
            if "s0" in c:
                eff.append(make_effect("presliding_stiffness", j, scale=c["s0"]))
            if "share" in c:
                eff.append(make_effect("friction_share", j, motor_side_share=c["share"]))
        effect_sets.append(eff)
    sims = rp.run(effect_sets)
    n = rp.n_samples
    meas = log.current_A[1 : n + 1]
    sel = _masks(log, n)

    def rms(x: np.ndarray, m: np.ndarray) -> list[float]:
        return masked_rms(x, m).round(4).tolist()

    near = sel["near_reversals"]
    e_meas = log.q_target_rad[1 : n + 1] - log.q_actual_rad[1 : n + 1]
    out = [{"case": dict(c), "status": sim.status, **{k: rms(sim.current_A - meas, m) for k, m in sel.items()},
            "tracking_near_reversals_sim_over_measured":
                (np.array(rms(log.q_target_rad[1 : n + 1] - sim.position_rad, near)) /
                 np.array(rms(e_meas, near))).round(3).tolist()}
           for c, sim in zip(cases, sims)]
    if log.target_current_A is not None:
        out.append({"case": "UR's model",
                    **{k: rms(log.target_current_A[1 : n + 1] - meas, m) for k, m in sel.items()}})
    return out

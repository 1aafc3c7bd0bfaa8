"""How the friction defaults that only a simulation can decide were chosen on a real log: replay the
log's targets under the nominal model with each candidate and compare the simulated motor current with
the measured one (RMS of the difference over the held-out last 40 %, at rest, near velocity reversals).

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
from ..sim.engine import RunSpec, Simulator
from ..sim.params import deep_merge, load_params

HELD_OUT_FROM = 0.6  # share of the log before the held-out part (the discrepancy workflow's default)
REST_SPEED_RAD_S = 1e-3  # target speed below which a joint is at rest


def _masks(log: MeasuredLog, n: int) -> dict[str, np.ndarray]:
    from ..discrepancy.report import conditions  # the discrepancy workflow's own definition of the conditions

    masks = conditions(log, n, log.current_A[1 : n + 1])
    t = log.t_s[1 : n + 1] - log.t_s[0]
    held = np.broadcast_to((t >= HELD_OUT_FROM * (log.t_s[-1] - log.t_s[0]))[:, None], (n, 6))
    return {"held_out": held, "at_rest": masks["at rest"], "near_reversals": masks["near velocity reversals"]}


def replay(log: MeasuredLog, friction: Mapping[str, Any] | None, cases: Sequence[Mapping[str, float]]
           ) -> list[dict[str, Any]]:
    """Replay once per case (``{"s0": scale}`` presliding stiffness, ``{"share": value}`` motor-side share,
    on every joint) with ``friction`` overriding the packaged friction parameters; per case the current
    RMS [A] per joint under each condition, and the same for UR's own model as the last entry."""
    over: dict[str, Any] = {"tcp_offset_m": list(log.tcp_offset_m)}
    if log.temperature_C is not None:
        over["joint_temperature_C"] = log.temperature_C.mean(axis=0).tolist()
    p = load_params(overrides=deep_merge(over, {"friction": dict(friction)} if friction else {}))
    runs = []
    for i, c in enumerate(cases):
        eff = []
        for j in range(1, 7):
            if "s0" in c:
                eff.append(make_effect("presliding_stiffness", j, scale=c["s0"]))
            if "share" in c:
                eff.append(make_effect("friction_share", j, motor_side_share=c["share"]))
        runs.append(RunSpec(f"c{i}", 1, tuple(eff)))
    res = Simulator(p).run(log.to_trajectory(), runs, log_period_s=log.period_s)
    n = res.t_s.size
    meas = log.current_A[1 : n + 1]
    sel = _masks(log, n)

    def rms(x: np.ndarray, m: np.ndarray) -> list[float]:
        """RMS per joint over the samples in ``m``; NaN for a joint with none (e.g. no reversal)."""
        count = m.sum(axis=0)
        sq = np.where(m, x, 0.0) ** 2
        return np.where(count > 0, np.sqrt(sq.sum(axis=0) / np.maximum(count, 1)), np.nan).round(4).tolist()

    near = sel["near_reversals"]
    e_meas = log.q_target_rad[1 : n + 1] - log.q_actual_rad[1 : n + 1]
    out = [{"case": dict(c), "status": res.status[i], **{k: rms(res["i_FB_A"][i] - meas, m) for k, m in sel.items()},
            "tracking_near_reversals_sim_over_measured":
                (np.array(rms(log.q_target_rad[1 : n + 1] - res["q_FB_rad"][i], near)) /
                 np.array(rms(e_meas, near))).round(3).tolist()}
           for i, c in enumerate(cases)]
    if log.target_current_A is not None:
        out.append({"case": "UR's model",
                    **{k: rms(log.target_current_A[1 : n + 1] - meas, m) for k, m in sel.items()}})
    return out

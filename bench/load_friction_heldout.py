"""Does the effect ``load_friction`` help held out? (issue 17; the evidence: bench/load_friction_evidence.py)

    python bench/load_friction_heldout.py [--cache results/load_friction] [--kufieta-model M.yaml] [--nist-model M.yaml]

Per joint, the coefficient ``mu`` of ``load_friction`` is fitted by linear least squares, alone (no other free
term), on the *fit* part only: the current residual of the packaged model's replay (measured minus model,
converted to joint torque with the model's own current-to-gear-torque gain) regressed on ``sgn(w) |T_gear|``
(the model's gear torque: what the effect scales) on samples at speed (|w| > 3 / stribeck_rate), clipped to the
effect's range.  Kufieta: fitted on ``cross_robot.FIT_RUNS`` (six undisturbed runs), scored on
``cross_robot.HELD_OUT_RUNS``; NIST: fitted on the first 60 %, scored on the last 40 %, both with the discrepancy
workflow's three current offsets (docs/validation.md).  The held-out runs are replayed with and without the
fitted effects; current RMS per joint on the logged ticks, as a multiple of UR's own model on the same ticks.
Needs the cached replays of ``load_friction_evidence.py`` (same ``--cache``).  ``--kufieta-model`` /
``--nist-model``: a model overlay (e.g. the discrepancy workflow's ``model.yaml`` fitted on the same fit part) as the
base instead, its fit-part replays made here; ``mu`` is then fitted on that model's residual and the held-out part
scored with the overlay and the overlay + ``load_friction``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

from load_friction_evidence import _overlay, _replay_arrays, design, gear_gain  # noqa: E402


def fit_mu(runs: list[dict], w_min: float, hi: float) -> list[float]:
    """``mu`` per joint from the fit runs' replays (packaged model), alone, clipped to ``[0, hi]``."""
    out = []
    for j in range(6):
        g = gear_gain(runs, j)
        X = np.concatenate([design(d, j, "tau_gear", w_min, g)[0][:, 4] for d in runs])
        y = np.concatenate([design(d, j, "tau_gear", w_min, g)[1] for d in runs])
        out.append(float(np.clip(np.dot(X, y) / np.dot(X, X), 0.0, hi)) if X.size >= 200 else 0.0)
    return out


def main(argv=None) -> int:
    from cross_robot import FIT_RUNS, HELD_OUT_RUNS, NIST_FIT_FRACTION, NIST_LOG, NIST_OFFSETS_A, read, score

    from ur5fault.logs import read_nist
    from ur5fault.sim.effects import REGISTRY, make_effect
    from ur5fault.sim.params import load_params

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", default=str(REPO / "results" / "load_friction"))
    ap.add_argument("--kufieta-model", default=None)
    ap.add_argument("--nist-model", default=None)
    args = ap.parse_args(argv)
    cache = Path(args.cache)
    w_min = 3.0 / load_params().friction.stribeck_rate_s_per_rad
    hi = REGISTRY["load_friction"].param("coeff").hi
    f = lambda v: " / ".join(f"{x:.2f}" for x in v)  # noqa: E731

    k_over, k_eff, k_label = None, (), "packaged"
    if args.kufieta_model:
        k_over, k_eff = _overlay(Path(args.kufieta_model))
        k_label = Path(args.kufieta_model).parent.name
        fit = [_replay_arrays(read(n), k_over, k_eff) for n in FIT_RUNS]
    else:
        fit = [dict(np.load(cache / f"kufieta_packaged_{n}.npz")) for n in FIT_RUNS]
    mu = fit_mu(fit, w_min, hi)
    print(f"Kufieta ({k_label}): mu fitted on {', '.join(FIT_RUNS)}: "
          + ", ".join(f"J{j + 1} {m:.4f}" for j, m in enumerate(mu)))
    effs = tuple(make_effect("load_friction", j + 1, coeff=m) for j, m in enumerate(mu) if m > 0)
    print("\n| held-out run | model | ratio to UR's J1..J6 | RMS [A] J1..J6 |\n| --- | --- | --- | --- |")
    for name in HELD_OUT_RUNS:
        log = read(name)
        for label, e in ((k_label, k_eff), ("+ load_friction", k_eff + effs)):
            s = score(log, k_over, e)
            print(f"| {name} | {label} | {f(s['ratio'])} | {f(s['model_A'])} |", flush=True)

    log = read_nist(NIST_LOG)
    offsets = tuple(make_effect("current_sensor_offset", j, offset_A=v) for j, v in NIST_OFFSETS_A.items())
    n_over, n_label = None, "packaged + offsets"
    if args.nist_model:
        n_over, offsets = _overlay(Path(args.nist_model))
        n_label = Path(args.nist_model).parent.name
        nist = _replay_arrays(log, n_over, offsets)
    else:
        nist = dict(np.load(cache / "nist_fit.npz"))
    t_end = nist["t"][-1]
    for k in ("keep",):
        nist[k] = nist[k] & (nist["t"] < NIST_FIT_FRACTION * t_end)
    mu_n = fit_mu([nist], w_min, hi)
    print(f"\nNIST ({n_label}): mu fitted on the first 60 %: "
          + ", ".join(f"J{j + 1} {m:.4f}" for j, m in enumerate(mu_n)))
    effs_n = tuple(make_effect("load_friction", j + 1, coeff=m) for j, m in enumerate(mu_n) if m > 0)
    from_s = NIST_FIT_FRACTION * (log.t_s[-1] - log.t_s[0])
    print("\n| NIST held-out last 40 % | ratio to UR's J1..J6 | RMS [A] J1..J6 |\n| --- | --- | --- |")
    for label, e in ((n_label, offsets), ("+ load_friction", offsets + effs_n)):
        s = score(log, n_over, e, from_s=from_s)
        print(f"| {label} | {f(s['ratio'])} | {f(s['model_A'])} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

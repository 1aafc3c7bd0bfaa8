"""Is a strain-wave gear's load-dependent friction in the real robots' current residual? (issue 17)

    python bench/load_friction_evidence.py [--fit-model /tmp/s31/kuf9/model.yaml] [--cache results/load_friction]
                                           [--recompute] [--min-speed-rad-s W]

Harmonic (strain-wave) drives lose more torque to friction the more torque they carry: their Coulomb level grows
with the transmitted torque, ``T_f = sgn(w) (T_c + mu |tau|) + f_v w`` (e.g. Madsen et al. 2020, identified on UR
robots).  The model's eq. (2) has no such term.  This script asks whether the measured current wants one.

1. *Replays* (cached as ``.npz``): every Kufieta run (payload 0 kg, TCP at the flange, as ``bench/cross_robot.py``)
   under the packaged model and under a fitted overlay (``--fit-model``: the discrepancy workflow's joint fit of the
   nine runs), and the NIST log under the packaged model and under the workflow's three current offsets
   (docs/validation.md).  Each replay keeps the measured and simulated current, the simulated gear torque (the
   transmitted torque ``tau``), UR's target torque (its gravity + inertia model: the proxy) and the speeds.
2. *Regression*, per joint and robot, on samples at speed (|target speed| and |measured speed| above ``W``, same
   sign; ``W`` defaults to ``3 / stribeck_rate`` = 0.3 rad/s, where eq. (2)'s Stribeck part is below 0.5 % of its
   excess): the current residual (measured minus replay), converted to joint torque with the model's own
   current-to-gear-torque gain (slope of the simulated gear torque on the simulated current, which also carries the
   joint's current sign), regressed on ``[1, sgn(w), w, tau, sgn(w) |tau|]``.  The last coefficient is ``mu``
   [N*m of friction per N*m carried]: physical when positive (friction opposes the motion and grows with load).
   ``tau`` itself is a regressor so that a torque-constant or mass error (a residual proportional to ``tau``) is
   not read as load-dependent friction.
3. *Significance*: the pooled ``mu`` with a leave-one-run-out jackknife standard error (Kufieta; runs with fewer
   than 200 samples at speed on the joint are left out) or a 10-block time jackknife (NIST, one log), and ``mu``
   fitted on each run alone (its spread across runs).

Samples are the ticks the robot logged, the first 0.5 s of each run left out.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

SKIP_S = 0.5
MIN_RUN_SAMPLES = 200
NIST_BLOCKS = 10
REGRESSORS = ("1", "sgn(w)", "w", "tau", "sgn(w)|tau|")


def _overlay(path: Path):
    from cross_robot import effects_of

    from ur5fault.util.yamlsafe import read_yaml

    doc = read_yaml(path)
    return dict(doc.get("params") or {}), effects_of(doc.get("effects"))


def _replay_arrays(log, overrides, effects) -> dict:
    from ur5fault.discrepancy.model import WORKFLOW_SEED
    from ur5fault.twin import LogReplay

    rp = LogReplay(log, overrides, seed=WORKFLOW_SEED)
    n = rp.n_samples
    r = rp.run([tuple(effects)], n)[0]
    t = log.t_s[1 : n + 1] - log.t_s[0]
    w_target = np.gradient(log.q_target_rad, log.t_s, axis=0)[1 : n + 1]
    w_actual = np.gradient(log.q_actual_rad, log.t_s, axis=0)[1 : n + 1]
    tau_ur = log.target_torque_Nm[1 : n + 1] if log.target_torque_Nm is not None else np.full((n, 6), np.nan)
    keep = log.logged_rows()[1 : n + 1] & (t >= SKIP_S)
    return {"t": t, "w_target": w_target, "w_actual": w_actual, "tau_gear": r.torque_gear_Nm,
            "tau_ur": np.nan_to_num(tau_ur), "i_true": r.current_true_A, "sim": r.y[:, 0],
            "meas": log.current_A[1 : n + 1], "keep": keep, "status": np.array(r.status)}


def compute(cache: Path, fit_model: Path) -> None:
    from cross_robot import KUFIETA, NIST_LOG, NIST_OFFSETS_A, read

    from ur5fault.logs import read_nist
    from ur5fault.sim.effects import make_effect

    cache.mkdir(parents=True, exist_ok=True)
    fit_over, fit_eff = _overlay(fit_model)
    for name in sorted(p.name.split(".")[0] for p in KUFIETA.glob("*.csv.gz")):
        log = read(name)
        for label, over, eff in (("packaged", None, ()), ("fit", fit_over, fit_eff)):
            print(f"replaying {name} ({label})", file=sys.stderr, flush=True)
            np.savez(cache / f"kufieta_{label}_{name}.npz", **_replay_arrays(log, over, eff))
    log = read_nist(NIST_LOG)
    offsets = tuple(make_effect("current_sensor_offset", j, offset_A=v) for j, v in NIST_OFFSETS_A.items())
    for label, eff in (("packaged", ()), ("fit", offsets)):
        print(f"replaying NIST ({label})", file=sys.stderr, flush=True)
        np.savez(cache / f"nist_{label}.npz", **_replay_arrays(log, None, eff))


def gear_gain(runs: list[dict], j: int) -> float:
    """Simulated gear torque per simulated motor current on joint ``j`` [N*m/A] (sign included), on the moving
    samples of all runs: the model's own conversion of a current residual into joint torque."""
    x = np.concatenate([d["i_true"][np.abs(d["w_target"][:, j]) > 0.05, j] for d in runs])
    y = np.concatenate([d["tau_gear"][np.abs(d["w_target"][:, j]) > 0.05, j] for d in runs])
    return float(np.dot(x - x.mean(), y - y.mean()) / np.dot(x - x.mean(), x - x.mean()))


def design(d: dict, j: int, tau_key: str, w_min: float, gain: float
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Samples at speed of joint ``j``: regressors ``(m, 5)``, the residual as joint torque ``(m,)`` [N*m] and the
    residual in amperes."""
    wt, wa = d["w_target"][:, j], d["w_actual"][:, j]
    sel = d["keep"] & (np.abs(wt) > w_min) & (np.abs(wa) > w_min) & (np.sign(wt) == np.sign(wa))
    w, tau = wt[sel], d[tau_key][sel, j]
    r_A = d["meas"][sel, j] - d["sim"][sel, j]
    X = np.stack([np.ones_like(w), np.sign(w), w, tau, np.sign(w) * np.abs(tau)], axis=1)
    return X, r_A * gain, r_A


def _lstsq(X, y):
    return np.linalg.lstsq(X, y, rcond=None)[0]


def jackknife(parts: list[tuple[np.ndarray, np.ndarray]]) -> tuple[float, float]:
    """Pooled ``mu`` and its delete-one-part jackknife standard error."""
    X = np.concatenate([p[0] for p in parts])
    y = np.concatenate([p[1] for p in parts])
    full = _lstsq(X, y)[-1]
    g = len(parts)
    loo = np.array([_lstsq(np.concatenate([p[0] for k, p in enumerate(parts) if k != i]),
                           np.concatenate([p[1] for k, p in enumerate(parts) if k != i]))[-1] for i in range(g)])
    se = float(np.sqrt((g - 1) / g * np.sum((loo - loo.mean()) ** 2)))
    return float(full), se


def _blocks(X, y, k):
    edges = np.linspace(0, len(y), k + 1).astype(int)
    return [(X[a:b], y[a:b]) for a, b in zip(edges[:-1], edges[1:])]


def analyse(cache: Path, robot: str, label: str, tau_key: str, w_min: float) -> list[dict]:
    files = sorted(cache.glob(f"{robot}_{label}*.npz"))
    runs = {p.stem.removeprefix(f"{robot}_{label}").lstrip("_") or robot: dict(np.load(p)) for p in files}
    rows = []
    for j in range(6):
        parts, per_run, n_tot = [], {}, 0
        gain = gear_gain(list(runs.values()), j)
        for name, d in runs.items():
            X, y, _ = design(d, j, tau_key, w_min, gain)
            if robot == "nist":
                parts = [b for b in _blocks(X, y, NIST_BLOCKS) if len(b[1]) >= 20]
                per_run = {f"block {k}": float(_lstsq(*b)[-1]) for k, b in enumerate(parts)}
            elif len(y) >= MIN_RUN_SAMPLES:
                parts.append((X, y))
                per_run[name] = float(_lstsq(X, y)[-1])
            n_tot += len(y)
        if len(parts) < 3:
            rows.append({"joint": j, "n": n_tot, "mu": float("nan"), "se": float("nan"), "per_run": per_run})
            continue
        mu, se = jackknife(parts)
        X = np.concatenate([p[0] for p in parts])
        y = np.concatenate([p[1] for p in parts])
        c_with = _lstsq(X, y)
        c_wo = _lstsq(X[:, :4], y)
        rms_with = float(np.sqrt(np.mean((y - X @ c_with) ** 2))) / abs(gain)
        rms_wo = float(np.sqrt(np.mean((y - X[:, :4] @ c_wo) ** 2))) / abs(gain)
        tau_rms = float(np.sqrt(np.mean(X[:, 3] ** 2)))
        rows.append({"joint": j, "n": len(y), "mu": mu, "se": se, "per_run": per_run, "tau_rms": tau_rms,
                     "rms_A_without": rms_wo, "rms_A_with": rms_with, "coef": c_with.tolist(), "gain": gain})
    return rows


def print_table(title: str, rows: list[dict]) -> None:
    print(f"\n### {title}\n")
    print("| joint | samples at speed | RMS tau [N*m] | mu [-] (jackknife SE) | t | per run mu (min..max, n>0/n) "
          "| in-sample RMS [A] without / with |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        j = r["joint"]
        if not np.isfinite(r["mu"]) or not r["se"] > 0:
            print(f"| J{j + 1} | {r['n']} | - | too few samples at speed | | | |")
            continue
        pr = list(r["per_run"].values())
        spread = (f"{min(pr):+.3f}..{max(pr):+.3f}, {sum(v > 0 for v in pr)}/{len(pr)} > 0" if pr else "-")
        print(f"| J{j + 1} | {r['n']} | {r['tau_rms']:.1f} | {r['mu']:+.4f} ({r['se']:.4f}) | {r['mu'] / r['se']:+.1f} "
              f"| {spread} | {r['rms_A_without']:.3f} / {r['rms_A_with']:.3f} |")


def main(argv=None) -> int:
    from ur5fault.sim.params import load_params

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fit-model", default="/tmp/s31/kuf9/model.yaml")
    ap.add_argument("--cache", default=str(REPO / "results" / "load_friction"))
    ap.add_argument("--recompute", action="store_true")
    ap.add_argument("--min-speed-rad-s", type=float, default=3.0 / load_params().friction.stribeck_rate_s_per_rad)
    args = ap.parse_args(argv)
    cache = Path(args.cache)
    if args.recompute or not list(cache.glob("*.npz")):
        compute(cache, Path(args.fit_model))
    w = args.min_speed_rad_s
    print("Per run: Kufieta, runs with >= 200 samples at speed on the joint; NIST, its 10 time blocks.")
    for robot in ("kufieta", "nist"):
        for label in ("packaged", "fit"):
            for tau_key, what in (("tau_gear", "the model's gear torque"), ("tau_ur", "UR's target torque")):
                print_table(f"{robot}, {label} model, tau = {what}, |w| > {w:g} rad/s",
                            analyse(cache, robot, label, tau_key, w))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

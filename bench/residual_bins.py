"""Where the fitted model's current residual lives, on both real robots, against UR's own model's residual
(issue 17: what stays after fitting is ~0.4-0.5 A on J1-J3 of the Kufieta robot and NIST's wrist_2 near
reversals; which physical effect is missing there?).

    python bench/residual_bins.py [--cache results/residual_bins] [--recompute] [--temperature-C T ...]

1. *Replays* (cached as ``.npz`` under ``--cache``; ``--recompute`` redoes them): the Kufieta robot's model is
   ``identify`` on ``cross_robot.FIT_RUNS`` (+ the standstill run's rest, as in ``bench/cross_robot.py``),
   replayed on those runs (in-sample) and on ``TEST`` (held out, never used to fit); the NIST robot's model is
   the packaged one with the discrepancy workflow's three current offsets (docs/validation.md), replayed on the
   whole log, its last 40 % held out.  ``--temperature-C`` replays the Kufieta runs also at other assumed joint
   temperatures (the log has none; 28 degC is the packaged assumption).
2. *Bins*: the residual RMS (measured minus model) and UR's (measured minus ``target_current``) per joint in
   bins of |target speed|, |target acceleration|, sign of speed, |UR's target torque| (the transmitted gear
   torque, gravity + inertia) and time since the last velocity reversal.
3. *Candidates*: least-squares fits of the residual [A] of the fit runs on one physical regressor at a time
   (each with an intercept-free coefficient per joint), scored on the held-out samples: the held-out RMS
   before and after, per joint.  A regressor that does not lower the held-out RMS is not what is missing.
   Candidates: Coulomb and viscous corrections, direction asymmetry, load-dependent (harmonic-drive) friction
   ``|tau| sgn(w)`` (also per direction), a torque-constant error, a holding current at rest, a Stribeck term, a
   term decaying after each reversal, and torque ripples periodic in the motor angle (``k`` per motor turn,
   phase free), the one that pays (docs/validation.md; the effect ``motor_harmonic``).

Samples are the ticks the robot logged; the first 0.5 s of each run is left out (start transient).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

NIST_OFFSETS_A = {"elbow": 0.094, "wrist_1": 0.170, "wrist_3": -0.113}  # docs/validation.md, discrepancy on NIST
NIST_HOLD_FROM = 0.6  # the discrepancy workflow's split: last 40 % held out
MOVING_RAD_S = 0.01  # below this |target speed| a joint counts as at rest (UR's setpoints are exact zeros there)
SKIP_S = 0.5


def _replay(log, overrides, effects=()):
    from ur5fault.discrepancy.model import WORKFLOW_SEED
    from ur5fault.twin import LogReplay

    rp = LogReplay(log, overrides, seed=WORKFLOW_SEED)
    n = rp.n_samples
    sim = rp.run([tuple(effects)], n)[0]
    return sim.y[:, 0]


def _arrays(log, sim_A, role: np.ndarray) -> dict:
    n = sim_A.shape[0]
    t = log.t_s[1 : n + 1] - log.t_s[0]
    q = log.q_target_rad
    w = np.gradient(q, log.t_s, axis=0)[1 : n + 1]
    a = np.gradient(np.gradient(q, log.t_s, axis=0), log.t_s, axis=0)[1 : n + 1]
    keep = log.logged_rows()[1 : n + 1] & (t >= SKIP_S)
    tau = log.target_torque_Nm[1 : n + 1] if log.target_torque_Nm is not None else np.full_like(sim_A, np.nan)
    return {"t": t, "w": w, "a": a, "q": log.q_actual_rad[1 : n + 1], "tau": np.nan_to_num(tau),
            "meas": log.current_A[1 : n + 1], "sim": sim_A,
            "ur": log.target_current_A[1 : n + 1], "keep": keep, "role": role[:n]}


def compute(cache: Path, temps: list[float]) -> None:
    from cross_robot import FIT_RUNS, NIST_LOG, REST_FROM_S, REST_RUN, read

    from ur5fault.identify import identify
    from ur5fault.logs import read_nist
    from ur5fault.sim.effects import make_effect
    from ur5fault.sim.params import load_params

    cache.mkdir(parents=True, exist_ok=True)
    params = load_params()
    print("identifying on", ", ".join(FIT_RUNS), file=sys.stderr, flush=True)
    ident = identify([read(n) for n in FIT_RUNS] + [read(REST_RUN).window(REST_FROM_S, 60.0)], params,
                     sweep=False, n_boot=20)
    overlay = ident.overlay(params)["params"]
    from ur5fault.util.io import write_json_atomic

    write_json_atomic(cache / "kufieta_overlay.json", overlay)
    for temp in temps:
        over = dict(overlay, joint_temperature_C=[temp] * 6) if temp != 28.0 else overlay
        for name in (*FIT_RUNS, "TEST"):
            print(f"replaying {name} at {temp:g} degC", file=sys.stderr, flush=True)
            log = read(name)
            role = np.full(log.t_s.size, 0 if name in FIT_RUNS else 1)
            np.savez(cache / f"kufieta_{temp:g}C_{name}.npz", **_arrays(log, _replay(log, over), role))
    print("replaying the NIST log", file=sys.stderr, flush=True)
    log = read_nist(NIST_LOG)
    effs = [make_effect("current_sensor_offset", j, offset_A=v) for j, v in NIST_OFFSETS_A.items()]
    t = log.t_s - log.t_s[0]
    role = (t >= NIST_HOLD_FROM * t[-1]).astype(int)
    np.savez(cache / "nist.npz", **_arrays(log, _replay(log, None, effs), role))


def load(cache: Path, pattern: str) -> dict:
    parts = [dict(np.load(p)) for p in sorted(cache.glob(pattern))]
    if not parts:
        raise SystemExit(f"no cached replays {cache}/{pattern}: run without --bins-only first")
    out = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    # time since the last reversal of each joint's target speed, per run (reset at each run's start)
    since = []
    for p in parts:
        s = np.zeros_like(p["w"])
        last = np.full(6, -np.inf)
        sign = np.zeros(6)
        for i, (ti, wi) in enumerate(zip(p["t"], p["w"])):
            mv = np.abs(wi) > MOVING_RAD_S
            sg = np.where(mv, np.sign(wi), sign)
            flip = mv & (sign != 0) & (sg != sign)
            last = np.where(flip, ti, last)
            sign = sg
            s[i] = ti - last
        since.append(s)
    out["since"] = np.concatenate(since)
    return out


def _rms(x):
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


BINS = {
    "|w| rad/s": ("w", np.abs, [0.0, MOVING_RAD_S, 0.05, 0.2, 0.5, 1.0, 4.0]),
    "|a| rad/s2": ("a", np.abs, [0.0, 0.05, 0.5, 1.5, 100.0]),
    "sign w": ("w", lambda w: np.where(np.abs(w) <= MOVING_RAD_S, 0.0, np.sign(w)), [-1.5, -0.5, 0.5, 1.5]),
    "|tau| N*m": ("tau", np.abs, [0.0, 2.0, 5.0, 10.0, 20.0, 40.0, 200.0]),
    "since reversal s": ("since", lambda s: s, [0.0, 0.1, 0.3, 1.0, 3.0, np.inf]),
}


def bins_table(d: dict, role: int, title: str) -> None:
    sel0 = d["keep"] & (d["role"] == role)
    print(f"\n### {title}: residual RMS [A] model / UR's model (samples) per bin\n")
    for label, (key, fn, edges) in BINS.items():
        x = fn(d[key])
        print(f"| {label} | " + " | ".join(f"J{j + 1}" for j in range(6)) + " |")
        print("| --- " * 7 + "|")
        for lo, hi in zip(edges[:-1], edges[1:]):
            cells = []
            for j in range(6):
                s = sel0 & (x[:, j] >= lo) & (x[:, j] < hi)
                if s.sum() < 20:
                    cells.append("-")
                    continue
                r_m = d["meas"][s, j] - d["sim"][s, j]
                r_u = d["meas"][s, j] - d["ur"][s, j]
                cells.append(f"{_rms(r_m):.2f}/{_rms(r_u):.2f} ({s.sum()}) mean {r_m.mean():+.2f}")
            print(f"| [{lo:g}, {hi:g}) | " + " | ".join(cells) + " |")
        print()


def regressors(d: dict) -> dict[str, np.ndarray]:
    """Physical candidates, each ``(n, 6)`` (or several columns per joint as ``(n, 6, k)``)."""
    w, tau = d["w"], d["tau"]
    mv = np.abs(w) > MOVING_RAD_S
    sg = np.where(mv, np.sign(w), 0.0)
    last = np.zeros_like(w)  # direction of the last motion (holds at rest)
    s = np.zeros(6)
    for i in range(w.shape[0]):
        s = np.where(mv[i], sg[i], s)
        last[i] = s
    near = np.exp(-d["since"] / 0.3)
    from ur5fault.sim.params import load_params

    ratio = np.asarray(load_params().gear.ratio)
    harmonics = {f"motor-angle harmonic {k}/turn sin,cos(k N q)":
                 np.stack([np.sin(k * ratio * d["q"]), np.cos(k * ratio * d["q"])], axis=-1) for k in (2, 3, 4, 5)}
    return {
        "coulomb sgn(w)": sg[..., None],
        "viscous w": w[..., None],
        "direction asymmetry 1[w>0]": (sg > 0).astype(float)[..., None],
        "load-dependent friction |tau| sgn(w)": (np.abs(tau) * sg)[..., None],
        "load-dep. by direction": np.stack([np.abs(tau) * (sg > 0), -np.abs(tau) * (sg < 0)], axis=-1),
        "torque-proportional tau (K_t error)": tau[..., None],
        "holding last-dir at rest": (last * ~mv)[..., None],
        "Stribeck sgn(w) exp(-(w/0.05)^2)": (sg * np.exp(-(w / 0.05) ** 2))[..., None],
        "after reversal sgn(w) exp(-since/0.3s)": (sg * near)[..., None],
        "coulomb + load-dep + K_t": np.stack([sg, np.abs(tau) * sg, tau], axis=-1),
        **harmonics,
    }


def candidates(d: dict, title: str) -> None:
    fit = d["keep"] & (d["role"] == 0)
    held = d["keep"] & (d["role"] == 1)
    r = d["meas"] - d["sim"]
    ur = d["meas"] - d["ur"]
    print(f"\n### {title}: held-out residual RMS [A] after fitting one regressor on the fit samples "
          "(coefficient per joint; ratio to UR's model in brackets)\n")
    print("| regressor | " + " | ".join(f"J{j + 1}" for j in range(6)) + " | coefficients |")
    print("| --- " * 8 + "|")
    base = [_rms(r[held, j]) for j in range(6)]
    urr = [_rms(ur[held, j]) for j in range(6)]
    print("| none (fitted model) | " + " | ".join(f"{b:.3f} ({b / u:.2f})" for b, u in zip(base, urr)) + " | |")
    print("| UR's model | " + " | ".join(f"{u:.3f}" for u in urr) + " | |")
    for name, X in regressors(d).items():
        cells, coefs = [], []
        for j in range(6):
            A = X[:, j, :]
            c, *_ = np.linalg.lstsq(A[fit], r[fit, j], rcond=None)
            after = r[held, j] - A[held] @ c
            cells.append(f"{_rms(after):.3f} ({_rms(after) / urr[j]:.2f})")
            coefs.append("/".join(f"{v:.3g}" for v in c))
        print(f"| {name} | " + " | ".join(cells) + " | " + "; ".join(coefs) + " |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", default=str(REPO / "results" / "residual_bins"))
    ap.add_argument("--recompute", action="store_true")
    ap.add_argument("--temperature-C", type=float, nargs="*", default=[28.0])
    args = ap.parse_args(argv)
    cache = Path(args.cache)
    if args.recompute or not list(cache.glob("*.npz")):
        compute(cache, args.temperature_C)
    for temp in args.temperature_C:
        k = load(cache, f"kufieta_{temp:g}C_*.npz")
        bins_table(k, 1, f"Kufieta at {temp:g} degC, held-out TEST")
        bins_table(k, 0, f"Kufieta at {temp:g} degC, fit runs (in-sample)")
        candidates(k, f"Kufieta at {temp:g} degC (fit: {', '.join(sorted(set(np.unique(k['role']).astype(str))))})")
    n = load(cache, "nist.npz")
    bins_table(n, 1, "NIST held-out last 40 %")
    candidates(n, "NIST (fit: first 60 %, held out: last 40 %)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

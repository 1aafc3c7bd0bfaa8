"""Discrepancy workflow: where do model and measurement disagree, which effect of the registry
explains it, add it, and show the gap shrink on data not used for fitting.

Estimator (scikit-learn manners: ``fit()`` returns self, fitted attributes end in ``_``):

1. *Find*: replay the log's target trajectory (payload, tool, temperatures) through the current
   model; residuals measured - simulated per signal (``current_A``: motor current,
   ``position_rad``: joint position, ``mismatch_rad``: motor-vs-joint encoders when the log has them)
   and joint, localised by condition (at speed, near reversals, accelerating, at rest, under load).
2. *Name*: every candidate (effect x joint x parameter of the registry) is simulated once at a probe
   value in one lockstep batch with the baseline; the secant sensitivity gives a least-squares
   estimate; the most promising are refined by re-simulation (secant Gauss-Newton). The objective is
   the residual sum of squares weighted by 1/sensor-noise^2; candidates are ranked by the Bayesian
   information criterion with an effective sample count (residuals are autocorrelated).
3. *Add*: the best candidate is added if it lowers BIC by more than ``min_delta_bic``; repeat until
   none does. What stays well above the noise floor is reported as unexplained, with where it is.
4. *Show*: before/after RMS per signal and joint on the held-out end of the log.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .axes import JOINT_NAMES, N_JOINTS
from .effects import REGISTRY, EffectSpec, make_effect
from .engine import RunSpec, Simulator
from .errors import ParameterError
from .logs import MeasuredLog
from .params import deep_merge, load_params

#: sensor noise sigma per signal (data/ur5_drive.yaml, [nist]) used as residual weights
NOISE_SIGMA = {"current_A": 0.012, "position_rad": 2.3e-5, "mismatch_rad": 2.3e-5}
WORKFLOW_SEED = 20261121  # the workflow's own noise stream, unrelated to any log


@dataclasses.dataclass(frozen=True)
class Candidate:
    """One parameter of one effect on one joint (or the whole robot), with its probe value."""

    effect: str
    joint: int | None  # 0-based
    param: str
    x0: float  # value meaning "absent" (or the nominal)
    probe: float

    def spec(self, value: float) -> EffectSpec:
        return make_effect(self.effect, None if self.joint is None else self.joint + 1, **{self.param: value})

    @property
    def label(self) -> str:
        where = JOINT_NAMES[self.joint] if self.joint is not None else "robot"
        return f"{where}: {self.effect}.{self.param}"


# probe value per (effect, parameter): a typical fault size, used for the first secant
PROBES = {
    ("backlash", "backlash_deg"): 0.1,
    ("coulomb_friction", "scale"): 1.5,
    ("viscous_friction", "scale"): 1.5,
    ("viscous_temperature", "coeff_per_K"): 0.04,
    ("gear_stiffness", "scale"): 0.5,
    ("torque_constant", "scale"): 0.9,
    ("resolver_offset", "offset_deg"): 0.01,
    ("current_sensor_gain", "gain"): 1.1,
    ("current_sensor_offset", "offset_A"): 0.1,
    ("cogging", "amplitude_Nm"): 0.02,
    ("delay", "delay_ms"): 4.0,
    ("payload", "mass_kg"): None,  # nominal + 0.5 kg
    ("payload_com", "dx_m"): 0.05, ("payload_com", "dy_m"): 0.05, ("payload_com", "dz_m"): 0.05,
}
#: parameters fitted in a transformed variable in which the signals respond about linearly:
#: a gear's wind-up goes with its compliance, 1 / stiffness
TRANSFORMS = {("gear_stiffness", "scale"): (lambda x: 1.0 / x, lambda u: 1.0 / u)}
_IDENTITY = (lambda x: x, lambda u: u)

#: effects that are operating conditions read from the log, not discrepancies
CONDITIONS = {"temperature"}


def candidates(payload_kg: float, joints: Sequence[int] = range(N_JOINTS),
               kinds: Sequence[str] | None = None) -> list[Candidate]:
    """All candidates of the registry (optionally only some effect kinds and joints)."""
    out = []
    for (name, par), probe in PROBES.items():
        if name in CONDITIONS or (kinds is not None and name not in kinds):
            continue
        eff = REGISTRY[name]
        p = eff.param(par)
        if name == "payload":
            x0, probe = payload_kg, payload_kg + 0.5
        elif name == "viscous_temperature":
            x0 = float(load_params().friction.viscous_temp_coeff_per_K[0])
        else:
            x0 = float(p.absent)
        for j in (joints if eff.per_joint else [None]):
            out.append(Candidate(name, j, par, x0, float(probe)))
    return out


class Replay:
    """Simulates a log's target trajectory under a model (overlay params + effects)."""

    def __init__(self, log: MeasuredLog, params_overrides: dict | None = None,
                 base_effects: Sequence[EffectSpec] = (), seed: int = WORKFLOW_SEED, jobs: int = 1) -> None:
        self.log = log
        self.jobs = max(1, int(jobs))
        over = {"tcp_offset_m": list(log.tcp_offset_m)}
        if log.temperature_C is not None:
            over["joint_temperature_C"] = np.clip(log.temperature_C.mean(axis=0), -20, 120).tolist()
        self.params = load_params(overrides=deep_merge(over, dict(params_overrides or {})))
        self.traj = log.to_trajectory()
        self.base = tuple(base_effects)
        self.seed = seed
        period = log.period_s
        steps = period / self.params.physics_dt_s
        if abs(steps - round(steps)) > 1e-6:
            raise ParameterError(f"{log.source}: sample period {period:g} s is not a multiple of the physics step "
                                 f"{self.params.physics_dt_s:g} s")
        self.n_sim = 0

    def signals(self, effect_sets: Sequence[Sequence[EffectSpec]], n_samples: int) -> list[dict[str, np.ndarray]]:
        """Simulated signals at log samples 1..n_samples, one dict per effect set."""
        runs = [RunSpec(f"c{i}", self.seed, self.base + tuple(e)) for i, e in enumerate(effect_sets)]
        self.n_sim += len(runs)
        if self.jobs > 1 and len(runs) >= 2 * self.jobs:
            # a batch equals its single runs bit for bit, so splitting over processes changes nothing
            import joblib

            size = -(-len(runs) // self.jobs)
            parts = joblib.Parallel(n_jobs=self.jobs)(
                joblib.delayed(_simulate_part)(self.params, self.traj, runs[i : i + size], self.log.period_s, n_samples)
                for i in range(0, len(runs), size))
            return [d for part in parts for d in self._unpack(part)]
        return self._unpack(_simulate_part(self.params, self.traj, runs, self.log.period_s, n_samples))

    def _unpack(self, res) -> list[dict[str, np.ndarray]]:
        ratio = np.asarray(self.params.gear.ratio)
        out = []
        for i in range(res.n_runs):
            d = {"current_A": res["i_FB_A"][i], "position_rad": res["q_FB_rad"][i], "T_gear_Nm": res["T_gear_Nm"][i],
                 "status": res.status[i]}
            if self.log.q_motor_rad is not None:
                d["mismatch_rad"] = res["q_M_FB_rad"][i] / ratio - res["q_FB_rad"][i]
            out.append(d)
        return out

    def measured(self, n_samples: int) -> dict[str, np.ndarray]:
        L = self.log
        m = {"current_A": L.current_A[1 : n_samples + 1], "position_rad": L.q_actual_rad[1 : n_samples + 1]}
        if L.q_motor_rad is not None:
            ratio = np.asarray(self.params.gear.ratio)
            m["mismatch_rad"] = L.q_motor_rad[1 : n_samples + 1] / ratio - L.q_actual_rad[1 : n_samples + 1]
        return m


def _simulate_part(params, traj, runs, period_s: float, n_samples: int):
    return Simulator(params).run(traj, runs, log_period_s=period_s, duration_s=n_samples * period_s)


def weighted_rss(meas: dict, sim: dict, sl: slice = slice(None)) -> float:
    return float(sum(np.nansum(((meas[s][sl] - sim[s][sl]) / NOISE_SIGMA[s]) ** 2) for s in meas))


def effective_n(meas: dict, sim: dict) -> float:
    """Independent samples in the residual: n * (1 - rho) / (1 + rho), rho its lag-1 autocorrelation."""
    total = 0.0
    for s in meas:
        r = (meas[s] - sim[s]) / NOISE_SIGMA[s]
        for j in range(r.shape[1]):
            x = r[:, j] - np.nanmean(r[:, j])
            den = np.nansum(x * x)
            rho = float(np.nansum(x[1:] * x[:-1]) / den) if den > 0 else 0.0
            rho = min(max(rho, 0.0), 0.999)
            total += x.size * (1 - rho) / (1 + rho)
    return max(total, 10.0)


def block_standard_error(meas: dict, sim: dict, sens: dict, blocks: int = 10) -> float:
    """Standard error of a one-parameter weighted LS estimate from its spread over time blocks
    (a block jackknife: accounts for the residuals' autocorrelation without re-simulating)."""
    n = next(iter(meas.values())).shape[0]
    edges = np.linspace(0, n, blocks + 1).astype(int)
    deltas, weights = [], []
    for b in range(blocks):
        sl = slice(edges[b], edges[b + 1])
        num = sum(np.nansum((meas[s][sl] - sim[s][sl]) * sens[s][sl] / NOISE_SIGMA[s] ** 2) for s in meas)
        den = sum(np.nansum((sens[s][sl] / NOISE_SIGMA[s]) ** 2) for s in meas)
        if den > 0:
            deltas.append(num / den)
            weights.append(den)
    if len(deltas) < 3:
        return float("nan")
    d, w = np.array(deltas), np.array(weights)
    mean = np.sum(w * d) / np.sum(w)
    # variance of the weighted mean from the between-block scatter
    var = np.sum(w**2 * (d - mean) ** 2) / np.sum(w) ** 2 * len(d) / (len(d) - 1)
    return float(math.sqrt(var))


def bic(rss: float, n_eff: float, k: int) -> float:
    return n_eff * math.log(max(rss, 1e-300) / n_eff) + k * math.log(n_eff)


def rms_table(meas: dict, sim: dict, sl: slice) -> dict[str, dict[str, float]]:
    return {s: {JOINT_NAMES[j]: float(np.sqrt(np.nanmean((meas[s][sl, j] - sim[s][sl, j]) ** 2)))
                for j in range(N_JOINTS)} for s in meas}


def conditions(log: MeasuredLog, n: int, torque: np.ndarray) -> dict[str, np.ndarray]:
    """Boolean masks ``(n, 6)`` of operating conditions at samples 1..n."""
    q = log.q_target_rad[: n + 2]
    qd = np.gradient(q, log.period_s, axis=0)[1 : n + 1]
    qdd = np.gradient(np.gradient(q, log.period_s, axis=0), log.period_s, axis=0)[1 : n + 1]
    win = max(1, round(0.25 / log.period_s))
    near = np.zeros_like(qd, dtype=bool)
    moving = np.abs(qd) > 1e-3
    sign = np.sign(np.where(moving, qd, 0.0))
    for j in range(N_JOINTS):
        last = 0.0
        for k in range(n):
            if sign[k, j] != 0:
                if last != 0 and sign[k, j] != last:
                    near[max(0, k - win) : k + win, j] = True
                last = sign[k, j]
    peak = lambda x: np.abs(x) > 0.5 * np.maximum(np.abs(x).max(axis=0), 1e-12)  # noqa: E731
    out = {"at speed": peak(qd), "near velocity reversals": near, "accelerating": peak(qdd),
           "at rest": ~moving, "under high load": peak(torque)}
    if log.temperature_C is not None and np.ptp(log.temperature_C) > 0.5:
        temp = log.temperature_C[1 : n + 1]
        out["warmer half"] = temp > np.median(temp, axis=0)
    return out


def rms_by_condition(r: np.ndarray, masks: dict[str, np.ndarray], j: int) -> tuple[dict[str, float], str]:
    """RMS of one joint's residual ``r`` under each condition that occurs, and the largest one."""
    by = {k: float(np.sqrt(np.nanmean(r[m[:, j]] ** 2))) for k, m in masks.items() if m[:, j].any()}
    return by, max(by, key=by.get)


def localise(log: MeasuredLog, residual: dict, torque: np.ndarray, top: int = 3) -> list[dict[str, Any]]:
    """The largest residuals (signal, joint) with their RMS under each operating condition."""
    n = next(iter(residual.values())).shape[0]
    masks = conditions(log, n, torque)
    ranked = sorted(((float(np.sqrt(np.nanmean(r[:, j] ** 2))) / NOISE_SIGMA[s], s, j)
                     for s, r in residual.items() for j in range(N_JOINTS)), reverse=True)[:top]
    out = []
    for ratio, s, j in ranked:
        r = residual[s][:, j]
        by, worst = rms_by_condition(r, masks, j)
        out.append({"signal": s, "joint": JOINT_NAMES[j], "rms": float(np.sqrt(np.nanmean(r**2))),
                    "rms_over_noise": ratio, "rms_by_condition": by, "largest_where": worst})
    return out


@dataclasses.dataclass
class FoundEffect:
    candidate: Candidate
    value: float
    interval: tuple[float, float]
    delta_bic: float
    share_explained: dict[str, float]
    alternatives: list[tuple[Candidate, float]] = dataclasses.field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        c = self.candidate
        return {"name": c.effect, "joint": JOINT_NAMES[c.joint] if c.joint is not None else None,
                "parameters": {c.param: self.value}, "interval": {c.param: list(self.interval)},
                "delta_bic": self.delta_bic, "share_explained": self.share_explained,
                "indistinguishable_from": [
                    {"name": a.effect, "joint": JOINT_NAMES[a.joint] if a.joint is not None else None,
                     "parameters": {a.param: v}} for a, v in self.alternatives]}

    def sentence(self) -> str:
        c = self.candidate
        where = JOINT_NAMES[c.joint] if c.joint is not None else "robot"
        unit = REGISTRY[c.effect].param(c.param).unit
        best = max(self.share_explained, key=self.share_explained.get)
        alt = ""
        if self.alternatives:
            alt = "; indistinguishable in this log from " + ", ".join(
                f"{a.effect} {a.param} {v:.4g}" + (f" on {JOINT_NAMES[a.joint]}" if a.joint is not None else "")
                for a, v in self.alternatives)
        return (f"{where}: {REGISTRY[c.effect].doc} - {c.param} {self.value:.4g} {unit} "
                f"({self.interval[0]:.4g}..{self.interval[1]:.4g}) explains "
                f"{100 * self.share_explained[best]:.0f} % of the {best} residual{alt}")


class DiscrepancyModel:
    """Fit effects of the registry to a measured log (see the module docstring).

    Args:
        fit_fraction: share of the log (from its start) used for fitting; the rest is held out.
        max_effects: most effects added.
        min_delta_bic: an effect is added only if it lowers BIC by more than this ...
        min_share: ... and removes at least this share of the residual on some signal and joint.
        kinds: restrict the candidate effect kinds (default: the whole registry).
        refine: candidates refined by re-simulation per round.
    """

    def __init__(self, fit_fraction: float = 0.6, max_effects: int = 3, min_delta_bic: float = 10.0,
                 kinds: Sequence[str] | None = None, refine: int = 6, jobs: int = 1, min_share: float = 0.5) -> None:
        if not 0.2 <= fit_fraction <= 0.9:
            raise ParameterError(f"fit_fraction = {fit_fraction} is out of range [0.2, 0.9]")
        self.fit_fraction, self.max_effects, self.min_delta_bic = fit_fraction, max_effects, min_delta_bic
        self.kinds, self.refine, self.jobs, self.min_share = kinds, refine, jobs, min_share

    # -------------------------------------------------------------------------------- fit
    def fit(self, log: MeasuredLog, params_overrides: dict | None = None,
            base_effects: Sequence[EffectSpec] = ()) -> DiscrepancyModel:
        t0 = time.perf_counter()
        n_all = log.t_s.size - 1
        n_fit = int(n_all * self.fit_fraction)
        rp = Replay(log, params_overrides, base_effects, jobs=self.jobs)
        self.replay_ = rp
        meas = rp.measured(n_fit)
        found: list[FoundEffect] = []
        current: list[EffectSpec] = []
        base_sim = rp.signals([()], n_fit)[0]
        self.log_ = []
        for _ in range(self.max_effects):
            n_eff = effective_n(meas, base_sim)
            rss0 = weighted_rss(meas, base_sim)
            bic0 = bic(rss0, n_eff, len(current))
            taken = {(f.candidate.effect, f.candidate.joint) for f in found}
            joints = self._joints_above_floor(meas, base_sim)
            cands = [c for c in candidates(log.payload_kg, joints=joints, kinds=self.kinds)
                     if (c.effect, c.joint) not in taken]
            best = self._search(rp, meas, base_sim, current, cands, n_fit, n_eff, len(current))
            if best is None:
                break
            cand, value, sim_best, rss1, sens, alternatives = best
            bic1 = bic(rss1, n_eff, len(current) + 1)
            channel_share = max(
                1 - float(np.nansum((meas[s][:, j] - sim_best[s][:, j]) ** 2))
                / max(float(np.nansum((meas[s][:, j] - base_sim[s][:, j]) ** 2)), 1e-300)
                for s in meas for j in range(N_JOINTS))
            self.log_.append({"candidate": cand.label, "value": value, "delta_bic": bic1 - bic0,
                              "best_channel_share": channel_share})
            # named only if it is both supported (information criterion) and material: it removes at
            # least min_share of the residual on some signal and joint (not a fit to noise)
            if bic1 - bic0 > -self.min_delta_bic or channel_share < self.min_share:
                break
            sigma = block_standard_error(meas, sim_best, sens)
            share = {}
            for s in meas:
                before = float(np.nansum((meas[s] - base_sim[s]) ** 2))
                after = float(np.nansum((meas[s] - sim_best[s]) ** 2))
                share[s] = 1 - after / before if before > 0 else 0.0
            found.append(FoundEffect(cand, value, (value - 1.96 * sigma, value + 1.96 * sigma), bic1 - bic0, share,
                                     alternatives))
            current.append(cand.spec(value))
            base_sim = sim_best
        self.effects_ = found
        self.base_effects_ = tuple(base_effects)
        self.params_overrides_ = dict(params_overrides or {})
        # held-out comparison on the whole log
        both = rp.signals([(), tuple(current)], n_all)
        meas_all = rp.measured(n_all)
        held = slice(n_fit, n_all)
        self.rms_before_ = rms_table(meas_all, both[0], held)
        self.rms_after_ = rms_table(meas_all, both[1], held)
        self.rms_fit_before_ = rms_table(meas_all, both[0], slice(0, n_fit))
        self.rms_fit_after_ = rms_table(meas_all, both[1], slice(0, n_fit))
        self.residual_before_, self.residual_after_ = (
            {s: meas_all[s] - b[s] for s in meas_all} for b in both)
        self.unexplained_ = self._unexplained(meas_all, both[1], n_fit, n_all)
        self.localisation_ = localise(log, self.residual_before_, both[0]["T_gear_Nm"])
        self.n_fit_, self.n_all_ = n_fit, n_all
        self.wall_s_ = time.perf_counter() - t0
        self.n_simulated_runs_ = rp.n_sim
        return self

    @staticmethod
    def _joints_above_floor(meas, sim, factor: float = 2.0) -> list[int]:
        """Joints whose residual RMS exceeds ``factor`` x the noise floor in some signal: per-joint
        candidates are tried only there (robot-level candidates always)."""
        out = []
        for j in range(N_JOINTS):
            if any(np.sqrt(np.nanmean((meas[s][:, j] - sim[s][:, j]) ** 2)) > factor * math.sqrt(2) * NOISE_SIGMA[s]
                   for s in meas):
                out.append(j)
        return out

    def _search(self, rp, meas, base_sim, current, cands, n_fit, n_eff, k):
        """Probe every candidate in one lockstep batch, then refine the best by secant steps."""
        probes = rp.signals([tuple(current) + (c.spec(c.probe),) for c in cands], n_fit)
        scored = []
        for c, sim in zip(cands, probes):
            if sim["status"] != "ok":
                continue
            dx = c.probe - c.x0
            sens = {s: (sim[s] - base_sim[s]) / dx for s in meas}
            num = sum(np.nansum((meas[s] - base_sim[s]) * sens[s] / NOISE_SIGMA[s] ** 2) for s in meas)
            den = sum(np.nansum((sens[s] / NOISE_SIGMA[s]) ** 2) for s in meas)
            if den <= 0:
                continue
            step = num / den
            gain = num * num / den  # predicted drop of the weighted RSS (linear model)
            probe_rss = weighted_rss(meas, sim)
            scored.append((max(gain, weighted_rss(meas, base_sim) - probe_rss), c, c.x0 + step, sim, sens))
        if not scored:
            return None
        scored.sort(key=lambda t: -t[0])
        top = scored[: self.refine]
        # secant refinements of the top candidates, one batch per round, in a variable u in which the
        # effect is about linear; a step that lands worse than the best point is halved back towards it
        states = []
        for _gain, c, _x_est, sim_probe, _sens in top:
            p = REGISTRY[c.effect].param(c.param)
            fwd, inv = TRANSFORMS.get((c.effect, c.param), _IDENTITY)
            u0, u1 = fwd(c.x0), fwd(c.probe)
            su = {s: (sim_probe[s] - base_sim[s]) / (u1 - u0) for s in meas}
            num = sum(np.nansum((meas[s] - base_sim[s]) * su[s] / NOISE_SIGMA[s] ** 2) for s in meas)
            den = sum(np.nansum((su[s] / NOISE_SIGMA[s]) ** 2) for s in meas)
            u_next = u0 + num / den if den > 0 else u1
            states.append({"c": c, "p": p, "fwd": fwd, "inv": inv,
                           "pts": [(c.x0, base_sim, weighted_rss(meas, base_sim)),
                                   (c.probe, sim_probe, weighted_rss(meas, sim_probe))],
                           "next": _clip(inv(u_next), p)})
        for _ in range(3):
            sims = rp.signals([tuple(current) + (st["c"].spec(st["next"]),) for st in states], n_fit)
            for st, sim in zip(states, sims):
                rss = weighted_rss(meas, sim) if sim["status"] == "ok" else math.inf
                st["pts"].append((st["next"], sim, rss))
                pts = sorted(st["pts"], key=lambda t: t[2])
                (xa, ya, ra), (xb, yb, _) = pts[0], pts[1]
                fwd, inv = st["fwd"], st["inv"]
                if rss > ra:  # the last step made things worse: halve back towards the best
                    st["next"] = _clip(inv(0.5 * (fwd(st["next"]) + fwd(xa))), st["p"])
                    continue
                ua, ub = fwd(xa), fwd(xb)
                if ua == ub:
                    continue
                su = {s: (ya[s] - yb[s]) / (ua - ub) for s in meas}
                num = sum(np.nansum((meas[s] - ya[s]) * su[s] / NOISE_SIGMA[s] ** 2) for s in meas)
                den = sum(np.nansum((su[s] / NOISE_SIGMA[s]) ** 2) for s in meas)
                st["sens_u"] = su
                st["next"] = _clip(inv(ua + num / den), st["p"]) if den > 0 else xa
        best = None
        per_state = []
        for st in states:
            ok = [(x, r) for x, sim, r in st["pts"][1:] if sim["status"] == "ok" and math.isfinite(r)]
            if ok:
                per_state.append((st["c"], *min(ok, key=lambda t: t[1])))
            for x, sim, rss in st["pts"][1:]:
                if sim["status"] != "ok" or not math.isfinite(rss):
                    continue
                if best is None or rss < best[3]:
                    # sensitivity in the parameter itself at the optimum, for the uncertainty
                    others = sorted((p for p in st["pts"] if p[0] != x and p[1]["status"] == "ok"),
                                    key=lambda t: abs(t[0] - x))
                    xo, yo = others[0][0], others[0][1]
                    sens = {s: (sim[s] - yo[s]) / (x - xo) for s in meas}
                    best = (st["c"], float(x), sim, rss, sens)
        if best is None:
            return None
        # other effects that explain (almost) as much, >= 98 % of the best one's improvement: this log
        # cannot tell them apart (e.g. a current-sensor gain and a torque-constant change)
        gain = weighted_rss(meas, base_sim) - best[3]
        alts = [(c, float(x)) for c, x, r in per_state
                if c is not best[0] and gain > 0 and (r - best[3]) < 0.02 * gain]
        return (*best, alts)

    def _unexplained(self, meas, sim, n_fit, n_all) -> list[dict[str, Any]]:
        """Signal/joint pairs whose held-out residual stays above 3x the noise floor."""
        out = []
        torque = sim["T_gear_Nm"]
        masks = conditions(self.replay_.log, n_all, torque)
        for s in meas:
            floor = math.sqrt(2.0) * NOISE_SIGMA[s]
            r = meas[s] - sim[s]
            for j in range(N_JOINTS):
                rms = float(np.sqrt(np.nanmean(r[n_fit:, j] ** 2)))
                if rms > 3 * floor:
                    where, worst = rms_by_condition(r[:, j], masks, j)
                    out.append({"signal": s, "joint": JOINT_NAMES[j], "rms_held_out": rms,
                                "noise_floor": floor, "rms_by_condition": where, "largest_where": worst})
        return out

    # -------------------------------------------------------------------------------- outputs
    def overlay(self) -> dict[str, Any]:
        """The model overlay (``params`` and ``effects``) that ``simulate`` and ``campaign`` accept."""
        effects = [{"effect": e.name, **({"joint": JOINT_NAMES[e.joint]} if e.joint is not None else {}),
                    **dict(e.values)} for e in self.base_effects_]
        for f in self.effects_:
            c = f.candidate
            effects.append({"effect": c.effect, **({"joint": JOINT_NAMES[c.joint]} if c.joint is not None else {}),
                            c.param: f.value})
        return {"params": self.params_overrides_, "effects": effects}

    def summary(self) -> dict[str, Any]:
        return {
            "log": self.replay_.log.source,
            "effects": [f.to_json() for f in self.effects_],
            "named": [f.sentence() for f in self.effects_],
            "rms_before": self.rms_before_,
            "rms_after": self.rms_after_,
            "rms_fit_before": self.rms_fit_before_,
            "rms_fit_after": self.rms_fit_after_,
            "unexplained": self.unexplained_,
            "localisation_before": self.localisation_,
            "search": self.log_,
            "fit_fraction": self.fit_fraction,
            "held_out_s": [self.n_fit_ * self.replay_.log.period_s, self.n_all_ * self.replay_.log.period_s],
            "wall_s": self.wall_s_,
            "simulated_runs": self.n_simulated_runs_,
        }


def _clip(x: float, p) -> float:
    return float(min(max(x, p.lo), p.hi))


def write_report(model: DiscrepancyModel, out: Path) -> list[Path]:
    """``report.md`` with residual plots, ``model.yaml`` (overlay) and ``summary.json``."""
    import yaml
    from matplotlib.figure import Figure  # no pyplot: no backend picked, nothing to close

    out.mkdir(parents=True, exist_ok=True)
    summ = model.summary()
    (out / "summary.json").write_text(json.dumps(summ, indent=2, default=float))
    (out / "model.yaml").write_text(yaml.safe_dump(model.overlay(), sort_keys=False))
    log = model.replay_.log
    t = log.t_s[1 : model.n_all_ + 1]
    figs = []
    for s in model.residual_before_:
        fig = Figure(figsize=(11, 11))
        axes = fig.subplots(N_JOINTS, 1, sharex=True)
        for j, ax in enumerate(axes):
            ax.plot(t, model.residual_before_[s][:, j], lw=0.5, label="before")
            ax.plot(t, model.residual_after_[s][:, j], lw=0.5, label="after")
            ax.axvline(t[model.n_fit_ - 1], color="k", ls="--", lw=0.8)
            ax.set_ylabel(f"J{j + 1} [{s.split('_')[-1]}]")
        axes[0].legend(loc="upper right", fontsize=8)
        axes[0].set_title(f"{s} residual (measured - simulated); dashed: start of the held-out part")
        axes[-1].set_xlabel("time [s]")
        fig.tight_layout()
        p = out / f"residual_{s}.png"
        fig.savefig(p, dpi=80)
        figs.append(p)
    lines = [f"# Discrepancy report: {log.source}", "", "## Where the starting model disagrees", "",
             "| signal | joint | RMS | RMS / noise | largest where |", "| --- | --- | --- | --- | --- |"]
    for loc in summ["localisation_before"]:
        lines.append(f"| {loc['signal']} | {loc['joint']} | {loc['rms']:.4g} | {loc['rms_over_noise']:.1f} | "
                     f"{loc['largest_where']} ({loc['rms_by_condition'][loc['largest_where']]:.4g}) |")
    lines.append("")
    lines += ["## Effects found", ""]
    lines += [f"- {s}" for s in summ["named"]] or ["- none: no candidate lowered the information criterion enough"]
    lines += ["", "## Held-out gap (RMS, measured - simulated)", "",
              "| signal | joint | before | after | share explained |", "| --- | --- | --- | --- | --- |"]
    for s, per in summ["rms_before"].items():
        for jn, b in per.items():
            a = summ["rms_after"][s][jn]
            lines.append(f"| {s} | {jn} | {b:.4g} | {a:.4g} | {100 * (1 - (a / b) ** 2) if b else 0:.0f} % |")
    lines += ["", "## Unexplained", ""]
    if summ["unexplained"]:
        for u in summ["unexplained"]:
            lines.append(f"- {u['signal']} on {u['joint']}: held-out RMS {u['rms_held_out']:.4g} against a noise "
                         f"floor of {u['noise_floor']:.3g}, largest {u['largest_where']}; no effect of the library "
                         "explains it")
    else:
        lines.append("- nothing above three times the noise floor")
    lines += ["", "## Residual plots", ""] + [f"![{p.stem}]({p.name})" for p in figs]
    lines += ["", f"Fitted on the first {100 * model.fit_fraction:.0f} % of the log; {summ['simulated_runs']} "
              f"simulated runs in {summ['wall_s']:.0f} s."]
    (out / "report.md").write_text("\n".join(lines) + "\n")
    return [out / "report.md", out / "model.yaml", out / "summary.json", *figs]

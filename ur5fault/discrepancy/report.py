"""What the workflow tells its user: RMS tables, where residuals are largest, one sentence per finding,
``summary.json``, ``model.yaml`` (the overlay) and ``report.md`` with residual figures."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..sim.axes import JOINT_NAMES, N_JOINTS
from ..sim.effects import REGISTRY
from ..twin.residuals import UNEXPLAINED_FACTOR
from ..util.io import json_text, remove_unwritten, write_figure_atomic, write_text_atomic
from ..util.results import result_folder
from .candidates import LibraryCandidate, TermCandidate
from .speed import bare_mj_step_us, wall_over_mj_steps
from .statistics import Z_95

if TYPE_CHECKING:  # pragma: no cover
    from .judging import Finding
    from .model import DiscrepancyModel

#: the links the joints move (MJCF body names), for findings about a link's mass
LINK_NAMES = ("shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link", "wrist_3_link")
#: the residual figures are 11 x 11 in (six joints stacked): at this resolution [dots per inch] 880 px
#: square, against ur5fault.util.io.FIGURE_DPI for the other figures
RESIDUAL_FIGURE_DPI = 80


# ------------------------------------------------------------------------------------------ sentences
def _amplitude(f: Finding) -> tuple[float, float, float]:
    """Size of a finding's coefficients (the amplitude of a sine-cosine pair) and its 95 % interval."""
    th, se = np.asarray(f.theta), np.asarray(f.se)
    amp = float(np.linalg.norm(th)) if th.size > 1 else float(th[0])
    if th.size > 1:
        u = th / max(abs(amp), 1e-300)
        s = float(np.sqrt(np.sum((u * se) ** 2)))
    else:
        s = float(se[0])
    return amp, amp - Z_95 * s, amp + Z_95 * s


def size(f: Finding) -> float:
    """A finding's size in its effect's own unit (amplitude for a harmonic; the parameter value for a
    library effect)."""
    c = f.candidate
    if isinstance(c, LibraryCandidate):
        return c.value(f.theta)
    return _amplitude(f)[0] * c.to_param


#: how to read a finding's bracket, once above the findings of ``report.md``
HOW_TO_READ = ("Each finding: its size with a 95 % interval, then [z: the size over its standard error; delta BIC: "
               "how much better the fitting part is explained with it (below -10: strong evidence); held out: removes "
               "N % of its change: on the held-out part, the drop of the residual's sum of squares over the sum of "
               "squares of the change the finding makes there. 100 %: the residual left is orthogonal to the change, "
               "its size fits; above 100 %: more of its shape is left, the held-out part would take it larger; "
               "0-100 %: smaller; below 0: it makes the held-out part worse]. Then the effects this log cannot tell "
               "from it, and what would.")


def sentence(f: Finding) -> str:
    """One line a robotics engineer reads: what, where, how big (95 % interval), and how sure."""
    c = f.candidate
    amp, lo, hi = _amplitude(f)
    if isinstance(c, LibraryCandidate):
        unit = REGISTRY[c.effect].param(c.param).unit_text()  # none for a factor: "scale 1.5 - (...)" read oddly
        a, b = sorted((c.value(lo), c.value(hi)))
        text = (f"{c.where}: {REGISTRY[c.effect].doc} - {c.param} {c.value(f.theta):.4g}{unit} "
                f"({a:.4g}..{b:.4g})")
        if (c.effect, c.param) == ("payload", "mass_kg"):  # the job's, stated by the user: which the log contradicts
            text += (f", where {c.x0:g} kg was stated: check the payload given (--payload-kg, a manifest's "
                     "payload_kg), or omit it to have it fitted"
                     + (" with its centre of mass (omit --tcp-offset-m too), which a fit about 0 kg stated cannot "
                        "place: this one holds it at the stated tool point" if c.x0 == 0 else "")
                     + "; model.yaml does not hold it (a payload is the "
                     f"job's): with model.yaml on this job's logs state --payload-kg {c.value(f.theta):.3g}")
    else:
        text = _term_text(c, amp, lo, hi)
    tests = f"z {f.verdict.z:.0f}, delta BIC {f.verdict.delta_bic:.0f}"
    if f.held_out is not None:
        tests += (f", held out: removes {100 * f.held_out.ratio:.0f} % of its change" if f.held_out.testable
                  else ", not testable on the held-out part")
    alt = ""
    if f.alternatives:
        alt = "; indistinguishable in this log from " + ", ".join(
            f"{a.label} {_coef_text(a, th)}" for a, th in f.alternatives)
    if f.tell_apart:
        alt += f" ({f.tell_apart})"
    for r in f.rivals:
        if r.tell_apart:
            alt += f" ({r.candidate.label}: {r.tell_apart})"
    return f"{text} [{tests}]{alt}"


def _coef_text(c, th) -> str:
    if isinstance(c, LibraryCandidate):
        return f"{c.value(th):.4g}"
    return ", ".join(f"{k} {v * c.to_param:.4g}" for k, v in zip(c.keys, np.ravel(th)))


def _term_text(c: TermCandidate, amp: float, lo: float, hi: float) -> str:
    k = dict(c.fixed)
    amps = f"{c.signal_per_coef * amp:.3g} A"
    rng = f"95 % {lo:.3g}..{hi:.3g}"
    fam = c.family
    if fam == "joint_harmonic":
        return (f"{c.where}: current ripple of {amps} periodic in the joint angle, {k['periods_per_rev']:.0f} per "
                f"revolution (link torque {amp:.3g} N*m, {rng})")
    if fam == "coulomb":
        return f"{c.where}: Coulomb-like load torque of {amp:.3g} N*m ({amps}) beyond the model's friction ({rng})"
    if fam == "stribeck":
        return (f"{c.where}: Stribeck-like load torque of {amp:.3g} N*m ({amps}) at low speed, fading above "
                f"{k['speed_rad_s']:g} rad/s ({rng})")
    if fam == "holding":
        return (f"{c.where}: holding torque of {amp:.3g} N*m ({amps}) at rest, in the direction of the last motion "
                f"(friction that stays loaded when the joint stops; {rng})")
    if fam == "viscous":
        return f"{c.where}: viscous load of {amp:.3g} N*m*s/rad beyond the model's friction ({rng})"
    if fam == "quadratic":
        return f"{c.where}: speed-squared drag of {amp:.3g} N*m*s^2/rad^2 (torque c w|w|; {rng})"
    if fam == "inertia":
        what = "missing" if amp > 0 else "excess"
        return f"{c.where}: {what} inertia of {abs(amp):.3g} kg*m^2 on the joint ({rng})"
    if fam == "gravity_scale":
        return f"{c.where}: gravity torque {100 * amp:+.1f} % of the model's ({100 * lo:.1f}..{100 * hi:.1f} %)"
    if fam == "link_mass":
        return f"{LINK_NAMES[c.joint]}: {amp:+.3g} kg at the link's centre of mass ({rng} kg)"
    if fam == "link_com":
        axis = c.keys[0][5]
        return (f"{LINK_NAMES[c.joint]}: centre of mass {1e3 * amp:+.1f} mm along the link's {axis} axis "
                f"(95 % {1e3 * lo:.1f}..{1e3 * hi:.1f} mm)")
    if fam == "temperature_drift":
        return f"{c.where}: current drift of {1e3 * amp:.3g} mA/K with joint temperature (95 % {1e3 * lo:.3g}.." \
               f"{1e3 * hi:.3g} mA/K)"
    what = "current" if fam == "current_time_shift" else "position"
    return (f"{c.where}: {what} reading {abs(1e3 * amp):.3g} ms {'late' if amp > 0 else 'early'} "
            f"(95 % {1e3 * lo:.3g}..{1e3 * hi:.3g} ms)")


def rival_json(r) -> dict[str, Any]:
    c = r.candidate
    out = {"candidate": c.label, "name": c.effect, "joint": JOINT_NAMES[c.joint] if c.joint is not None else None,
           "coefficients": list(map(float, np.ravel(r.theta))), "held_out_ratio": r.held_out_ratio,
           "held_out_delta_bic": r.held_out_delta_bic, "tell_apart": r.tell_apart}
    if isinstance(c, LibraryCandidate):
        out["size"] = float(c.value(r.theta))
    return out


def finding_json(f: Finding) -> dict[str, Any]:
    c = f.candidate
    lo, hi = f.interval()
    # as fitted (a dropped finding's may lie outside the valid range), the others at their "absent" values
    params = {**{p.name: p.absent for p in REGISTRY[c.effect].params if p.absent is not None}, **c.values(f.theta)}
    out = {"source": c.source, "name": c.effect, "joint": JOINT_NAMES[c.joint] if c.joint is not None else None,
           "parameters": params, "sentence": sentence(f), "size": size(f), "kept": f.kept,
           "reason": f.reason, "z": f.verdict.z, "delta_bic": f.verdict.delta_bic,
           "block_ratios": list(f.verdict.stability.ratios),
           # the RMS of its estimate on the model's replays under other noise seeds (in se, z and the interval)
           "replay_scatter": None if f.replay_scatter is None else list(map(float, np.ravel(f.replay_scatter))),
           "held_out": None if f.held_out is None else {"testable": f.held_out.testable, "ratio": f.held_out.ratio,
                                                       "energy": f.held_out.energy},
           "indistinguishable_from": [{"candidate": a.label, "coefficients": list(map(float, np.ravel(th)))}
                                      for a, th in f.alternatives],
           "tell_apart": f.tell_apart,
           # the alternatives judged on the held-out part (rivals.py), also among indistinguishable_from
           "rivals": [rival_json(r) for r in f.rivals]}
    if isinstance(c, LibraryCandidate):
        a, b = sorted((c.value(lo), c.value(hi)))
        out["interval"] = {c.param: [a, b]}
    else:
        out["family"] = c.family
        out["interval"] = {k: [float(x) * c.to_param, float(y) * c.to_param] for k, x, y in zip(c.keys, lo, hi)}
    return out


def summary(model: DiscrepancyModel, bare_step_us: float | None = None) -> dict[str, Any]:
    """Everything ``summary.json`` holds; ``bare_step_us``: one bare mj_step timed now [us] (see ``speed.py``),
    which adds the fit's wall time in machine-independent units."""
    rp = model.replay_
    out = {
        "log": rp.log.source,
        # each log's own (several logs: the joint axis has no temperatures if one log lacks them, nor one pose)
        "log_assumptions": list(dict.fromkeys(a for r in getattr(rp, "replays", [rp])
                                              for a in r.log.assumptions(rp.params.joint_temperature_C))),
        "named": [sentence(f) for f in model.findings_ if f.kept],
        "findings": [finding_json(f) for f in model.findings_],
        "dropped": [f"{sentence(f)}: {f.reason}" for f in model.dropped_],
        "rms_before": model.rms_before_,
        "rms_after": model.rms_after_,
        "rms_fit_before": model.rms_fit_before_,
        "rms_fit_after": model.rms_fit_after_,
        "rms_controller_model_current_A": model.rms_controller_model_,
        "per_log": model.per_log_,
        "payload": {name: rec.to_json() for name, rec in model.payload_.items()},
        "unexplained": model.unexplained_,
        "localisation_before": model.localisation_,
        "search": [vars(s) for s in model.search_],
        "fit_fraction": model.fit_fraction,
        "held_out_s": [model.n_fit_ * rp.log.period_s, model.n_all_ * rp.log.period_s],
        "wall_s": model.wall_s_,
        "wall_s_by_stage": model.timings_s_,
        "simulated_runs": model.n_simulated_runs_,
        "simulated_s": model.simulated_s_,
    }
    if bare_step_us is not None:
        out["bare_mj_step_us"] = bare_step_us
        out["wall_over_mj_steps"] = wall_over_mj_steps(model, bare_step_us)
    return out


def figures(model: DiscrepancyModel):
    """One residual figure per signal (before/after, held-out part marked), as matplotlib Figures."""
    from matplotlib.figure import Figure

    rp = model.replay_
    t = rp.log.t_s[1 : model.n_all_ + 1]
    out = {}
    for i, s in enumerate(rp.signals):
        fig = Figure(figsize=(11, 11))
        axes = fig.subplots(N_JOINTS, 1, sharex=True)
        for j, ax in enumerate(axes):
            ax.plot(t, model.residual_before_[:, i, j], lw=0.5, label="before")
            ax.plot(t, model.residual_after_[:, i, j], lw=0.5, label="after")
            ax.axvline(t[model.n_fit_ - 1], color="k", ls="--", lw=0.8)
            ax.set_ylabel(f"J{j + 1} [{s.split('_')[-1]}]")
        axes[0].legend(loc="upper right", fontsize=8)
        axes[0].set_title(f"{s} residual (measured - simulated); dashed: start of the held-out part")
        axes[-1].set_xlabel("time [s]")
        fig.tight_layout()
        out[s] = fig
    return out


#: the files of a result (``--out``), besides the figures
RESULT_FILES = ("report.md", "model.yaml", "summary.json")


def write_report(model: DiscrepancyModel, out: Path, replace: bool = True) -> list[Path]:
    """``report.md`` with residual plots, ``model.yaml`` (overlay) and ``summary.json``, written as one set
    (:func:`ur5fault.util.results.result_folder`: a run stopped between them leaves the folder marked incomplete).
    ``replace=False``: refuse a result another process wrote into ``out`` meanwhile."""
    from ..util.yamlsafe import dump

    summ = summary(model, bare_mj_step_us(model.replay_.params.physics_dt_s))
    with result_folder(out, RESULT_FILES, replace) as out:
        write_text_atomic(out / "summary.json", json_text(summ))  # strict JSON: no value is null, never NaN
        write_text_atomic(out / "model.yaml", dump(model.overlay(), "model.yaml", sort_keys=False))
        paths = []
        for s, fig in figures(model).items():
            paths.append(write_figure_atomic(fig, out / f"residual_{s}.png", RESIDUAL_FIGURE_DPI))
        remove_unwritten(out, "residual_*.png", paths)  # an earlier result's figures of other signals (--replace)
        write_text_atomic(out / "report.md", _markdown(model, summ, paths))
    return [out / "report.md", out / "model.yaml", out / "summary.json", *paths]


def _markdown(model: DiscrepancyModel, summ: dict[str, Any], figs: list[Path]) -> str:
    lines = [f"# Discrepancy report: {summ['log']}", "", "## Where the starting model disagrees", "",
             "| signal | joint | RMS | RMS / noise | largest where |", "| --- | --- | --- | --- | --- |"]
    for loc in summ["localisation_before"]:
        lines.append(f"| {loc['signal']} | {loc['joint']} | {loc['rms']:.4g} | {loc['rms_over_noise']:.1f} | "
                     f"{loc['largest_where']} ({loc['rms_by_condition'][loc['largest_where']]:.4g}) |")
    # what the run assumed beyond the log's data (stderr said it; a reader of the report alone had only the findings,
    # e.g. an offset named on a run whose arm stands, where a gain and a torque constant read alike)
    lines += ["", "## What the log does not say (assumed, or what it cannot show)", ""]
    lines += [f"- {a}" for a in summ["log_assumptions"]] or ["- nothing: the log carries every input the replay takes"]
    lines += ["", "## Payload (the job's, not the robot's: not in model.yaml, nor a finding of its mass or centre of "
              "mass below)", ""]
    lines += [f"- {rec.line()}" for rec in model.payload_.values()]
    lib = [sentence(f) for f in model.effects_]
    terms = [sentence(f) for f in model.terms_]
    lines += ["", "## Effects of the library found", "", HOW_TO_READ, ""]
    lines += [f"- {s}" for s in lib] or ["- none"]
    lines += ["", "## Terms discovered outside the library (added to model.yaml as data-driven effects)", ""]
    lines += [f"- {s}" for s in terms] or ["- none"]
    if summ["dropped"]:
        lines += ["", "## Dropped", ""] + [f"- {s}" for s in summ["dropped"]]
    lines += ["", "## Held-out gap (RMS, measured - simulated)", "",
              "| signal | joint | before | after | share explained |", "| --- | --- | --- | --- | --- |"]
    for s, per in summ["rms_before"].items():
        for jn, b in per.items():
            a = summ["rms_after"][s][jn]
            lines.append(f"| {s} | {jn} | {b:.4g} | {a:.4g} | {100 * (1 - (a / b) ** 2) if b else 0:.0f} % |")
    if summ["rms_controller_model_current_A"]:
        ctl = summ["rms_controller_model_current_A"]["held_out"]
        lines += ["", "The robot controller's own current model (target - actual current in the log), held out: "
                  + ", ".join(f"{jn} {v:.3g} A" for jn, v in ctl.items()) + "."]
    lines += ["", "## Unexplained", ""]
    if summ["unexplained"]:
        for u in summ["unexplained"]:
            reg = u.get("angle_region")
            local = (f"; between {reg['from_deg']:g} and {reg['to_deg']:g} deg of the joint's travel {reg['rms']:.4g} "
                     f"(elsewhere {reg['rms_elsewhere']:.4g})") if reg else ""
            lines.append(f"- {u['signal']} on {u['joint']}: held-out RMS {u['rms_held_out']:.4g} against a noise "
                         f"floor of {u['noise_floor']:.3g}, largest {u['largest_where']}{local}{_why_not_fitted(u)}")
    else:
        lines.append(f"- nothing above {UNEXPLAINED_FACTOR:g} times the noise floor")
    lines += ["", "## Residual plots", ""] + [f"![{p.stem}]({p.name})" for p in figs]
    lines += ["", f"Fitted on the first {100 * model.fit_fraction:.0f} % of the log; {summ['simulated_runs']} "
              f"simulated runs ({summ['simulated_s']:.0f} s simulated) in {summ['wall_s']:.0f} s "
              f"({summ['wall_over_mj_steps']:.2f} bare mj_step times per simulated run-step)."]
    return "\n".join(lines) + "\n"


def _why_not_fitted(u: dict) -> str:
    """What the report adds to an unexplained entry whose residual the fitted part does not show: the search sees
    only that part, so nothing there could explain it (e.g. a clearance crossed only after the split)."""
    if not u.get("held_out_only"):
        return ""
    text = (f". Not in the fitted part (RMS {u['rms_fit']:.3g} there, under {UNEXPLAINED_FACTOR:g} x the floor): "
            "the search, which fits that part only, could not see it")
    rev = u.get("gear_reverses") or {}
    if rev.get("held_out") and not rev.get("fitted"):
        text += ("; the joint's gear torque reverses in the held-out part only, where a backlash (or any effect at "
                 "the gear's clearance) shows: fit a part that reverses it (a larger --fit-fraction, or a log that "
                 "does)")
    return text

"""The RUL benchmark's ``report.md``: the metrics of ``ur5fault prognose`` (benchmark.py) as a table and the
goals in words."""

from __future__ import annotations

import math
from typing import Any

_FRICTION_TEXT = {"learned": "learned per unit from the inspections", "law": "of the wear law"}


def _f(v: Any, fmt: str = ".3g") -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, fmt)


def _twin_model(model: dict[str, Any] | None) -> str:
    """Which model the twin ran (``--model``): the packaged one, or an overlay's parameters and effects."""
    if not model:
        return "the twin ran the packaged model, the fleet's own (--model: another)"
    params = ", ".join(sorted(model.get("params", {}))) or "none"
    effects = "; ".join(model.get("effects", [])) or "none"
    return f"the twin ran a model overlay (--model): parameter groups {params}; effects {effects}"


def markdown(m: dict[str, Any]) -> str:
    d = m["dataset"]
    ipu = d["inspections_per_unit"]
    lines = [
        f"# RUL benchmark: {m['source']}", "",
        f"{d['n_units']} units ({d['n_censored_units']} censored), {d['n_inspections']} inspections ({ipu['min']}-"
        f"{ipu['max']} per unit, mean {ipu['mean']:.1f}); split by unit: {d['n_train_units']} failed training and "
        f"{d['n_test_units']} failed held-out units. End of life: first inspection with {d['failure']['feature']} >= "
        f"{d['failure']['threshold']:g}; median {_f(d['eol_cycles']['median'])} cycles "
        f"({_f(d['eol_cycles']['min'])}-{_f(d['eol_cycles']['max'])}).", "",
        f"| estimator | RMSE at 25 % life | at 50 % | at 75 % | alpha-lambda accuracy (alpha {m['alpha']:g}, "
        f"lambda {m['lambda']:g}) | median prognostic horizon (fraction of life) | 90 % interval coverage |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name, r in m["estimators"].items():
        rm = r["rmse_cycles"]
        lines.append(f"| {name} | {_f(rm['0.25'])} | {_f(rm['0.5'])} | {_f(rm['0.75'])} | "
                     f"{_f(r['alpha_lambda_accuracy'], '.2f')} | {_f(r['prognostic_horizon_cycles_median'])} "
                     f"({_f(r['prognostic_horizon_fraction_median'], '.2f')}) | "
                     f"{_f(r['interval_coverage_90'], '.2f')} |")
    g = m["goals"]
    lines += ["", f"Goals: RMSE at 50 % life, {g['baseline']} / naive = "
              f"{_f(g['rmse_50_ratio_baseline_to_naive'], '.2f')} "
              f"(goal <= 0.5: {'met' if g['rmse_50_at_most_half_of_naive'] else 'missed'}); alpha-lambda accuracy "
              f">= 0.8: {'met' if g['alpha_lambda_at_least_0.8'] else 'missed'}. Each estimator: "
              + "; ".join(f"{k} {_f(v['rmse_50_ratio_to_naive'], '.2f')} x naive "
                          f"({'met' if v['rmse_50_at_most_half_of_naive'] else 'missed'}), alpha-lambda "
                          f"{'met' if v['alpha_lambda_at_least_0.8'] else 'missed'}"
                          for k, v in g["by_estimator"].items()) + ".", "",
              "RMSE in cycles. Health index: the unit's own feature changes since its inspection 0, mapped onto "
              "the failure criterion on the training units of the same duty task. linear: the index as a "
              "linear trend measured with "
              "error plus a Wiener term, intercept and slope with a population prior updated by the unit's "
              "history; RUL from the fitted trend. wiener: the index as a Wiener process with a population "
              "prior on its drift, RUL from the last index value. Both: median of the RUL distribution, 5-95 % "
              "interval. wiener_joint: the same Wiener estimator on a per-joint index (each joint's features estimate "
              "its clearance growth, combined per task with non-negative lever arms onto the criterion). "
              "clearance: each joint's clearance estimated from its own features (maps per task), its growth "
              "extrapolated as a line from the new robot with a population prior, the end of life where that "
              "line meets the failure boundary of the task's training units (radius by direction of growth, "
              "kernel width by leave-one-unit-out). twin (with --twin): the same clearance estimates and growth "
              "line, the failure boundary simulated by the digital twin along the unit's direction of growth on "
              "its own duty cycle (task, payload, temperature), calibrated on training units"
              + (f" ({tw['calibration']}: --twin-calibration; the friction rise with wear "
                 f"{_FRICTION_TEXT[tw['friction']['source']]}: --twin-friction; {_twin_model(tw.get('model'))})"
                 if (tw := m["fitted"].get("twin")) else "")
              + ". naive: mean "
              "residual life of the training units that outlived the unit's age.", "",
              "Figures: " + ", ".join(f"`{f}`" for f in m["figures"]) + f". Benchmark wall time "
              f"{m['benchmark_wall_s']:.1f} s."]
    return "\n".join(lines) + "\n"

"""How large a fault written into a real UR5 log ``ur5fault diagnose --baseline-logs`` flags, at the training runs'
5 % threshold and above the robot's own threshold (docs/diagnostics.md, "The robot's own threshold").

    python bench/diagnose_fault_sizes.py [--detector results/diagnostics_urlog/benchmark]
                                         [--out results/diagnose_fault_sizes]

bench/diagnose_real_logs.py diagnoses each real log with one size of each fault (0.1 A offset on wrist 1, 10 %
gain on the shoulder); this sweeps the sizes on the logs of the robot held out from its identification, with the
baselines of that bench: the NIST log's second half (its first half the baseline, packaged model) and the three
Kufieta runs of the second fold (No2, No4_Acc, TEST; overlay identified on the first fold and the standstill
run's rest, as there; baseline: all six other undisturbed runs).  The faults are written into the measured
current by tests/real_hidden.py.  Per log, kind and size: share of windows flagged and flagged with the
injected joint the likeliest, at each threshold.  Writes ``OUT/sizes.json``, ``OUT/sizes.md`` and ``OUT/sizes.png``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

import diagnose_real_logs as drl  # noqa: E402

OFFSETS_A = (0.1, 0.3, 1.0, 3.0)  # wrist 1 (J4)
GAINS = (1.1, 1.25, 1.5, 2.0)  # shoulder (J2)


def cases():
    yield "healthy", None, None, {}, "-"
    for a in OFFSETS_A:
        yield "current_sensor_offset", "current_sensor_offset", drl.OFFSET_JOINT, {"offset_A": a}, f"{a:g} A"
    for g in GAINS:
        yield "current_sensor_gain", "current_sensor_gain", drl.GAIN_JOINT, {"gain": g}, f"x {g:g}"


def sweep(log, model, detector, baseline, twin, windows) -> list[dict]:
    from ur5fault.health.diagnosis import diagnose

    rows = []
    for label, kind, joint, values, size in cases():
        lg = log if kind is None else drl.inject(log, kind, joint, **values)
        d = diagnose(lg, detector, model.params, model.effects, twin=twin, windows=windows if kind is None else None,
                     baseline=baseline)
        j = drl.OFFSET_JOINT if joint is None else joint
        row = {"log": Path(log.source).name.split(".")[0], "kind": label, "size": size,
               "joint": None if joint is None else joint + 1, **drl.flagged_on_joint(d, j),
               "flag_threshold": d["flag_threshold"]}
        rows.append(row)
    return rows


def table(rows: list[dict]) -> str:
    pct = "{:.0f} %".format
    lines = ["| log | fault | size | flagged / flagged on its joint: training threshold | **above the robot's "
             "threshold too** |", "| --- | --- | --- | --- | --- |"]
    for r in rows:
        where = "" if r["joint"] is None else f" J{r['joint']}"
        lines.append(f"| {r['log']} | {r['kind']}{where} | "
                     f"{r['size']} | {pct(100 * r['share_flagged_training_threshold'])} / "
                     f"{pct(100 * r['share_flagged_on_joint_training_threshold'])} | "
                     f"**{pct(100 * r['share_flagged'])} / {pct(100 * r['share_flagged_on_joint'])}** |")
    return "\n".join(lines) + "\n"


def plot(rows: list[dict], path: Path) -> Path:
    """Share of windows flagged on the injected joint against the fault's size, per log and kind, above the
    robot's threshold (solid) and at the training runs' alone (dashed)."""
    from matplotlib.figure import Figure

    from ur5fault.util.io import write_figure_atomic

    fig = Figure(figsize=(9, 4.0), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    for ax, (kind, sizes, unit) in zip(axes, (("current_sensor_offset", OFFSETS_A, "wrist-1 current offset [A]"),
                                              ("current_sensor_gain", GAINS, "shoulder current gain"))):
        for k, log in enumerate(dict.fromkeys(r["log"] for r in rows)):
            sel = [r for r in rows if r["log"] == log and r["kind"] == kind]
            c = f"C{k}"
            ax.plot(sizes, [100 * r["share_flagged_on_joint"] for r in sel], "o-", color=c,
                    label=log.replace("ur5testresult_halfspeed_payload1", "NIST 2nd half"))
            ax.plot(sizes, [100 * r["share_flagged_on_joint_training_threshold"] for r in sel], "x--", color=c,
                    alpha=0.5)
        if kind == "current_sensor_offset":
            ax.set_xscale("log")
        ax.set_xlabel(unit)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("windows flagged on the joint [%]")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=4, fontsize=8,
               title="solid: above the robot's threshold too; dashed: the training runs' threshold alone",
               title_fontsize=8)
    return write_figure_atomic(fig, path)


def main(argv=None) -> int:
    from ur5fault.health.diagnosis import robot_baseline
    from ur5fault.health.diagnostics.saved import load_models
    from ur5fault.util.io import write_json_atomic, write_text_atomic

    detector, out, n_boot, params_only = drl.arguments(__doc__, "diagnose_fault_sizes", argv)
    t0 = time.perf_counter()
    window_s = float(load_models(detector)[1]["window_s"])
    nist, nist_tw, nist_base = drl.nist_second_half(detector, window_s)
    rows = sweep(nist, drl.PACKAGED, detector, nist_base, *nist_tw)
    held = drl.FOLDS[1]
    overlay = drl.fold_overlay(1, n_boot, params_only)  # identified on the first fold: the second is held out
    logs = {n: drl.read_kufieta(n) for f in drl.FOLDS for n in f}
    tw = {n: drl.twin_and_windows(lg, overlay, window_s) for n, lg in logs.items()}
    for name in held:
        others = [n for n in logs if n != name]
        base = robot_baseline([logs[n] for n in others], detector, overlay.params, overlay.effects,
                              windows=[tw[n][1] for n in others])
        rows += sweep(logs[name], overlay, detector, base, *tw[name])
        print(f"{name}: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    write_json_atomic(out / "sizes.json", {"detector": str(detector), "rows": rows, "offsets_A": OFFSETS_A,
                                           "kufieta_model": "identify's parameters only" if params_only else
                                           "identify's whole overlay",
                                           "gains": GAINS, "wall_s": time.perf_counter() - t0})
    md = table(rows)
    write_text_atomic(out / "sizes.md", md)
    plot(rows, out / "sizes.png")
    print(md)
    print(f"wall {time.perf_counter() - t0:.0f} s; wrote {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

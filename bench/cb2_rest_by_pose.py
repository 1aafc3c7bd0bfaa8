"""The current a CB2 joint holds at rest, by pose: how repeatable it is at one pose for the robot and for its twin,
and how it scales with UR's own model there, on the runs the Kufieta model was fitted on and on TEST
(docs/validation.md, "The current held at rest, by pose").

    python bench/cb2_rest_by_pose.py [--cache results/residual_bins]

Reads the replays ``bench/residual_bins.py`` caches (the Kufieta robot's identified model on its six fit runs and
on TEST; run that first). A *rest* is a stretch of at least 10 samples where every joint's target speed is below
1e-3 rad/s; its first 3 samples are skipped; per rest and joint the mean measured current, twin current and UR's
target current (UR's gravity model at rest). Rests are grouped by pose (every joint's measured angle rounded to
0.05 rad). Printed per joint (J1-J3) and run set:

1. *Repeatability at one pose*: the pooled standard deviation, within poses visited at least twice, of
   (robot - UR) and of (twin - UR): how much of the held current depends on the history (friction held from
   the motion before) rather than on the pose.
2. *Against UR's model*: the least-squares line robot = a * UR + b over the rests, for the fit runs, for TEST and
   for both together, and the same for the twin.
3. *How much a constant could do on TEST*: TEST's current RMS (its first 0.5 s left out, as ``residual_bins.py``
   keeps it) as a multiple of UR's model, as replayed, with the fit runs' mean residual added to the twin (a
   current offset identified on them), and with TEST's own mean residual (an oracle: the most any constant can do).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
REST_RAD_S = 1e-3
MIN_REST, SKIP = 10, 3
POSE_STEP_RAD = 0.05


def rests(d: dict) -> list[tuple]:
    """``(pose key, robot (6,), twin (6,), UR (6,))`` per rest of one cached replay."""
    still = (np.abs(d["w"]) < REST_RAD_S).all(axis=1)
    out, i, n = [], 0, still.size
    while i < n:
        if not still[i]:
            i += 1
            continue
        k = i
        while k < n and still[k]:
            k += 1
        if k - i >= MIN_REST and i > 0:
            sl = slice(i + SKIP, k)
            key = tuple(np.round(d["q"][i] / POSE_STEP_RAD).astype(int))
            out.append((key, d["meas"][sl].mean(0), d["sim"][sl].mean(0), d["ur"][sl].mean(0)))
        i = k
    return out


def pooled_sd(groups: list[np.ndarray]) -> tuple[float, int]:
    """Pooled within-group standard deviation over groups of two or more, and the number of rests in them."""
    g = [x for x in groups if x.size >= 2]
    if not g:
        return float("nan"), 0
    ss = sum(float(((x - x.mean()) ** 2).sum()) for x in g)
    dof = sum(x.size - 1 for x in g)
    return float(np.sqrt(ss / dof)), sum(x.size for x in g)


def line(x: np.ndarray, y: np.ndarray) -> str:
    a, b = np.linalg.lstsq(np.c_[x, np.ones_like(x)], y, rcond=None)[0]
    return f"{a:.2f} UR {b:+.2f} A"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", default=str(REPO / "results" / "residual_bins"))
    args = ap.parse_args()
    files = sorted(Path(args.cache).glob("kufieta_28C_*.npz"))
    if not files:
        raise SystemExit(f"no cached replays in {args.cache}: run python bench/residual_bins.py first")
    sets: dict[str, list[tuple]] = {"fit runs": [], "TEST": []}
    for f in files:
        d = dict(np.load(f))
        sets["TEST" if int(d["role"][0]) else "fit runs"] += rests(d)
    print("| joint | runs | rests (at a pose visited twice) | within-pose SD robot - UR / twin - UR [A] | UR's current "
          "at rest [A] | robot = | twin = |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for j in range(3):
        both_ur, both_r, both_t = [], [], []
        for label, rs in sets.items():
            by_pose: dict[tuple, list[tuple[float, float]]] = {}
            for key, r, t, u in rs:
                by_pose.setdefault(key, []).append((r[j] - u[j], t[j] - u[j]))
            sd_r, n2 = pooled_sd([np.array([p[0] for p in v]) for v in by_pose.values()])
            sd_t, _ = pooled_sd([np.array([p[1] for p in v]) for v in by_pose.values()])
            ur = np.array([u[j] for _, _, _, u in rs])
            rob = np.array([r[j] for _, r, _, _ in rs])
            tw = np.array([t[j] for _, _, t, _ in rs])
            both_ur.append(ur)
            both_r.append(rob)
            both_t.append(tw)
            print(f"| J{j + 1} | {label} | {len(rs)} ({n2}) | {sd_r:.2f} / {sd_t:.2f} | {ur.min():+.2f} .. "
                  f"{ur.max():+.2f} | {line(ur, rob)} | {line(ur, tw)} |")
        ur, rob, tw = (np.concatenate(x) for x in (both_ur, both_r, both_t))
        print(f"| J{j + 1} | both | {ur.size} | | | {line(ur, rob)} | {line(ur, tw)} |")
    replays = [dict(np.load(f)) for f in files]
    fit = [d for d in replays if not int(d["role"][0])]
    test = next(d for d in replays if int(d["role"][0]))
    k = test["keep"].astype(bool)

    def rms(x: np.ndarray) -> float:
        return float(np.sqrt(np.mean(x * x)))

    print("\n| joint | TEST x UR's model: as replayed | + the fit runs' mean residual | + TEST's own mean (oracle) |")
    print("| --- | --- | --- | --- |")
    for j in range(6):
        c = float(np.mean(np.concatenate([(d["meas"] - d["sim"])[d["keep"].astype(bool), j] for d in fit])))
        e, ur = (test["meas"] - test["sim"])[k, j], (test["meas"] - test["ur"])[k, j]
        print(f"| J{j + 1} | {rms(e) / rms(ur):.2f} | {rms(e - c) / rms(ur):.2f} ({c:+.3f} A) | "
              f"{rms(e - e.mean()) / rms(ur):.2f} ({e.mean():+.3f} A) |")


if __name__ == "__main__":
    main()

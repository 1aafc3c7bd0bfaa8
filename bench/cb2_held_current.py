"""The current a joint holds at rest after a motion, robot against twin, and whether a friction feed-forward in the
twin's controller explains the difference (docs/validation.md, "The current held at rest").

    python bench/cb2_held_current.py [--overlay OVERLAY.json] [--runs TEST ...] [--nist] [--feed-forward sign 0.02]

1. *Held current* (J1-J3 of each Kufieta run, and with ``--nist`` the NIST log's held-out last 40 %): every stretch
   where the joint's target speed stays below 1e-3 rad/s for at least 10 samples, the sign of the joint's target
   speed over the motion before it ("last"), and the mean current there less UR's target current (which at rest is
   its gravity model), for the robot and for the twin (the log replayed under the Kufieta robot's identified model:
   ``--overlay`` as ``bench/residual_bins.py`` writes it, else identified here as ``bench/cb2_rest_target.py``
   does). Then per joint the mean of that excess times the last motion's sign: positive where the joint holds the
   friction of its last motion (the current keeps pushing the way it went), negative where it pulls back.
2. *A friction feed-forward* (``--feed-forward``): the twin's speed loop gets, outside its integrator, the joint's
   Coulomb level in amperes times ``sign(q̇_set)`` (``sign``; |q̇_set| > 1e-3 rad/s) or ``tanh(q̇_set / v)``
   (a number ``v`` in rad/s), so that at a stop the friction leaves the current with the setpoint instead of staying
   in the integrator. Applied by patching the reference (numpy) drive for this script only (``feed_forward``): the
   package has no such option. Current RMS of each run, whole run after its first 0.5 s (NIST: its held-out part),
   as a multiple of UR's own model, per joint, the reference drive without and with each variant.

The numpy drive steps about 40 x slower than the compiled loop: 2-6 minutes per replay.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

REST_RAD_S = 1e-3
MIN_REST = 10
NIST_HOLD_FROM = 0.6  # the discrepancy workflow's split (bench/residual_bins.py)
NIST_OFFSETS_A = {"elbow": 0.094, "wrist_1": 0.170, "wrist_3": -0.113}  # as bench/residual_bins.py replays NIST


@contextlib.contextmanager
def feed_forward(form: str | None):
    """Within the block, replays step the reference drive, whose speed loop adds the Coulomb feed-forward of
    ``form`` (``None``: the reference drive as it is)."""
    from ur5fault.sim.drive import controller, state
    from ur5fault.sim.engine import Simulator
    from ur5fault.twin import replay

    servo, speed_loop, simulator = state.NumpyDrive.servo, controller.speed_loop, replay.Simulator
    ff = {"A": 0.0}

    def shape(qd_set):
        if form == "sign":
            return np.where(np.abs(qd_set) > REST_RAD_S, np.sign(qd_set), 0.0)
        return np.tanh(qd_set / float(form))

    def patched_servo(drive, q_set, qd_set, nz):
        p = drive._p
        ff["A"] = p("t_coulomb") / (p("kt") * p("ratio")) * shape(qd_set) if form else 0.0
        return servo(drive, q_set, qd_set, nz)

    def patched_speed_loop(w_ref, w_fb, integ_A, kp, ki, ts_s, i_max_A):
        i_ref, integ = speed_loop(w_ref, w_fb, integ_A, kp, ki, ts_s, i_max_A)
        return np.clip(i_ref + ff["A"], -i_max_A, i_max_A), integ

    state.NumpyDrive.servo, controller.speed_loop = patched_servo, patched_speed_loop
    replay.Simulator = lambda params, **kw: Simulator(params, drive="numpy", **kw)
    try:
        yield
    finally:
        state.NumpyDrive.servo, controller.speed_loop, replay.Simulator = servo, speed_loop, simulator


def replay(name: str, over: dict | None) -> dict:
    """Robot, UR's model and the twin over samples 1..n, the target speed, and the samples scored."""
    from ur5fault.discrepancy.model import WORKFLOW_SEED
    from ur5fault.sim.effects import make_effect
    from ur5fault.twin import LogReplay

    if name == "nist":
        from cross_robot import NIST_LOG

        from ur5fault.logs import read_nist

        log, effects = read_nist(NIST_LOG), tuple(make_effect("current_sensor_offset", j, offset_A=v)
                                                  for j, v in NIST_OFFSETS_A.items())
    else:
        from cross_robot import read

        log, effects = read(name), ()
    rp = LogReplay(log, over, seed=WORKFLOW_SEED)
    sim = rp.run([effects], rp.n_samples)[0]
    n = sim.current_A.shape[0]
    t = log.t_s[1 : n + 1] - log.t_s[0]
    keep = log.logged_rows()[1 : n + 1] & (t >= 0.5)
    if name == "nist":
        keep &= t >= NIST_HOLD_FROM * t[-1]
    return {"t": t, "robot": log.current_A[1 : n + 1], "ur": log.target_current_A[1 : n + 1], "twin": sim.current_A,
            "w": np.gradient(log.q_target_rad, log.t_s, axis=0)[1 : n + 1], "keep": keep}


def held(r: dict, j: int) -> list[tuple[float, float, float, float]]:
    """``(t_start, last sign, robot - UR, twin - UR)`` of each stretch at rest of joint ``j`` after a motion."""
    rest = np.abs(r["w"][:, j]) < REST_RAD_S
    edges = np.flatnonzero(np.diff(rest.astype(int)))
    out, last = [], 0.0
    for a, b in zip([0, *(edges + 1)], [*(edges + 1), rest.size]):
        if not rest[a]:
            if b - a >= MIN_REST:
                last = float(np.sign(np.mean(r["w"][a:b, j])))
            continue
        k = np.arange(a, b)[r["keep"][a:b]]  # the scored samples of the stretch
        if k.size >= MIN_REST and last:
            ur = r["ur"][k, j].mean()
            robot, twin = r["robot"][k, j].mean() - ur, r["twin"][k, j].mean() - ur
            out.append((float(r["t"][k[0]]), last, float(robot), float(twin)))
    return out


def held_table(name: str, r: dict) -> None:
    print(f"\n{name}: current held at rest less UR's target [A], robot / twin (last motion's sign)")
    print("| joint | stretches | robot: mean excess x last sign | twin | every stretch (t s, sign: robot / twin) |")
    print("| --- | --- | --- | --- | --- |")
    for j in range(3):
        h = held(r, j)
        if not h:
            continue
        rob = np.mean([s * a for _, s, a, _ in h])
        tw = np.mean([s * b for _, s, _, b in h])
        cells = "; ".join(f"{t:.1f} {s:+.0f}: {a:+.2f} / {b:+.2f}" for t, s, a, b in h)
        print(f"| J{j + 1} | {len(h)} | {rob:+.3f} | {tw:+.3f} | {cells} |")


def ratio_row(label: str, r: dict) -> str:
    k = r["keep"]
    model = np.sqrt(np.nanmean((r["robot"] - r["twin"])[k] ** 2, axis=0))
    ur = np.sqrt(np.nanmean((r["robot"] - r["ur"])[k] ** 2, axis=0))
    return f"| {label} | " + " | ".join(f"{m / u:.2f}" for m, u in zip(model, ur)) + " |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--overlay", help="the Kufieta robot's identified parameters (bench/residual_bins.py's "
                                      "kufieta_overlay.json); identified here without it")
    ap.add_argument("--runs", nargs="*", default=["TEST", "Movement_No5_Acc_slow_w_disturbance"])
    ap.add_argument("--nist", action="store_true", help="also the NIST log's held-out part, packaged model")
    ap.add_argument("--feed-forward", nargs="*", default=["sign"], metavar="FORM",
                    help="'sign' or a speed v [rad/s] for tanh(q̇_set / v); none: the held currents only")
    args = ap.parse_args()
    from cb2_rest_target import overlay

    over = overlay(args.overlay)
    names = [*args.runs, *(["nist"] if args.nist else [])]
    rows: dict[str, list[str]] = {}
    for name in names:
        with feed_forward(None):
            r = replay(name, None if name == "nist" else over)
        held_table(name, r)
        rows[name] = [ratio_row("reference drive", r)]
        for form in args.feed_forward:
            print(f"replaying {name} with the feed-forward {form}", file=sys.stderr, flush=True)
            with feed_forward(form):
                rf = replay(name, None if name == "nist" else over)
            held_table(f"{name}, feed-forward {form}", rf)
            rows[name].append(ratio_row(f"feed-forward {form}", rf))
    for name in names:
        print(f"\n{name}: current RMS / UR's model's")
        print("| twin | J1 | J2 | J3 | J4 | J5 | J6 |\n| --- | --- | --- | --- | --- | --- | --- |")
        print("\n".join(rows[name]))


if __name__ == "__main__":
    main()

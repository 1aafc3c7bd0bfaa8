"""How far a current-sensor gain and the torque-constant loss that reads the same differ in the logged signals
(docs/diagnostics.md, "The same campaign on another machine": why the fault-kind classifier confuses them).

    python bench/gain_vs_torque_constant.py [--joint elbow_joint] [--gain 1.2] [--seed 3]

A current-sensor gain ``g`` makes the drive's current loop drive the true current to ``i_ref / g``, and the speed
loop then raises ``i_ref`` by ``g``: the reading is ``g`` times a healthy robot's.  A torque-constant scale ``1/g``
(``K_t`` and ``K_e``) needs ``g`` times the current for the same torque: the reading is again ``g`` times.  They
differ only through the loops' dynamics and the back-EMF.  Three runs of one motion with the same noise seed
(healthy, the gain, the torque constant), one healthy run with another noise seed; on the chosen joint, the RMS of
each pair's difference in the logged current (raw and over 50 ms) and motor-encoder angle.  Then the current-noise
ratio of the twin features (``twin/residuals.noise_ratio``: RMS of the reading's second difference over a
twin's, here the healthy run of the other noise seed) on the chosen joint, at rest and over all samples, for the
three runs and for a healthy run with ``--latency-ms`` of setpoint latency (what the all-samples ratio also
answers to).  Prints one JSON line.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from ur5fault import RunSpec, Simulator, get_trajectory, make_effect
from ur5fault.sim.axes import JOINT_NAMES
from ur5fault.twin.residuals import command_conditions, noise_ratio


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2)))


def _smooth(x: np.ndarray, n: int = 50) -> np.ndarray:
    return np.convolve(x, np.ones(n) / n, "valid")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--joint", default="elbow_joint", choices=JOINT_NAMES)
    ap.add_argument("--gain", type=float, default=1.2)
    ap.add_argument("--seed", type=int, default=3, help="random_pick_and_place motion")
    ap.add_argument("--payload-kg", type=float, default=1.0)
    ap.add_argument("--latency-ms", type=float, default=1.5)
    a = ap.parse_args()
    traj = get_trajectory("random_pick_and_place", seed=a.seed)
    pay = make_effect("payload", mass_kg=a.payload_kg)
    specs = [RunSpec("healthy", seed=1, effects=(pay,)),
             RunSpec("gain", seed=1, effects=(pay, make_effect("current_sensor_gain", joint=a.joint, gain=a.gain))),
             RunSpec("torque_constant", seed=1,
                     effects=(pay, make_effect("torque_constant", joint=a.joint, scale=1.0 / a.gain))),
             RunSpec("healthy_other_noise", seed=2, effects=(pay,)),
             RunSpec("healthy_latency", seed=1, effects=(pay, make_effect("delay", delay_ms=a.latency_ms)))]
    res = Simulator().run(traj, specs)
    j = JOINT_NAMES.index(a.joint)
    i, qm = res["i_FB_A"][:, :, j], res["q_M_FB_rad"][:, :, j]
    pairs = {"gain_minus_torque_constant": (1, 2), "gain_minus_healthy": (1, 0), "noise_seeds": (0, 3)}
    out = {"joint": a.joint, "gain": a.gain, "motion_seed": a.seed, "current_rms_A": _rms(i[0])}
    for name, (p, q) in pairs.items():
        out[name] = {"current_A": _rms(i[p] - i[q]), "current_50ms_A": _rms(_smooth(i[p] - i[q])),
                     "motor_angle_rad": _rms(qm[p] - qm[q])}
    qd = np.gradient(res.q_set_rad, res.t_s, axis=0)
    cond = command_conditions(qd, np.gradient(qd, res.t_s, axis=0), float(res.t_s[1] - res.t_s[0]))
    twin = res["i_FB_A"][3]
    for where, mask in (("rest", cond["at rest"]), ("all", None)):
        out[f"noise_ratio_{where}"] = {name: round(float(noise_ratio(res["i_FB_A"][k], twin, mask)[j]), 4)
                                       for k, name in ((0, "healthy"), (1, "gain"), (2, "torque_constant"),
                                                       (4, "healthy_latency"))}
    print(json.dumps(out))


if __name__ == "__main__":
    main()

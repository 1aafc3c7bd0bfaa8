"""``identify`` finds a motor-angle ripple (effect ``motor_harmonic``) that a simulated replay carries, with its
period and phase, and calls it "not identifiable" on joints that carry none."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.sim.axes import JOINT_NAMES


@pytest.mark.slow
def test_identify_recovers_a_simulated_ripple_and_marks_joints_without_one(nist_path):
    from ur5fault import RunSpec, Simulator, make_effect
    from ur5fault.identify import identify
    from ur5fault.logs import MeasuredLog, read_nist
    from ur5fault.sim.params import load_params

    real = read_nist(nist_path).window(0.0, 32.0)
    p = load_params(overrides={"tcp_offset_m": list(real.tcp_offset_m), "joint_temperature_C": 28.0})
    truth = {1: (5.0, -0.012, 0.006), 3: (3.0, 0.004, -0.008)}  # joint: k per motor turn, sin_Nm, cos_Nm
    effects = tuple(make_effect("motor_harmonic", j + 1, sin_Nm=s, cos_Nm=c, periods_per_rev=k)
                    for j, (k, s, c) in truth.items())
    res = Simulator(p).run(real.to_trajectory(), [RunSpec("sim", 2, effects)], log_period_s=real.period_s)
    n = res.t_s.size
    sim_log = MeasuredLog("simulated", res.t_s, real.q_target_rad[1 : n + 1], res["q_FB_rad"][0], res["i_FB_A"][0],
                          temperature_C=np.full((n, 6), 28.0), payload_kg=real.payload_kg,
                          tcp_offset_m=real.tcp_offset_m)
    ident = identify(sim_log, p, sweep=False, n_boot=50)
    for j, (k, s, c) in truth.items():
        assert ident.get("ripple.periods_per_rev", j).value == k
        # the torque from the current ripple: each coefficient within 20 % of the amplitude.  identify takes the
        # loop's answer as exactly -T/K_t; the simulated loop passes 0.9-1.2x of it with a few degrees of phase
        # below 10 Hz (shoulder highest, ur5fault/identify/ripple.py), plus noise
        amp = np.hypot(s, c)
        assert abs(ident.get("ripple.sin_Nm", j).value - s) < 0.2 * amp, j
        assert abs(ident.get("ripple.cos_Nm", j).value - c) < 0.2 * amp, j
    for j in (0, 2):  # no ripple simulated there
        e = ident.get("ripple.amplitude_A", j)
        assert not e.identifiable and e.value == 0.0, e
    effects_out = ident.overlay(p)["effects"]
    assert [e["joint"] for e in effects_out] == [JOINT_NAMES[j] for j in truth]
    assert all(e["effect"] == "motor_harmonic" for e in effects_out)

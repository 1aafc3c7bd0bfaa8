"""``identify`` reports the load-dependent friction coefficient (effect ``load_friction``) a simulated replay
carries, significant and of the right size, as a check that the overlay does not write; a log without one gives an
interval holding zero.  The estimate reads about a quarter low (ur5fault/identify/loadfriction.py): the size is
checked to within a factor 1.5 either way, the sign and significance strictly."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.mark.slow
def test_identify_reports_a_simulated_load_friction_coefficient_and_writes_nothing(nist_path):
    from ur5fault import RunSpec, Simulator, make_effect
    from ur5fault.identify import identify
    from ur5fault.identify.loadfriction import KEY
    from ur5fault.logs import MeasuredLog, read_nist
    from ur5fault.sim.params import load_params

    real = read_nist(nist_path)
    p = load_params(overrides={"tcp_offset_m": list(real.tcp_offset_m), "joint_temperature_C": 28.0})
    mu = 0.10
    runs = [RunSpec("with", 2, (make_effect("load_friction", "shoulder_lift_joint", coeff=mu),)), RunSpec("none", 2)]
    res = Simulator(p).run(real.to_trajectory(), runs, log_period_s=real.period_s)
    n = res.t_s.size
    idents = [identify(MeasuredLog("simulated", res.t_s, real.q_target_rad[1 : n + 1], res["q_FB_rad"][r],
                                   res["i_FB_A"][r], temperature_C=np.full((n, 6), 28.0), payload_kg=real.payload_kg,
                                   tcp_offset_m=real.tcp_offset_m), p, sweep=False, n_boot=50) for r in range(2)]
    e = idents[0].get(KEY, 1)
    assert e.identifiable and e.lo > 0.0, e  # significant, of the physical sign
    assert mu / 1.5 < e.value < 1.5 * mu, e
    null = idents[1].get(KEY, 1)
    assert null.identifiable and null.lo <= 0.0 <= null.hi, null
    for ident in idents:  # reported, never written
        assert all(x["effect"] != "load_friction" for x in ident.overlay(p).get("effects", []))


def test_a_friction_law_without_a_stribeck_term_takes_every_moving_sample():
    """A model whose Stribeck rate is 0 (a valid law: no Stribeck term) has no Stribeck range to stay above: every
    moving sample is at speed (it divided by the rate and raised ZeroDivisionError inside ``identify``)."""
    from types import SimpleNamespace

    from ur5fault.identify.loadfriction import at_speed

    qd = np.array([[0.0], [0.05], [-0.5], [2.0]]).repeat(6, axis=1)
    fit = SimpleNamespace(moving=np.array([False, True, True, True])[:, None].repeat(6, axis=1),
                          sig=SimpleNamespace(qd_target_rad_s=qd))
    assert at_speed(fit, 1, 0.0).tolist() == [False, True, True, True]
    assert at_speed(fit, 1, 10.0).tolist() == [False, False, True, True]  # above 3 / 10 = 0.3 rad/s

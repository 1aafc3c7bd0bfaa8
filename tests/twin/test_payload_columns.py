"""The current a payload adds, per unit of its unknowns, against the DH Newton-Euler reference of the tests."""

from __future__ import annotations

import numpy as np

from ur5fault.sim.params import load_params
from ur5fault.twin.payload import payload_current_columns

from reference_ur5 import rnea

#: the simulator's payload inertia: a solid cube of 0.06 m edge (ur5fault/sim/multibody.py's stated assumption),
#: I = m a^2 / 6 about its centre
CUBE_INERTIA_PER_KG = 0.06**2 / 6.0


def test_columns_equal_newton_euler_of_a_point_mass():
    """Per kg and per kg*m of first moment, the current the payload adds equals the DH Newton-Euler reference's
    torque difference (tests/reference_ur5.py) over the torque constant and gear ratio."""
    dt, n = 0.008, 300
    t = np.arange(n) * dt
    rng = np.random.default_rng(11)
    q0, amp, w, ph = (rng.uniform(-2, 2, 6), rng.uniform(0.2, 0.6, 6), rng.uniform(1.0, 4.0, 6),
                      rng.uniform(0, 2 * np.pi, 6))
    q = q0 + amp * np.sin(w * t[:, None] + ph)
    qd = amp * w * np.cos(w * t[:, None] + ph)
    qdd = -amp * w**2 * np.sin(w * t[:, None] + ph)
    params = load_params()
    cols = payload_current_columns(params, q, dt)
    per_amp = np.asarray(params.motor.torque_constant_Nm_per_A) * np.asarray(params.gear.ratio)
    inertia = np.eye(3) * CUBE_INERTIA_PER_KG
    h = 0.01
    for k in (50, 150, 250):
        empty = rnea(q[k], qd[k], qdd[k])
        want = [rnea(q[k], qd[k], qdd[k], payload_mass_kg=1.0, payload_inertia_flange_kgm2=inertia) - empty]
        for axis in range(3):
            e = np.zeros(3)
            e[axis] = h
            up = rnea(q[k], qd[k], qdd[k], payload_mass_kg=1.0, payload_pos_flange_m=e,
                      payload_inertia_flange_kgm2=inertia)
            down = rnea(q[k], qd[k], qdd[k], payload_mass_kg=1.0, payload_pos_flange_m=-e,
                        payload_inertia_flange_kgm2=inertia)
            want.append((up - down) / (2 * h))
        np.testing.assert_allclose(cols[:, k], np.array(want) / per_amp, rtol=2e-3, atol=2e-5)
    assert np.abs(cols[0]).max() > 0.1  # a kilogram is a tenth of an ampere or more: the comparison tests something

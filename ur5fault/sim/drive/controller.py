"""Cascaded joint controller (paper Fig. 1): position loop on the resolver, motor-speed
loop on the encoder, current loop with back-EMF compensation (field-oriented for PMSM
joints, with ``i_d`` regulated to zero and d-q decoupling).

Gains follow textbook loop-shaping from bandwidths (docs/parameters.md):

* current PI:  ``K_p = 2 pi f_c L``, ``K_i = 2 pi f_c R``   (pole-zero cancellation of R-L)
* speed PI:    ``K_p = 2 pi f_v J / K_t``, ``K_i = K_p / T_i`` with
  ``J = J_rotor + J_link / N^2`` at the motor
* position P:  ``K_p = 2 pi f_p`` [1/s], plus the setpoint velocity as feed-forward.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray


@dataclasses.dataclass(frozen=True)
class Gains:
    """Per-joint controller gains, arrays of shape (6,) or (n_runs, 6)."""

    pos_kp_per_s: NDArray
    speed_kp_A_s_per_rad: NDArray
    speed_ki_A_per_rad: NDArray
    cur_kp_V_per_A: NDArray
    cur_ki_V_per_A_s: NDArray


def design_gains(ctrl, motor_inductance_H, motor_resistance_ohm, rotor_inertia_kgm2, torque_constant, ratio) -> Gains:
    """Controller gains from the bandwidths in :class:`ur5fault.sim.params.ControllerParams`.

    The motor values are the *nominal* ones the controller was tuned with; a fault that
    changes the real motor (e.g. a weaker torque constant) does not retune the controller.
    """
    two_pi = 2.0 * np.pi
    j_motor = np.asarray(rotor_inertia_kgm2) + np.asarray(ctrl.design_link_inertia_kgm2) / np.asarray(ratio) ** 2
    skp = two_pi * np.asarray(ctrl.speed_bw_Hz) * j_motor / np.asarray(torque_constant)
    return Gains(
        pos_kp_per_s=two_pi * np.asarray(ctrl.position_bw_Hz),
        speed_kp_A_s_per_rad=skp,
        speed_ki_A_per_rad=skp / np.asarray(ctrl.speed_integral_time_s),
        cur_kp_V_per_A=two_pi * np.asarray(ctrl.current_bw_Hz) * np.asarray(motor_inductance_H),
        cur_ki_V_per_A_s=two_pi * np.asarray(ctrl.current_bw_Hz) * np.asarray(motor_resistance_ohm),
    )


def position_loop(q_set_rad, qd_set_rad_s, q_fb_rad, kp_per_s, ff: float, ratio):
    """Motor-speed reference [rad/s, motor side] from the joint position error."""
    return ratio * (ff * qd_set_rad_s + kp_per_s * (q_set_rad - q_fb_rad))


def speed_loop(w_ref, w_fb, integ_A, kp, ki, ts_s: float, i_max_A):
    """PI speed loop with clamped integrator; returns (i_ref [A], new integrator [A])."""
    err = w_ref - w_fb
    integ = np.clip(integ_A + ki * ts_s * err, -i_max_A, i_max_A)
    return np.clip(kp * err + integ, -i_max_A, i_max_A), integ


def current_loop(i_ref_A, i_d_fb, i_q_fb, w_fb, integ_d, integ_q, kp, ki, ts_s: float, ke, cross, v_max):
    """PI current loops on d and q with back-EMF compensation and d-q decoupling.

    Returns ``(v_d_ref, v_q_ref, integ_d, integ_q)`` [V].  ``cross`` is ``m p L``
    (0 for DC-equivalent joints, whose d channel then stays at 0).
    """
    e_q = i_ref_A - i_q_fb
    e_d = -i_d_fb
    integ_q = np.clip(integ_q + ki * ts_s * e_q, -v_max, v_max)
    integ_d = np.where(cross != 0.0, np.clip(integ_d + ki * ts_s * e_d, -v_max, v_max), 0.0)
    v_q = kp * e_q + integ_q + ke * w_fb + cross * w_fb * i_d_fb
    v_d = np.where(cross != 0.0, kp * e_d + integ_d - cross * w_fb * i_q_fb, 0.0)
    return v_d, v_q, integ_d, integ_q

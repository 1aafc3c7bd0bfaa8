"""Per-run parameter arrays: the robot's parameters broadcast over the batch, with each
run's effects applied to its row.

Shapes: ``(n_runs, 6)`` per joint, ``(n_runs,)`` or ``(n_runs, 3)`` per run.  The engine
reads only these arrays, so an effect never needs code in the engine.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from .axes import N_JOINTS
from .drive.motor import back_emf_constant
from .effects import REGISTRY, EffectSpec
from .params import RobotParams
from .terms import MAX_HARMONICS


@dataclasses.dataclass
class RunArrays:
    """Actual (possibly faulty) parameters of every run in a batch."""

    gear_ratio: NDArray
    gear_stiffness_Nm_per_rad: NDArray
    gear_damping_Nms_per_rad: NDArray
    backlash_rad: NDArray
    friction_coulomb_Nm: NDArray
    friction_static_Nm: NDArray
    friction_viscous_Nms_per_rad: NDArray
    friction_temp_coeff_per_K: NDArray
    friction_sign_smoothing_rad_s: NDArray
    friction_is_lugre: NDArray
    friction_presliding_stiffness_Nm_per_rad: NDArray
    friction_bristle_damping_Nms_per_rad: NDArray
    friction_motor_side_share: NDArray
    friction_load_coeff: NDArray  # [-] Coulomb and static friction added per N*m of gear torque (``load_friction``)
    temperature_C: NDArray
    motor_is_pmsm: NDArray
    motor_kt_Nm_per_A: NDArray
    motor_ke_V_s_per_rad: NDArray
    motor_resistance_ohm: NDArray
    motor_inductance_H: NDArray
    motor_rotor_inertia_kgm2: NDArray
    motor_pole_pairs: NDArray
    cogging_Nm: NDArray
    cogging_periods_per_rev: NDArray
    motor_harmonic_Nm: NDArray  # (n_runs, 6, 2): sin and cos amplitudes of the effect ``motor_harmonic``
    motor_harmonic_per_rev: NDArray
    current_limit_A: NDArray
    resolver_noise_rad: NDArray
    resolver_lsb_rad: NDArray
    resolver_offset_rad: NDArray
    encoder_noise_rad: NDArray
    encoder_lsb_rad: NDArray
    encoder_speed_noise_rad_s: NDArray
    encoder_speed_lsb_rad_s: NDArray
    current_noise_A: NDArray
    current_lsb_A: NDArray
    current_gain: NDArray
    current_offset_A: NDArray
    payload_kg: NDArray
    payload_com_m: NDArray
    setpoint_delay_s: NDArray
    # data-driven terms (ur5fault/sim/terms.py; the engine's term hook reads them): harmonics in slots
    # (n_runs, 6, MAX_HARMONICS) with [..., 0] the sine and [..., 1] the cosine amplitude
    term_joint_harmonic_Nm: NDArray
    term_joint_harmonic_per_rev: NDArray
    term_coulomb_Nm: NDArray
    term_coulomb_width_rad_s: NDArray
    term_stribeck_Nm: NDArray
    term_stribeck_speed_rad_s: NDArray
    term_viscous_Nms_per_rad: NDArray
    term_quadratic_Nms2_per_rad2: NDArray
    term_gravity_scale: NDArray
    term_holding_Nm: NDArray
    term_holding_speed_rad_s: NDArray
    armature_kgm2: NDArray
    link_mass_kg: NDArray
    link_com_shift_m: NDArray  # (n_runs, 6, 3) in the link's body frame
    current_temp_drift_A_per_K: NDArray
    current_temp_reference_C: NDArray
    current_time_shift_s: NDArray
    position_time_shift_s: NDArray

    @property
    def n_runs(self) -> int:
        return self.gear_ratio.shape[0]


def build_run_arrays(params: RobotParams, effects: Sequence[Sequence[EffectSpec]], payload_kg: float) -> RunArrays:
    """Broadcast ``params`` over ``len(effects)`` runs and apply each run's effects.

    Args:
        params: the nominal robot.
        effects: per run, the effects it carries (applied in order).
        payload_kg: payload mass of the trajectory, before any payload effect [kg].
    """
    n = len(effects)

    def joint(values) -> NDArray:
        return np.tile(np.asarray(values, dtype=float), (n, 1))

    two_pi = 2.0 * np.pi
    g, f, m, s = params.gear, params.friction, params.motor, params.sensors
    is_pmsm = np.array([k == "pmsm" for k in m.kind])
    kt = np.asarray(m.torque_constant_Nm_per_A)
    arrays = RunArrays(
        gear_ratio=joint(g.ratio),
        gear_stiffness_Nm_per_rad=joint(g.stiffness_Nm_per_rad),
        gear_damping_Nms_per_rad=joint(g.damping_Nms_per_rad),
        backlash_rad=joint(g.backlash_rad),
        friction_coulomb_Nm=joint(f.coulomb_Nm),
        friction_static_Nm=joint(f.static_Nm),
        friction_viscous_Nms_per_rad=joint(f.viscous_Nms_per_rad),
        friction_temp_coeff_per_K=joint(f.viscous_temp_coeff_per_K),
        friction_sign_smoothing_rad_s=joint(f.sign_smoothing_rad_s),
        friction_is_lugre=np.tile(np.array([k == "lugre" for k in f.model]), (n, 1)),
        friction_presliding_stiffness_Nm_per_rad=joint(f.presliding_stiffness_Nm_per_rad),
        friction_bristle_damping_Nms_per_rad=joint(f.bristle_damping_Nms_per_rad),
        friction_motor_side_share=joint(f.motor_side_share),
        friction_load_coeff=np.full((n, N_JOINTS), REGISTRY["load_friction"].absent("coeff")),
        temperature_C=joint(params.joint_temperature_C),
        motor_is_pmsm=np.tile(is_pmsm, (n, 1)),
        motor_kt_Nm_per_A=joint(kt),
        motor_ke_V_s_per_rad=joint(back_emf_constant(kt, is_pmsm)),
        motor_resistance_ohm=joint(m.resistance_ohm),
        motor_inductance_H=joint(m.inductance_H),
        motor_rotor_inertia_kgm2=joint(m.rotor_inertia_kgm2),
        motor_pole_pairs=joint(m.pole_pairs),
        cogging_Nm=np.zeros((n, N_JOINTS)),
        cogging_periods_per_rev=np.full((n, N_JOINTS), REGISTRY["cogging"].absent("periods_per_rev")),
        motor_harmonic_Nm=np.zeros((n, N_JOINTS, 2)),
        motor_harmonic_per_rev=np.full((n, N_JOINTS), REGISTRY["motor_harmonic"].absent("periods_per_rev")),
        current_limit_A=joint(params.power.current_limit_A),
        resolver_noise_rad=joint(s.resolver_noise_rad),
        resolver_lsb_rad=joint(two_pi / np.asarray(s.resolver_counts_per_rev)),
        resolver_offset_rad=np.zeros((n, N_JOINTS)),
        encoder_noise_rad=joint(s.encoder_noise_rad),
        encoder_lsb_rad=joint(two_pi / np.asarray(s.encoder_counts_per_rev)),
        encoder_speed_noise_rad_s=joint(s.encoder_speed_noise_rad_s),
        encoder_speed_lsb_rad_s=joint(s.encoder_speed_lsb_rad_s),
        current_noise_A=joint(s.current_noise_A),
        current_lsb_A=joint(s.current_lsb_A),
        current_gain=np.ones((n, N_JOINTS)),
        current_offset_A=np.zeros((n, N_JOINTS)),
        payload_kg=np.full(n, float(payload_kg)),
        payload_com_m=np.zeros((n, 3)),
        setpoint_delay_s=np.zeros(n),
        **_term_fields(n),
    )
    for row, run_effects in enumerate(effects):
        for spec in run_effects:
            REGISTRY[spec.name].apply(arrays, row, spec.joint, dict(spec.values))
    return arrays


def _term_fields(n: int) -> dict[str, NDArray]:
    """The data-driven terms' fields at their absent values (the registry's defaults)."""
    h = MAX_HARMONICS
    zeros = np.zeros((n, N_JOINTS))

    def absent(effect: str, param: str, shape: tuple[int, ...] = (n, N_JOINTS)) -> NDArray:
        return np.full(shape, REGISTRY[effect].absent(param))

    return {
        "term_joint_harmonic_Nm": np.zeros((n, N_JOINTS, h, 2)),
        "term_joint_harmonic_per_rev": absent("torque_joint_harmonic", "periods_per_rev", (n, N_JOINTS, h)),
        "term_coulomb_Nm": zeros.copy(), "term_coulomb_width_rad_s": absent("torque_coulomb", "width_rad_s"),
        "term_stribeck_Nm": zeros.copy(), "term_stribeck_speed_rad_s": absent("torque_stribeck", "speed_rad_s"),
        "term_viscous_Nms_per_rad": zeros.copy(), "term_quadratic_Nms2_per_rad2": zeros.copy(),
        "term_gravity_scale": zeros.copy(), "term_holding_Nm": zeros.copy(),
        "term_holding_speed_rad_s": absent("torque_holding", "speed_rad_s"),
        "armature_kgm2": zeros.copy(), "link_mass_kg": zeros.copy(),
        "link_com_shift_m": np.zeros((n, N_JOINTS, 3)), "current_temp_drift_A_per_K": zeros.copy(),
        "current_temp_reference_C": absent("current_temperature_drift", "reference_C"),
        "current_time_shift_s": zeros.copy(), "position_time_shift_s": zeros.copy(),
    }

"""The one registry of effects: faults, deviations and operating conditions.

An *effect* has named parameters with units, valid ranges and a value that means
"absent".  Campaigns sweep effect parameters; the discrepancy workflow fits them; both
read this registry, so adding an effect is one new :class:`Effect` entry here.

An effect acts on a run by changing that run's row of the per-run parameter arrays
(:class:`ur5fault.sim.run_arrays.RunArrays`) before the simulation starts; the drive-chain
code never needs to know which effect changed a value.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from typing import Any

from ..errors import ParameterError, UnknownNameError
from ..util.checks import is_real
from . import effect_appliers as ap
from .axes import JOINT_NAMES, joint_index
from .effect_types import Effect, EffectKey, EffectParam
from .params import JOINT_TEMPERATURE_RANGE_C, NOMINAL_JOINT_TEMPERATURE_C


@dataclasses.dataclass(frozen=True)
class EffectSpec:
    """An effect as a run carries it: name, joint array index and parameter values.

    Build it with :func:`make_effect`, which takes joints the way a user writes them (1..6 or a name). The field
    is ``joint_index`` (0..5, or None for robot-level effects), so ``EffectSpec(name, joint=1, ...)``, which
    would mean joint 1 to a user and joint 2 to the arrays, is refused by Python instead of silently shifted.
    """

    name: str
    joint_index: int | None
    values: tuple[tuple[str, float], ...]

    def __post_init__(self) -> None:
        j = self.joint_index
        if j is not None and (isinstance(j, bool) or not isinstance(j, int) or not 0 <= j < len(JOINT_NAMES)):
            raise ParameterError(f"EffectSpec.joint_index = {j!r} must be 0..{len(JOINT_NAMES) - 1} or None "
                                 "(build effects with make_effect, joints 1..6 or names)")

    @property
    def joint(self) -> int | None:
        """The 0-based joint index (array position), None for robot-level effects."""
        return self.joint_index

    def value(self, key: str) -> float:
        return dict(self.values)[key]

    @property
    def is_absent(self) -> bool:
        """Its size (and any parameter that acts alone, :attr:`Effect.acts_alone`) at the registry's "absent" value:
        the run carries no such effect, whatever its shape (a cogging period at amplitude 0 is no fault)."""
        eff = REGISTRY[self.name]
        live = {p.name for p in eff.size_parameters()} | set(eff.acts_alone)
        return all(eff.param(k).absent == v for k, v in self.values if k in live)

    def describe(self) -> str:
        where = f" on {JOINT_NAMES[self.joint]}" if self.joint is not None else ""
        vals = ", ".join(f"{k}={v:g}" for k, v in self.values)
        return f"{self.name}{where} ({vals})"


def effects_of_keys(values: Iterable[tuple[str, Any]], where: str = "") -> tuple[EffectSpec, ...]:
    """Validated effects of ``(<effect>.<param>, value)`` pairs, one per effect in name order
    (``<effect>.joint`` is its joint); pairs whose key has no dot are not effects and are skipped."""
    by_effect: dict[str, dict[str, Any]] = {}
    for key, v in values:
        k = EffectKey.parse(key)
        if k is not None:
            by_effect.setdefault(k.effect, {})[k.param] = v
    out = []
    for name, vals in sorted(by_effect.items()):
        joint = vals.pop("joint", None)
        out.append(effect_of(name, joint, vals, where))
    return tuple(out)


def make_effect(name: str, joint: int | str | None = None, *, where: str = "", **values: Any) -> EffectSpec:
    """Validate and build an :class:`EffectSpec` (:func:`effect_of` with the values as keywords).

    Args:
        name: registry key; an unknown one lists the registered effects.
        joint: 1-based number, name or alias for per-joint effects.
        where: context (file and key path) for error messages.
        values: parameter values, at least one (a sizeless effect is refused: a fault of size 0 is no fault);
            missing ones take their "absent" value.
    """
    return effect_of(name, joint, values, where)


def effect_of(name: str, joint: int | str | None, values: Mapping[str, Any], where: str = "") -> EffectSpec:
    """:func:`make_effect` of a mapping of parameter values, as a file or a command line gives them: a key that
    is also an argument's name (``where``, ``name``) is an unknown parameter like any other, not an argument."""
    if name not in REGISTRY:
        raise UnknownNameError("effect", name, REGISTRY, where)
    eff = REGISTRY[name]
    loc = f"{where}: " if where else ""
    if eff.per_joint:
        if joint is None:
            raise ParameterError(f"{loc}effect {name!r} needs a joint (1..6 or one of {', '.join(JOINT_NAMES)})")
        j: int | None = joint_index(joint, where)
    else:
        if joint is not None:
            raise ParameterError(f"{loc}effect {name!r} acts on the whole robot and takes no joint")
        j = None
    if eff.params and not values:  # a fault of size 0 is no fault: say which size
        sizes = ", ".join(f"{p.name} [{p.lo:g}..{p.hi:g}{p.unit_text()}]" for p in eff.params)
        raise ParameterError(f"{loc}effect {name!r} has no size; give {sizes}")
    known = {p.name: p for p in eff.params}
    out = []
    for key in values:
        if key not in known:
            raise UnknownNameError(f"parameter of effect {name!r}", key, known, where)
    for p in eff.params:
        if p.name not in values and p.absent is None:
            raise ParameterError(f"{loc}effect {name!r} needs a value for {p.name!r} in {p.range_text()}")
        v = values.get(p.name, p.absent)
        if not is_real(v) or not math.isfinite(float(v)):
            raise ParameterError(f"{loc}{name}.{p.name} = {v!r} must be a number in {p.range_text()}")
        if not p.lo <= float(v) <= p.hi:
            raise ParameterError(f"{loc}{name}.{p.name} = {v!r} is out of range {p.range_text()}")
        out.append((p.name, float(v)))
    return EffectSpec(name, j, tuple(out))


# ----------------------------------------------------------------------------- appliers
#: a harmonic's size: its amplitude, the norm of its sine and cosine parts (the period is its shape)
_AMPLITUDE = ("sin_Nm", "cos_Nm")


def _harmonic_params(angle: str) -> tuple[EffectParam, ...]:
    return (EffectParam("sin_Nm", "N*m", -50.0, 50.0, 0.0, f"link torque amplitude of sin(k {angle})"),
            EffectParam("cos_Nm", "N*m", -50.0, 50.0, 0.0, f"link torque amplitude of cos(k {angle})"),
            EffectParam("periods_per_rev", "1/rev", 1.0, 200.0, 1.0, f"k: periods per revolution of the {angle}"))


_TERM_EFFECTS = [
    Effect("torque_joint_harmonic", "link torque periodic in the joint angle (eccentric or worn gear; data-driven)",
           _harmonic_params("joint angle"), True, ap.harmonic("term_joint_harmonic"), size_params=_AMPLITUDE),
    Effect("torque_coulomb", "Coulomb-like load torque tanh(w / width) (data-driven)",
           (EffectParam("torque_Nm", "N*m", -30.0, 30.0, 0.0, "level at speed"),
            EffectParam("width_rad_s", "rad/s", 1e-3, 1.0, 0.01, "speed of the smooth sign")),
           True, ap.both(ap.add("term_coulomb_Nm", "torque_Nm"),
                         ap.set_value("term_coulomb_width_rad_s", "width_rad_s")), size_params=("torque_Nm",)),
    Effect("torque_stribeck", "Stribeck-like load torque at low speed, fading above v_s (data-driven)",
           (EffectParam("torque_Nm", "N*m", -30.0, 30.0, 0.0, "level at low speed"),
            EffectParam("speed_rad_s", "rad/s", 1e-3, 2.0, 0.05, "Stribeck speed v_s")),
           True, ap.both(ap.add("term_stribeck_Nm", "torque_Nm"),
                         ap.set_value("term_stribeck_speed_rad_s", "speed_rad_s")), size_params=("torque_Nm",)),
    Effect("torque_viscous", "viscous load torque c w (data-driven)",
           (EffectParam("coeff_Nms_per_rad", "N*m*s/rad", -100.0, 100.0, 0.0, "c"),),
           True, ap.add("term_viscous_Nms_per_rad", "coeff_Nms_per_rad")),
    Effect("torque_quadratic", "speed-squared load torque c w|w| (seal or fluid drag; data-driven)",
           (EffectParam("coeff_Nms2_per_rad2", "N*m*s^2/rad^2", -500.0, 500.0, 0.0, "c"),),
           True, ap.add("term_quadratic_Nms2_per_rad2", "coeff_Nms2_per_rad2")),
    Effect("torque_gravity_scale", "load torque proportional to the model's own gravity torque on the joint "
           "(gravity-model error; data-driven)",
           (EffectParam("scale", "-", -1.0, 1.0, 0.0, "share of the joint's gravity torque added"),),
           True, ap.add("term_gravity_scale", "scale")),
    Effect("torque_holding", "torque held at rest in the direction of the last motion (friction that stays "
           "loaded when the joint stops; data-driven)",
           (EffectParam("torque_Nm", "N*m", -30.0, 30.0, 0.0, "level at rest"),
            EffectParam("speed_rad_s", "rad/s", 1e-3, 1.0, 0.02, "speed below which the joint is at rest")),
           True, ap.both(ap.add("term_holding_Nm", "torque_Nm"),
                         ap.set_value("term_holding_speed_rad_s", "speed_rad_s")), size_params=("torque_Nm",)),
    Effect("inertia", "added rotational inertia on the joint (armature; missing inertia; data-driven)",
           (EffectParam("inertia_kgm2", "kg*m^2", 0.0, 10.0, 0.0, "added to the joint's inertia"),),
           True, ap.add("armature_kgm2", "inertia_kgm2")),
    Effect("link_mass", "mass and centre-of-mass error of the link the joint moves (data-driven)",
           (EffectParam("mass_kg", "kg", -10.0, 30.0, 0.0, "added at the link's centre of mass"),
            *(EffectParam(f"com_{k}_m", "m", -0.5, 0.5, 0.0, f"centre-of-mass shift along the link's {k[1]} axis")
              for k in ("dx", "dy", "dz"))),
           True, ap.link_mass, size_params=("mass_kg",), acts_alone=("com_dx_m", "com_dy_m", "com_dz_m")),
    Effect("current_temperature_drift", "current-reading drift with joint temperature (sensor or thermal drift; "
           "data-driven)",
           (EffectParam("coeff_A_per_K", "A/K", -1.0, 1.0, 0.0, "c in c (T - T_ref)"),
            EffectParam("reference_C", "degC", *JOINT_TEMPERATURE_RANGE_C, NOMINAL_JOINT_TEMPERATURE_C, "T_ref")),
           True, ap.both(ap.add("current_temp_drift_A_per_K", "coeff_A_per_K"),
                       ap.set_value("current_temp_reference_C", "reference_C")), size_params=("coeff_A_per_K",)),
    Effect("current_time_shift", "logged current reading shifted in time (timestamp skew; data-driven)",
           (EffectParam("shift_ms", "ms", -50.0, 50.0, 0.0, "reading(t) = current(t - shift)"),),
           True, ap.add("current_time_shift_s", "shift_ms", 1e-3)),
    Effect("position_time_shift", "logged joint-position reading shifted in time (timestamp skew or lag; "
           "data-driven)",
           (EffectParam("shift_ms", "ms", -50.0, 50.0, 0.0, "reading(t) = position(t - shift)"),),
           True, ap.add("position_time_shift_s", "shift_ms", 1e-3)),
]

REGISTRY: dict[str, Effect] = {
    e.name: e
    for e in [
        Effect(
            "backlash",
            "gear backlash (clearance alpha of eq. (1))",
            (EffectParam("backlash_deg", "deg", 0.0, 5.0, 0.0, "clearance alpha"),),
            True,
            ap.set_value("backlash_rad", "backlash_deg", ap.DEG),
        ),
        Effect(
            "temperature",
            "joint temperature (viscous friction falls as the lubricant warms)",
            (EffectParam("temperature_C", "degC", *JOINT_TEMPERATURE_RANGE_C, NOMINAL_JOINT_TEMPERATURE_C,
                         "all joints"),),
            False,
            ap.temperature,
        ),
        Effect(
            "payload",
            "mass the gripper holds (when the trajectory grips it; hold and joint_sweep: throughout)",
            (EffectParam("mass_kg", "kg", 0.0, 5.0, None, "mass while gripped"),),
            False,
            ap.payload,
        ),
        Effect(
            "payload_com",
            "payload centre-of-mass offset from the TCP",
            tuple(EffectParam(k, "m", -0.3, 0.3, 0.0, "in the flange frame") for k in ("dx_m", "dy_m", "dz_m")),
            False,
            ap.payload_com,
        ),
        Effect(
            "coulomb_friction",
            "Coulomb and static friction scaled (wear, lubricant loss)",
            (EffectParam("scale", "-", 0.0, 10.0, 1.0, "factor on T_f,c and T_f,s"),),
            True,
            ap.both(ap.multiply("friction_coulomb_Nm", "scale"), ap.multiply("friction_static_Nm", "scale")),
        ),
        Effect(
            "load_friction",
            "load-dependent gear friction: Coulomb and static friction grow with the torque the strain-wave gear "
            "transmits (tooth and wave-generator bearing loads)",
            (EffectParam("coeff", "-", 0.0, 1.0, 0.0, "N*m of friction added per N*m of gear torque"),),
            True,
            ap.set_value("friction_load_coeff", "coeff"),
        ),
        Effect(
            "viscous_friction",
            "viscous friction scaled at every temperature",
            (EffectParam("scale", "-", 0.0, 10.0, 1.0, "factor on f_v"),),
            True,
            ap.multiply("friction_viscous_Nms_per_rad", "scale"),
        ),
        Effect(
            "viscous_temperature",
            "temperature sensitivity of viscous friction",
            (EffectParam("coeff_per_K", "1/K", 0.0, 0.2, None, "beta in f_v(T)"),),
            True,
            ap.set_value("friction_temp_coeff_per_K", "coeff_per_K"),
        ),
        Effect(
            "gear_stiffness",
            "gear torsional stiffness scaled (cracked or worn flexspline)",
            (EffectParam("scale", "-", 0.01, 10.0, 1.0, "factor on k"),),
            True,
            ap.multiply("gear_stiffness_Nm_per_rad", "scale"),
        ),
        Effect(
            "torque_constant",
            "motor torque constant scaled (demagnetisation); the controller is not retuned",
            (EffectParam("scale", "-", 0.2, 2.0, 1.0, "factor on K_t and K_e"),),
            True,
            ap.both(ap.multiply("motor_kt_Nm_per_A", "scale"), ap.multiply("motor_ke_V_s_per_rad", "scale")),
        ),
        Effect(
            "resolver_offset",
            "joint-side encoder (resolver) zero offset",
            (EffectParam("offset_deg", "deg", -5.0, 5.0, 0.0, "added to the reading"),),
            True,
            ap.add("resolver_offset_rad", "offset_deg", ap.DEG),
        ),
        Effect(
            "current_sensor_gain",
            "current-sensor gain error",
            (EffectParam("gain", "-", 0.5, 2.0, 1.0, "factor on the reading"),),
            True,
            ap.multiply("current_gain", "gain"),
        ),
        Effect(
            "current_sensor_offset",
            "current-sensor offset",
            (EffectParam("offset_A", "A", -2.0, 2.0, 0.0, "added to the reading"),),
            True,
            ap.add("current_offset_A", "offset_A"),
        ),
        Effect(
            "delay",
            "time delay between the logged setpoints and their execution (communication latency)",
            (EffectParam("delay_ms", "ms", 0.0, 50.0, 0.0, "in whole servo periods (0.1 ms)"),),
            False,
            ap.delay,
        ),
        Effect(
            "sensor_noise",
            "white noise of every sensor scaled (resolver, motor encoder angle and speed, current); quantisation, "
            "sample-and-hold, filters, offsets and gains unchanged. 0 is the noise-free reading a digital twin "
            "carries (the healthy robot's expected reading, not a second noisy robot)",
            (EffectParam("scale", "-", 0.0, 10.0, 1.0, "factor on the model's noise sigmas (sensors.*_noise_*; "
                         "upper bound an assumption, as the friction scales')"),),
            False,
            ap.sensor_noise,
        ),
        Effect(
            "cogging",
            "torque ripple periodic in motor angle (cogging or gear ripple)",
            (
                EffectParam("amplitude_Nm", "N*m", 0.0, 0.5, 0.0, "motor-side amplitude"),
                EffectParam("periods_per_rev", "1/rev", 1.0, 200.0, 6.0, "ripple periods per motor turn"),
            ),
            True,
            ap.both(ap.set_value("cogging_Nm", "amplitude_Nm"),
                    ap.set_value("cogging_periods_per_rev", "periods_per_rev")),
            size_params=("amplitude_Nm",),
        ),
        Effect(
            "motor_harmonic",
            "rotor torque periodic in the motor angle, with its phase (cogging, motor torque ripple or the strain-wave "
            "gear's wave generator; the phase is the log's: motor angle = ratio x joint angle)",
            (
                EffectParam("sin_Nm", "N*m", -0.5, 0.5, 0.0, "motor-side amplitude of sin(k * motor angle)"),
                EffectParam("cos_Nm", "N*m", -0.5, 0.5, 0.0, "motor-side amplitude of cos(k * motor angle)"),
                EffectParam("periods_per_rev", "1/rev", 1.0, 200.0, 1.0, "k: periods per motor turn"),
            ),
            True,
            ap.motor_harmonic,
            size_params=_AMPLITUDE,
        ),
        Effect(
            "breakaway_friction",
            "breakaway (static) friction scaled, Coulomb friction unchanged (stick-slip, lubricant loss at rest)",
            (EffectParam("scale", "-", 0.0, 10.0, 1.0, "factor on T_f,s"),),
            True,
            ap.multiply("friction_static_Nm", "scale"),
        ),
        Effect(
            "presliding_stiffness",
            "LuGre presliding (bristle) stiffness scaled: how far a stuck joint yields before it slides",
            (EffectParam("scale", "-", 0.01, 100.0, 1.0, "factor on sigma0"),),
            True,
            ap.multiply("friction_presliding_stiffness_Nm_per_rad", "scale"),
        ),
        Effect(
            "friction_share",
            "share of the joint friction acting on the motor side of the gear clearance (the rest on the link)",
            (EffectParam("motor_side_share", "-", 0.0, 1.0, None, "0: all on the link, 1: all on the rotor"),),
            True,
            ap.set_value("friction_motor_side_share", "motor_side_share"),
        ),
        # ---- data-driven terms (ur5fault/sim/terms.py): what the discrepancy workflow discovers outside the
        # entries above; the engine's term hook evaluates them (link torques, model terms, sensor terms)
        *_TERM_EFFECTS,
    ]
}

#: the white sensor noise silenced (``sensor_noise.scale = 0``): what the noise-free twins that give the twin
#: fits their regressors carry (:mod:`ur5fault.health.twin_regressors`), the campaign's
#: (:func:`ur5fault.campaign.digital_twin.regressor_runs`) and ``ur5fault diagnose``'s
#: (:func:`ur5fault.health.diagnosis.replay_twin`), so that the two compute their features alike
NOISE_FREE: EffectSpec = make_effect("sensor_noise", scale=0.0)

"""How each effect of the registry (:mod:`.effects`) changes a run's row of the per-run parameter arrays
(:class:`ur5fault.sim.run_arrays.RunArrays`): every function here is an ``apply(arrays, row, joint, values)``
(:class:`ur5fault.sim.interfaces.EffectApplier`) or builds one.

``arrays`` holds the batch's parameters, ``row`` is the run, ``joint`` the 0-based joint (unused by whole-robot
effects) and ``values`` the effect's validated parameters by name.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError
from .axes import JOINT_NAMES


def set_value(field: str, key: str, scale: float = 1.0):
    """``field[row, joint] = values[key] * scale``."""
    def apply(a, row, j, v):
        getattr(a, field)[row, j] = v[key] * scale

    return apply


def multiply(field: str, key: str):
    """``field[row, joint] *= values[key]``."""
    def apply(a, row, j, v):
        getattr(a, field)[row, j] *= v[key]

    return apply


def add(field: str, key: str, scale: float = 1.0):
    """``field[row, joint] += values[key] * scale``."""
    def apply(a, row, j, v):
        getattr(a, field)[row, j] += v[key] * scale

    return apply


def both(*fns):
    """Every applier of ``fns`` in turn."""
    def apply(a, row, j, v):
        for f in fns:
            f(a, row, j, v)

    return apply


def temperature(a, row, j, v):
    a.temperature_C[row, :] = v["temperature_C"]


def payload(a, row, j, v):
    a.payload_kg[row] = v["mass_kg"]


def delay(a, row, j, v):
    a.setpoint_delay_s[row] = v["delay_ms"] * 1e-3


#: the per-run white-noise sigmas of the sensors (:class:`ur5fault.sim.run_arrays.RunArrays`), all that the
#: effect ``sensor_noise`` scales: quantisation steps, filters, offsets and gains are not noise and stay
NOISE_FIELDS = ("resolver_noise_rad", "encoder_noise_rad", "encoder_speed_noise_rad_s", "current_noise_A")


def sensor_noise(a, row, j, v):
    """Every sensor's white-noise sigma of the run, on every joint, times ``scale``."""
    for field in NOISE_FIELDS:
        getattr(a, field)[row, :] *= v["scale"]


def payload_com(a, row, j, v):
    a.payload_com_m[row, :] = (v["dx_m"], v["dy_m"], v["dz_m"])


DEG = math.pi / 180.0


def harmonic(field: str):
    """Store a harmonic term in the joint's slot of the same period (added) or the first free one."""

    def apply(a, row, j, v):
        amp, per = getattr(a, f"{field}_Nm"), getattr(a, f"{field}_per_rev")
        k = v["periods_per_rev"]
        if v["sin_Nm"] == 0.0 and v["cos_Nm"] == 0.0:
            return
        slots = [i for i in range(per.shape[-1]) if per[row, j, i] == k or not np.any(amp[row, j, i])]
        if not slots:
            raise ParameterError(f"{field.removeprefix('term_')}: at most {per.shape[-1]} periods per joint "
                                 f"in one run ({JOINT_NAMES[j]})")
        i = slots[0]
        per[row, j, i] = k
        amp[row, j, i] += (v["sin_Nm"], v["cos_Nm"])

    return apply


def motor_harmonic(a, row, j, v):
    """Add to the joint's motor-angle harmonic of the same period, or set it if the joint has none; one period per
    joint and run (a second one is refused rather than silently merged)."""
    k = v["periods_per_rev"]
    amp = a.motor_harmonic_Nm[row, j]
    if v["sin_Nm"] == 0.0 and v["cos_Nm"] == 0.0:
        return
    if np.any(amp != 0.0) and a.motor_harmonic_per_rev[row, j] != k:
        raise ParameterError(f"motor_harmonic: one period per joint in one run ({JOINT_NAMES[j]} already has "
                             f"{a.motor_harmonic_per_rev[row, j]:g} per turn, not {k:g})")
    a.motor_harmonic_per_rev[row, j] = k
    amp += (v["sin_Nm"], v["cos_Nm"])


def link_mass(a, row, j, v):
    a.link_mass_kg[row, j] += v["mass_kg"]
    a.link_com_shift_m[row, j] += (v["com_dx_m"], v["com_dy_m"], v["com_dz_m"])

"""Degradation laws: gear wear that grows with the work the gear transmits.

State of one unit (a robot) after ``N`` duty cycles, per joint ``j``: the gear clearance
``alpha_j`` [rad] (eq. (1)'s backlash).  Between two inspections the clearance grows by a gamma
increment driven by the gear work of one duty cycle ``W_j = int |T_gear,j * qdot_j| dt`` [J]
(Archard: worn volume proportional to load x sliding distance; for a gear mesh the transmitted
work is that product up to a constant), so over ``dN`` cycles of work ``u = dN * W_j``:

    d alpha_j ~ Gamma(shape = u / u0, scale = c_j * u0),   E = c_j * u,   CV = sqrt(u0 / u)

(a gamma process in the cumulative work: independent, non-negative increments, so the clearance
never shrinks; van Noortwijk 2009, "A survey of the application of gamma processes in
maintenance", Reliab. Eng. Syst. Saf. 94:2-21).  ``c_j = c * exp(sigma * z_uj)`` varies from unit to
unit and joint to joint (lognormal, ``z ~ N(0, 1)``).  Friction and stiffness follow the clearance:
harmonic-drive degradation tests measure backlash, friction (starting) torque and torsional
stiffness degrading together before the flexspline fails (Machines 2025, 13(10), 918,
doi:10.3390/machines13100918), so

    Coulomb and static friction  x (1 + f_alpha * alpha_deg + f_N * N / 1e6)   (wear and lubricant ageing)
    gear stiffness               x max(k_min, 1 - k_alpha * alpha_deg)

Every random number comes from a stream keyed by (fleet seed, unit, inspection, purpose), so a
unit's history is the same whichever process computes it and whenever (resume, parallel).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...errors import ParameterError
from ...sim.axes import N_JOINTS
from ...sim.effects import EffectSpec, make_effect
from ...util.checks import is_real
from ...util.yamlsafe import plain

DEG = math.pi / 180.0
#: purposes of the random streams of one unit (the last entry of their seed key)
STREAM_UNIT, STREAM_WEAR, STREAM_NOISE = 0, 1, 2


@dataclasses.dataclass(frozen=True)
class WearLaw:
    """Constants of the degradation laws (YAML ``life.wear``); defaults and their reasons in docs/prognostics.md.

    Attributes:
        backlash_rate_deg_per_MJ: mean Archard coefficient c: clearance growth per MJ of gear work [deg/MJ].
        unit_sigma: lognormal sigma of c from unit to unit and joint to joint [-].
        work_scale_MJ: u0, work per independent wear event of the gamma process [MJ]; the increment over
            work u has a coefficient of variation sqrt(u0 / u).
        friction_per_deg: relative rise of Coulomb and static friction per degree of clearance [1/deg].
        friction_per_Mcycle: relative rise of Coulomb and static friction per million cycles (lubricant ageing).
        stiffness_loss_per_deg: relative loss of gear stiffness per degree of clearance [1/deg].
        stiffness_floor: smallest stiffness factor the law reaches [-].
    """

    backlash_rate_deg_per_MJ: float = 1.3e-3
    unit_sigma: float = 0.25
    work_scale_MJ: float = 0.05
    friction_per_deg: float = 5.0
    friction_per_Mcycle: float = 0.05
    stiffness_loss_per_deg: float = 2.0
    stiffness_floor: float = 0.5

    RANGES = {  # valid ranges (generous: the benchmark is meant to be run across them)
        "backlash_rate_deg_per_MJ": (0.0, 1.0, False),
        "unit_sigma": (0.0, 2.0, True),
        "work_scale_MJ": (0.0, 100.0, False),
        "friction_per_deg": (0.0, 100.0, True),
        "friction_per_Mcycle": (0.0, 10.0, True),
        "stiffness_loss_per_deg": (0.0, 100.0, True),
        "stiffness_floor": (0.01, 1.0, True),
    }

    def __post_init__(self) -> None:
        for name, (lo, hi, lo_closed) in self.RANGES.items():
            v = getattr(self, name)
            number = is_real(v)  # a numpy number too, kept as the Python number it holds (cache keys, manifests)
            ok = number and math.isfinite(v) and (lo <= v if lo_closed else lo < v) and v <= hi
            if not ok:
                span = f"{'[' if lo_closed else '('}{lo:g}, {hi:g}]"
                raise ParameterError(f"life.wear.{name} = {v!r} "
                                     + (f"is out of range {span}" if number else f"must be a number in {span}"))
            object.__setattr__(self, name, plain(v))

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any] | None, where: str = "life.wear") -> WearLaw:
        from ...errors import UnknownNameError

        data = dict(data or {})
        names = [f.name for f in dataclasses.fields(cls)]
        for key in data:
            if key not in names:
                raise UnknownNameError("key", key, names, where)
        try:
            return cls(**data)
        except ParameterError as exc:  # name the file and key path, as every other key of the life section
            text = str(exc)
            if where != "life.wear" and text.startswith("life.wear."):
                raise ParameterError(where + text[len("life.wear"):]) from None
            raise


def stream(seed: int, unit: int, inspection: int, purpose: int) -> np.random.Generator:
    """The random stream of one (unit, inspection, purpose): independent of process and order."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(unit), int(inspection), int(purpose)]))


def unit_rates_deg_per_MJ(law: WearLaw, seed: int, unit: int) -> NDArray:
    """c_j of one unit, ``(6,)`` [deg/MJ]: the mean coefficient times a lognormal unit-joint factor."""
    z = stream(seed, unit, 0, STREAM_UNIT).standard_normal(N_JOINTS)
    return law.backlash_rate_deg_per_MJ * np.exp(law.unit_sigma * z)


def gear_work_J(t_s: NDArray, q_rad: NDArray, t_gear_Nm: NDArray) -> NDArray:
    """Work the gear transmits over one duty cycle, ``int |T_gear * qdot| dt`` per joint [J].

    Args:
        t_s: ``(n,)`` times; q_rad, t_gear_Nm: ``(n, 6)`` link angle and gear torque (or batch-first
            ``(n_runs, n, 6)``).
    """
    w = np.gradient(q_rad, t_s, axis=-2)
    return np.trapezoid(np.abs(t_gear_Nm * w), t_s, axis=-2)


def advance_backlash_deg(law: WearLaw, rates_deg_per_MJ: NDArray, backlash_deg: NDArray, work_J: NDArray,
                         cycles: float, seed: int, unit: int, inspection: int) -> NDArray:
    """Clearance ``(6,)`` [deg] after ``cycles`` more duty cycles of gear work ``work_J`` per cycle,
    from the state at ``inspection`` (gamma increments from that inspection's stream)."""
    u_MJ = np.maximum(np.asarray(work_J, float), 0.0) * float(cycles) * 1e-6
    shape = u_MJ / law.work_scale_MJ
    rng = stream(seed, unit, inspection, STREAM_WEAR)
    draw = rng.standard_gamma(np.where(shape > 0, shape, 1.0))  # one draw per joint, always (a fixed stream)
    inc = np.where(shape > 0, draw * rates_deg_per_MJ * law.work_scale_MJ, 0.0)
    return np.asarray(backlash_deg, float) + inc


def friction_scale(law: WearLaw, backlash_deg: NDArray, cycles: float) -> NDArray:
    """Factor on Coulomb and static friction ``(6,)``: wear (clearance) and lubricant ageing (cycles)."""
    return 1.0 + law.friction_per_deg * np.asarray(backlash_deg, float) + law.friction_per_Mcycle * cycles * 1e-6


def stiffness_scale(law: WearLaw, backlash_deg: NDArray) -> NDArray:
    """Factor on the gear stiffness ``(6,)``."""
    return np.maximum(law.stiffness_floor, 1.0 - law.stiffness_loss_per_deg * np.asarray(backlash_deg, float))


#: the effects :func:`wear_effects` puts on a unit (so a model overlay beside them must not carry them)
WEAR_KINDS = frozenset({"backlash", "gear_stiffness", "coulomb_friction"})


def wear_effects(law: WearLaw, backlash_deg: NDArray, cycles: float) -> tuple[EffectSpec, ...]:
    """The registry effects a unit carries in this wear state (none for a joint with no wear)."""
    fr, st = friction_scale(law, backlash_deg, cycles), stiffness_scale(law, backlash_deg)
    out = []
    for j in range(N_JOINTS):
        a = float(backlash_deg[j])
        if a > 0:
            out.append(make_effect("backlash", j + 1, backlash_deg=a))
            out.append(make_effect("gear_stiffness", j + 1, scale=float(st[j])))
        if fr[j] != 1.0:
            out.append(make_effect("coulomb_friction", j + 1, scale=float(fr[j])))
    return tuple(out)

"""Data-driven terms: the dictionary functions shared by the discrepancy workflow's sparse regression
(``ur5fault.discrepancy.discovery``) and the simulation (the engine's term hook, :class:`TermHook`).

A term found in a measured log enters the model as an effect of the registry (``torque_*``, ``inertia``,
``link_mass``, ``current_temperature_drift``, ``*_time_shift``), so a model overlay carries it like any
other effect and ``simulate``, ``campaign run`` and ``discrepancy --model`` replay it.  Each term acts at
one place of the drive chain:

* **link torques** (``torque_*``): a load torque on the joint, added where friction acts (the link
  receives ``T_gear - T_f - T_term``), a function of the joint angle, the joint speed
  (``torque_holding``: at rest, in the direction of the last motion - friction that stays loaded when
  a joint stops), or the model's own static gravity torque on the joint.  The motor must supply it, so at low
  frequencies the current rises by ``T_term / (K_t N)``.  Velocity functions are applied
  semi-implicitly with their local slope, like the friction of eq. (2), so a steep one stays stable
  on a light link.
* **model terms** (``inertia``, ``link_mass``): changes of the runs' MuJoCo models before the run starts
  (joint armature; a link's mass and centre of mass), so the multibody carries them exactly.
* **sensor terms** (``current_temperature_drift``, ``current_time_shift``, ``position_time_shift``):
  applied to the logged readings, outside the control loops.  At the low frequencies where they are
  identified this equals a sensor error inside the loop (the loop then holds the reading where the
  physics needs it); a logged reading shifted in time is a timestamp skew of the log.

The run's joint temperature is constant (effect ``temperature``); a replay of a measured log
substitutes the log's temperature series for the temperature terms (``sensor_temperature_term``).
"""

from __future__ import annotations

import dataclasses
import math
import sys

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from ..errors import ParameterError
from .axes import JOINT_NAMES
from .jitcache import protect

#: harmonic terms per joint and kind that one run can carry (slots of ``RunArrays``)
MAX_HARMONICS = 3
#: width of the smooth sign of the Stribeck-like term [rad/s] (assumption: well below any commanded
#: speed, like ``friction.sign_smoothing_rad_s``, but wide enough for the 8 ms samples of a log)
STRIBECK_SIGN_WIDTH_RAD_S = 0.01


# ------------------------------------------------------------------------------------ dictionary functions
def harmonic(angle_rad: ArrayLike, periods_per_rev: ArrayLike) -> tuple[NDArray, NDArray]:
    """``sin(k angle)``, ``cos(k angle)``: a ripple of ``k`` periods per revolution of ``angle``."""
    x = np.asarray(periods_per_rev) * np.asarray(angle_rad)
    return np.sin(x), np.cos(x)


def coulomb(w_rad_s: ArrayLike, width_rad_s: ArrayLike) -> tuple[NDArray, NDArray]:
    """Coulomb-like ``tanh(w / width)`` and its slope ``d/dw``."""
    s = np.tanh(np.asarray(w_rad_s) / width_rad_s)
    return s, (1.0 - s * s) / width_rad_s


def stribeck(w_rad_s: ArrayLike, speed_rad_s: ArrayLike) -> tuple[NDArray, NDArray]:
    """Stribeck-like ``tanh(w / w_s) exp(-(w / v_s)^2)``: a torque at low speed that fades above ``v_s``;
    returns the value and its slope ``d/dw``."""
    w = np.asarray(w_rad_s)
    s = np.tanh(w / STRIBECK_SIGN_WIDTH_RAD_S)
    e = np.exp(-((w / speed_rad_s) ** 2))
    slope = (1.0 - s * s) / STRIBECK_SIGN_WIDTH_RAD_S * e - s * e * 2.0 * w / np.asarray(speed_rad_s) ** 2
    return s * e, slope


def rest_weight(w_rad_s: ArrayLike, speed_rad_s: ArrayLike) -> tuple[NDArray, NDArray]:
    """How much a joint is at rest, ``exp(-(w / w_r)^2)`` (1 at rest, 0 in motion), and its slope."""
    w = np.asarray(w_rad_s)
    e = np.exp(-((w / speed_rad_s) ** 2))
    return e, -2.0 * w / np.asarray(speed_rad_s) ** 2 * e


def last_motion_sign(w_rad_s: NDArray, speed_rad_s: float, start: float = 0.0) -> NDArray:
    """Direction of the last motion faster than ``speed_rad_s`` at each sample of ``w`` ``(n,)`` (``start``
    before the first one): the memory of the holding term."""
    out = np.empty(w_rad_s.shape[0])
    s = start
    for i, w in enumerate(w_rad_s):
        if abs(w) > speed_rad_s:
            s = 1.0 if w > 0 else -1.0
        out[i] = s
    return out


def quadratic(w_rad_s: ArrayLike) -> tuple[NDArray, NDArray]:
    """Speed-squared drag ``w |w|`` and its slope ``2 |w|``."""
    w = np.asarray(w_rad_s)
    return w * np.abs(w), 2.0 * np.abs(w)


def time_shift(t_s: NDArray, y: NDArray, shift_s: float) -> NDArray:
    """``y(t - shift)`` by linear interpolation over the samples (ends held); ``y`` is ``(n,)``."""
    return np.interp(t_s - shift_s, t_s, y)


def sensor_temperature_term(coeff_A_per_K: ArrayLike, temperature_C: ArrayLike, reference_C: ArrayLike) -> NDArray:
    """Current-reading drift ``c (T - T_ref)`` [A]."""
    return np.asarray(coeff_A_per_K) * (np.asarray(temperature_C) - np.asarray(reference_C))


# ------------------------------------------------------------------------------------ the engine's hook
@dataclasses.dataclass
class TermHook:
    """The data-driven terms of a batch, evaluated inside :func:`ur5fault.sim.engine._integrate`.

    Its methods do nothing for the parts no run carries, so runs without terms pay nothing.  Arrays are the run
    arrays' term fields, batch axis first.
    """

    a: object  # RunArrays (not imported: the engine imports this module)
    link_torque: bool
    gravity: bool
    last_sign: NDArray | None = None  # holding terms: direction of each joint's last motion (n_runs, 6)

    @classmethod
    def build(cls, a) -> TermHook:
        """The batch's terms; a batch without any is a hook whose methods do nothing."""
        link = any(np.any(getattr(a, f) != 0.0) for f in LINK_TORQUE_FIELDS)
        return cls(a, bool(link), bool(np.any(a.term_gravity_scale != 0.0)))

    @property
    def any_term(self) -> bool:
        """Some run carries a term (link torque, model or sensor)."""
        a = self.a
        return bool(self.link_torque or np.any(a.armature_kgm2 != 0.0) or np.any(a.link_mass_kg != 0.0)
                    or np.any(a.link_com_shift_m != 0.0) or any(np.any(getattr(a, f) != 0.0) for f in SENSOR_FIELDS))

    # -- model terms, once before the run starts
    def prepare_model(self, mb) -> None:
        """Armature and link mass / centre-of-mass changes in every run's MuJoCo model."""
        a = self.a
        if self.any_term:  # (the models' derived constants are recomputed for any term, as they always were)
            if np.any(a.armature_kgm2 != 0.0):
                arm = mb.model_field("dof_armature")
                for r in range(a.n_runs):
                    arm[r][:6] = arm[r][:6] + a.armature_kgm2[r]
            if np.any(a.link_mass_kg != 0.0) or np.any(a.link_com_shift_m != 0.0):
                mass, ipos = mb.model_field("body_mass"), mb.model_field("body_ipos")
                bodies = mb.link_bodies()
                for r in range(a.n_runs):
                    for j, b in enumerate(bodies):
                        if a.link_mass_kg[r, j] == 0.0 and not np.any(a.link_com_shift_m[r, j]):
                            continue
                        new_kg = mass[r][b] + a.link_mass_kg[r, j]
                        if not new_kg > 0.0:  # a massless or negative link: the mass matrix is no longer positive
                            raise ParameterError(
                                f"link_mass on {JOINT_NAMES[j]}: mass_kg = {a.link_mass_kg[r, j]:g} would leave the "
                                f"link {new_kg:.3g} kg (it weighs {mass[r][b]:.3g} kg); a link's mass must stay "
                                "positive")
                        ipos[r][b] = ipos[r][b] + a.link_com_shift_m[r, j]
                        mass[r][b] = new_kg
            mb.model_changed()
        if self.link_torque and self.gravity:
            mb.gravity_torque()  # binds the kinematic fields before the run starts

    def static_load(self, q: NDArray, mb, dt: float) -> NDArray | float:
        """The link-torque terms' load at rest at ``q`` (held by the drive from the start), or 0."""
        if not self.link_torque:
            return 0.0
        return self.load_torque(q, np.zeros_like(q), np.ones_like(q), dt, mb.gravity_torque() if self.gravity else None)

    def step_load(self, q: NDArray, qd: NDArray, mb, dt: float) -> NDArray | float:
        """The link-torque terms' load over one physics step (:meth:`load_torque` with the multibody's mass-matrix
        diagonal and gravity torque), or 0."""
        if not self.link_torque:
            return 0.0
        return self.load_torque(q, qd, mb.mass_diagonal(), dt, mb.gravity_torque() if self.gravity else None)

    # -- link torques, every physics step
    def load_torque(self, q: NDArray, qd: NDArray, m_ii: NDArray, dt: float,
                    gravity_Nm: NDArray | None) -> NDArray:
        """Load torque of the terms on every joint ``(n_runs, 6)`` [N*m], velocity parts semi-implicit
        (compiled: :func:`_load_torque`; ``load_torque_reference`` is the same in numpy)."""
        a = self.a
        out = np.empty_like(q)
        if self.last_sign is None:
            self.last_sign = np.zeros_like(q)
        _load_torque(q, qd, m_ii, dt, gravity_Nm if gravity_Nm is not None else np.zeros_like(q),
                     a.term_joint_harmonic_Nm, a.term_joint_harmonic_per_rev, a.term_coulomb_Nm,
                     a.term_coulomb_width_rad_s, a.term_stribeck_Nm, a.term_stribeck_speed_rad_s,
                     a.term_viscous_Nms_per_rad, a.term_quadratic_Nms2_per_rad2, a.term_gravity_scale,
                     STRIBECK_SIGN_WIDTH_RAD_S, a.term_holding_Nm, a.term_holding_speed_rad_s, self.last_sign, out)
        return out

    def load_torque_reference(self, q: NDArray, qd: NDArray, m_ii: NDArray, dt: float,
                              gravity_Nm: NDArray | None) -> NDArray:
        """:meth:`load_torque` with the numpy dictionary functions (the reference of the compiled path)."""
        a = self.a
        t = np.zeros_like(q)  # position-dependent part
        tv = np.zeros_like(q)  # velocity-dependent part
        slope = np.zeros_like(q)
        s, c = harmonic(q[..., None], a.term_joint_harmonic_per_rev)
        t += np.sum(a.term_joint_harmonic_Nm[..., 0] * s + a.term_joint_harmonic_Nm[..., 1] * c, axis=-1)
        for scale, (f, df) in ((a.term_coulomb_Nm, coulomb(qd, a.term_coulomb_width_rad_s)),
                               (a.term_stribeck_Nm, stribeck(qd, a.term_stribeck_speed_rad_s)),
                               (a.term_viscous_Nms_per_rad, (qd, np.ones_like(qd))),
                               (a.term_quadratic_Nms2_per_rad2, quadratic(qd))):
            tv += scale * f
            slope += scale * df
        if gravity_Nm is not None:
            t += a.term_gravity_scale * gravity_Nm
        if self.last_sign is None:
            self.last_sign = np.zeros_like(q)
        moving = np.abs(qd) > a.term_holding_speed_rad_s
        self.last_sign = np.where(moving, np.sign(qd), self.last_sign)
        f, df = rest_weight(qd, a.term_holding_speed_rad_s)
        tv += a.term_holding_Nm * self.last_sign * f
        slope += np.abs(a.term_holding_Nm * self.last_sign * df)
        # a dissipative slope is integrated like implicit friction (drive/friction.py); the holding term's
        # steep edges with their magnitude (stable on a light link; its level at rest is unchanged)
        return t + tv / (1.0 + np.maximum(slope, 0.0) * dt / m_ii)

    # -- sensor terms, on the logged readings after the run
    def apply_sensor_terms(self, log: dict[str, NDArray], t_log: NDArray) -> None:
        """Temperature drift of the current reading and time shifts of the logged readings, in place."""
        a = self.a
        if not any(np.any(getattr(a, f) != 0.0) for f in SENSOR_FIELDS):
            return
        if np.any(a.current_temp_drift_A_per_K != 0.0):
            log["i_FB_A"] += sensor_temperature_term(a.current_temp_drift_A_per_K, a.temperature_C,
                                                     a.current_temp_reference_C)[:, None, :]
        for name, field in (("i_FB_A", "current_time_shift_s"), ("q_FB_rad", "position_time_shift_s")):
            shift = getattr(a, field)
            for r, j in zip(*np.nonzero(shift)):
                log[name][r, :, j] = time_shift(t_log, log[name][r, :, j], shift[r, j])


#: run-array fields of the link-torque terms and of the sensor terms (the hook's switches)
LINK_TORQUE_FIELDS = ("term_joint_harmonic_Nm", "term_coulomb_Nm", "term_stribeck_Nm",
                      "term_viscous_Nms_per_rad", "term_quadratic_Nms2_per_rad2", "term_gravity_scale",
                      "term_holding_Nm")
SENSOR_FIELDS = ("current_temp_drift_A_per_K", "current_time_shift_s", "position_time_shift_s")


# ------------------------------------------------------------------------------------ compiled paths
@njit(cache=True)
def _load_torque(q, qd, m_ii, dt, grav, amp_j, per_j, coul, coul_w, strib, strib_v, visc, quad,
                 grav_scale, sign_w, hold, hold_w, last_sign, out):
    """The terms' load torque, run by run and joint by joint (:func:`load_torque_rj`)."""
    n, nj = q.shape
    for r in range(n):
        for j in range(nj):
            out[r, j] = load_torque_rj(r, j, q[r, j], qd[r, j], m_ii[r, j], dt, grav[r, j], amp_j, per_j, coul,
                                       coul_w, strib, strib_v, visc, quad, grav_scale, sign_w, hold, hold_w, last_sign)


@njit(cache=True, inline="always")
def load_torque_rj(r, j, q, w, m_ii, dt, grav, amp_j, per_j, coul, coul_w, strib, strib_v, visc, quad,
                   grav_scale, sign_w, hold, hold_w, last_sign):
    """Load torque of joint ``j`` of run ``r`` at angle ``q``, speed ``w``, skipping absent terms (same equations
    as :meth:`TermHook.load_torque_reference`); updates the holding term's ``last_sign[r, j]``."""
    t = grav_scale[r, j] * grav
    for h in range(amp_j.shape[2]):
        if amp_j[r, j, h, 0] != 0.0 or amp_j[r, j, h, 1] != 0.0:
            x = per_j[r, j, h] * q
            t += amp_j[r, j, h, 0] * math.sin(x) + amp_j[r, j, h, 1] * math.cos(x)
    tv = 0.0
    slope = 0.0
    if coul[r, j] != 0.0:
        s = math.tanh(w / coul_w[r, j])
        tv += coul[r, j] * s
        slope += coul[r, j] * (1.0 - s * s) / coul_w[r, j]
    if strib[r, j] != 0.0:
        s = math.tanh(w / sign_w)
        vs = strib_v[r, j]
        e = math.exp(-((w / vs) ** 2))
        tv += strib[r, j] * s * e
        slope += strib[r, j] * ((1.0 - s * s) / sign_w * e - s * e * 2.0 * w / (vs * vs))
    if visc[r, j] != 0.0:
        tv += visc[r, j] * w
        slope += visc[r, j]
    if quad[r, j] != 0.0:
        tv += quad[r, j] * w * abs(w)
        slope += quad[r, j] * 2.0 * abs(w)
    if abs(w) > hold_w[r, j]:
        last_sign[r, j] = 1.0 if w > 0.0 else -1.0
    if hold[r, j] != 0.0:
        e = math.exp(-((w / hold_w[r, j]) ** 2))
        tv += hold[r, j] * last_sign[r, j] * e
        slope += abs(hold[r, j] * last_sign[r, j] * 2.0 * w / (hold_w[r, j] * hold_w[r, j]) * e)
    return t + tv / (1.0 + max(slope, 0.0) * dt / m_ii)

protect(sys.modules[__name__])  # the numba cache of the functions above verified on read (jitcache.py)

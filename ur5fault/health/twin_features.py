"""Digital-twin residual features of one run: what the robot measured minus what its twin predicts.

The twin is the same commanded motion run through the robot's model (the nominal one, or a ``--model``
overlay) with the configured payload mass and the logged temperatures, an independent noise seed and no
knowledge of the fault or of the nuisance a robot does not know (its payload's true centre of mass, its
setpoint latency).  Their difference removes what the motion, payload and temperature do to a signal
and leaves the fault (and the unknown nuisance, and twice the sensor noise).

Residuals (``(n_log, 6)``, measured - twin):

* ``current``: current-sensor reading ``i_FB`` [A];
* ``position``: resolver reading ``q_FB`` [rad];
* ``mismatch``: encoder mismatch ``q_M,FB / N - q_FB`` [rad].

Features per joint ``j`` (units in the names):

* ``twin_<signal>_mean_<unit>_<cond>_j`` and ``twin_<signal>_rms_<unit>_<cond>_j``: mean and RMS of the
  residual under each motion condition of :func:`ur5fault.twin.motion_conditions` (``rest``, ``speed``,
  ``reversal``, ``accel``; from the commanded motion, which the robot knows); NaN where the motion never
  meets the condition on that joint.
* ``twin_est_*_j``: least-squares projections of the residual onto linearised signatures of the
  library's effects (:mod:`ur5fault.discrepancy.library` simulates the same secants; here they are
  written in closed form from the twin's own signals, because a campaign cannot afford a probe batch
  per run).  Two joint fits per joint:

  - current residual ~ ``a`` * 1 + ``b`` * i_twin + ``c`` * i_coulomb, where i_twin is the twin's motor current
    simulated without sensor noise (:mod:`ur5fault.health.twin_regressors`: the regressors' shapes carry no
    noise of the twin's, whose reading the residual subtracts), i_coulomb =
    sign(w) T_level(w) / (K_t N) (0 at rest) is the motor current that carries the twin's Coulomb/static friction at
    the commanded speed w: ``twin_est_current_offset_A`` = a (a current-sensor offset gives its offset:
    the loops hold the true current where the motion needs it, so the reading carries the offset);
    ``twin_est_current_gain_err`` = b (a gain error g - 1 gives g - 1; a torque-constant scale s needs
    1/s times the current, b = 1/s - 1: the two are the same shape in the current and told apart only
    by the rest of the signals); ``twin_est_coulomb_scale_err`` = c (Coulomb scale - 1);
  - mismatch residual ~ ``d`` * 1 + ``e`` * sign(T_twin) / 2 + ``f`` * T_twin / k, with T_twin the twin's
    gear torque (also simulated without sensor noise; since twin residuals format 11 with the payload CoM shift the
    current fit below finds fed back, :func:`ur5fault.health.twin_fit.com_corrected_torque`: on wrist 2 that shift
    decides which flank the gear is on) and k the gear stiffness: ``twin_est_mismatch_offset_rad``
    = d (a resolver offset o reads the link o too high, the position loop moves the link back by o and the motor
    with it, so the mismatch falls by o: d = -o); ``twin_est_backlash_rad`` = e (a clearance alpha swaps flanks
    with the sign of the gear torque: the mismatch jumps by alpha); ``twin_est_compliance_err`` = f (a
    stiffness scale s makes the windup T/(s k): f = 1/s - 1).

  The current fit is made over all six joints at once (:mod:`ur5fault.health.twin_fit`), each joint weighted
  by its noise, with four more columns shared by the joints for the nuisance the robot does not know: the
  payload's centre-of-mass shift along the flange's x, y, z (the gravity torque of the shift through the twin's
  kinematics, while the payload is held; with the campaign option ``twin_com_twins``, twin residuals format 4
  (now 6), the motor current of noise-free twins with the CoM shifted minus the unshifted one's, per metre: gravity, the
  payload's inertia and what the loops make of them, :mod:`ur5fault.health.twin_regressors`) and the setpoint
  latency (``-di_twin/dt``).
  An offset is thus estimated with a CoM that puts a near-constant torque on the wrists held out: the CoM's torque is
  the same on J2, J3 and J4, an offset sits on one joint.  Run-level estimates of the nuisance:
  ``twin_est_payload_com_<x|y|z>_m`` [m] and ``twin_est_latency_s`` [s].

* ``twin_est_<name>_se`` (the estimate's unit) and ``twin_est_<name>_t`` (-): every estimate's standard error
  (Newey-West over the log's instants: the residual is correlated from sample to sample) and its
  t-statistic, estimate / SE - how many standard errors the signature stands out of the residual, on the
  same scale whatever the motion (standard normal on a healthy run with white noise).  SE and t are NaN
  where the motion does not identify the estimate (e.g. the CoM columns without a payload).
* ``twin_gear_flank_share_j`` (-, twin residuals format 5): how far the motion reverses the joint's gear torque,
  the twin's (noise-free, CoM fed back as above) peak torque on its weaker flank as a share of its peak torque on either
  (:func:`flank_share`; 0 where the torque keeps one sign).  A backlash is crossed, and so can be seen, only
  where it exceeds :data:`FLANK_SHARE`, the share the mismatch fit's flank column counts as a flank: below it
  the torque only approaches zero from one side, which the backlash estimate can still fit (its SE is finite)
  but a clearance does not show (docs/diagnostics.md, "Backlash on the motions that reverse the gear torque").
* ``twin_current_noise_ratio_rest_j`` (-, twin residuals format 9): the RMS of the measured current reading's
  second difference over the twin reading's, over the samples where the joint's target is at rest
  (:func:`ur5fault.twin.residuals.noise_ratio`).  At rest the second difference of a 1 kHz reading is its white
  noise, so the ratio is how much louder the robot's current sensor is than the twin's.  A current-sensor gain
  ``g`` multiplies the sensor's noise with its signal (assumption, as the simulator's sensor model: the noise
  enters before the gain, as a shunt's and its amplifier's do), so the ratio reads about ``g``; a torque-constant
  loss that raises the reading by the same factor leaves the sensor's noise alone (ratio about 1).  Their current
  residuals are otherwise the same shape (``twin_est_current_gain_err`` above): this is what tells them apart
  (docs/diagnostics.md, "A current gain told from a torque-constant loss").  Only at rest: in motion the
  reading's millisecond-to-millisecond change also carries the loops' answer to the setpoints' steps, which the
  run's unknown latency changes (a healthy run with 1.5 ms of latency read 2.6 on the base over all samples).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
from numpy.typing import NDArray

from ..sim.axes import N_JOINTS
from ..sim.drive.friction import stribeck_level
from ..sim.params import RobotParams
from ..twin.residuals import command_conditions, noise_ratio
from .twin_fit import (
    RCOND_NUISANCE,
    com_corrected_torque,
    flange_kinematics,
    hac_fit,
    latency_column,
    noise_scale,
    payload_com_columns,
)

#: motion conditions used, short name -> the key of :func:`ur5fault.twin.motion_conditions`
CONDITIONS = {"rest": "at rest", "speed": "at speed", "reversal": "near velocity reversals", "accel": "accelerating"}
#: residual signals, name -> unit
SIGNAL_UNITS = {"current": "A", "position": "rad", "mismatch": "rad"}
#: projections, name -> unit (see the module docstring for what each measures)
ESTIMATE_UNITS = {"current_offset_A": "A", "current_gain_err": "-", "coulomb_scale_err": "-",
                  "mismatch_offset_rad": "rad", "backlash_rad": "rad", "compliance_err": "-"}
#: run-level estimates of the nuisance the robot does not know, name -> unit (the current fit's shared columns)
NUISANCE_UNITS = {"payload_com_x_m": "m", "payload_com_y_m": "m", "payload_com_z_m": "m", "latency_s": "s"}
#: smallest gear-torque magnitude whose sign counts as a flank, as a share of the joint's largest
#: (assumption: a gear torque within 2 % of its peak may sit in the clearance either way)
FLANK_SHARE = 0.02
#: the motion condition the noise ratio is taken in (module docstring: only at rest is it the sensor's noise)
NOISE_CONDITION = "at rest"


def feature_units() -> dict[str, str]:
    """Every twin feature name -> unit, in the order :func:`twin_features` writes them."""
    out = {}
    for j in range(1, N_JOINTS + 1):
        for sig, unit in SIGNAL_UNITS.items():
            for stat in ("mean", "rms"):
                for cond in CONDITIONS:
                    out[f"twin_{sig}_{stat}_{unit}_{cond}_j{j}"] = unit
        for name, unit in ESTIMATE_UNITS.items():
            out[f"twin_est_{name}_j{j}"] = unit
    for j in range(1, N_JOINTS + 1):  # after the first format's columns, which keep their order
        for name, unit in ESTIMATE_UNITS.items():
            out[f"twin_est_{name}_se_j{j}"] = unit
            out[f"twin_est_{name}_t_j{j}"] = "-"
    for name, unit in NUISANCE_UNITS.items():
        out[f"twin_est_{name}"] = unit
        out[f"twin_est_{name}_t"] = "-"
    for j in range(1, N_JOINTS + 1):  # twin residuals format 5
        out[f"twin_gear_flank_share_j{j}"] = "-"
    for j in range(1, N_JOINTS + 1):  # twin residuals format 9
        out[f"twin_current_noise_ratio_rest_j{j}"] = "-"
    return out


FEATURE_UNITS = feature_units()


@dataclasses.dataclass(frozen=True)
class CommandedMotion:
    """What the twin features take from the commanded motion and the twin's model alone, the same for every run
    of one trajectory and model (a campaign's batch builds it once: :func:`commanded_motion`).

    Attributes:
        dt_s: log period [s].
        q_set_rad: the commanded joint angles ``(n_log, 6)``.
        qd: commanded speed ``(n_log, 6)`` [rad/s] (``np.gradient`` of ``q_set_rad``).
        masks: :func:`ur5fault.twin.residuals.command_conditions` of the commanded motion, ``(n_log, 6)`` each.
        i_coulomb_A: the current fit's Coulomb column ``(n_log, 6)`` (module docstring) [A].
    """

    dt_s: float
    q_set_rad: NDArray
    qd: NDArray
    masks: dict[str, NDArray]
    i_coulomb_A: NDArray

    @functools.cached_property
    def flange(self) -> tuple[NDArray, NDArray]:
        """:func:`ur5fault.health.twin_fit.flange_kinematics` of the commanded angles (computed when first
        needed: only a run with a held payload's centre-of-mass columns needs it)."""
        return flange_kinematics(self.q_set_rad)


def commanded_motion(t_s: NDArray, q_set_rad: NDArray, params: RobotParams) -> CommandedMotion:
    """:class:`CommandedMotion` of log times ``t_s`` ``(n_log,)`` [s], commanded angles ``q_set_rad`` ``(n_log, 6)``
    and the twin's model ``params`` (friction levels, torque constants, gear ratios)."""
    dt = float(t_s[1] - t_s[0])
    qd = np.gradient(q_set_rad, dt, axis=0)
    qdd = np.gradient(qd, dt, axis=0)
    fr, mo = params.friction, params.motor
    level = stribeck_level(qd, np.asarray(fr.coulomb_Nm), np.asarray(fr.static_Nm), fr.stribeck_rate_s_per_rad)[0]
    conditions = command_conditions(qd, qdd, dt)
    # at rest the friction is static and holds whatever the load needs, so a Coulomb scale has no first-order
    # signature there; and the sign of a resting target's speed (rounding, ~1e-8 rad/s) is noise, which gave the
    # column a full friction level of random sign on every resting sample
    moving = ~conditions["at rest"]
    i_coulomb = np.where(moving, np.sign(qd) * level, 0.0) / (np.asarray(mo.torque_constant_Nm_per_A)
                                                              * np.asarray(params.gear.ratio))
    return CommandedMotion(dt, q_set_rad, qd, conditions, i_coulomb)


def _motion_for(t_s: NDArray, q_set_rad: NDArray, params: RobotParams, motion: CommandedMotion | None
                ) -> CommandedMotion:
    """``motion`` when given (checked to be of ``q_set_rad``'s length), else built from the commanded motion."""
    if motion is None:
        return commanded_motion(t_s, q_set_rad, params)
    if motion.qd.shape != np.shape(q_set_rad):
        raise ValueError(f"commanded motion of shape {motion.qd.shape} given for joint angles of shape "
                         f"{np.shape(q_set_rad)}")
    return motion


def flank_share(torque_Nm: NDArray) -> NDArray:
    """Per joint ``(6,)``: the peak of the gear torque ``torque_Nm`` ``(n, 6)`` on its weaker flank over its peak on
    either, ``min(max T, max -T) / max |T|`` clipped at 0 (0 for a joint that carries no torque): 0 where the
    torque keeps one sign, 1 where it swings equally both ways."""
    T = np.asarray(torque_Nm, dtype=float)
    peak = np.abs(T).max(axis=0)
    weaker = np.clip(np.minimum(T.max(axis=0), (-T).max(axis=0)), 0.0, None)
    return np.divide(weaker, peak, out=np.zeros_like(peak), where=peak > 0)


def projection_columns(t_s: NDArray, q_set_rad: NDArray, twin: dict[str, NDArray], params: RobotParams,
                       motion: CommandedMotion | None = None) -> tuple[list[NDArray], list[NDArray]]:
    """The regressors of the two least-squares fits, ``(n_log, 6)`` each: the current fit's (1, i_twin,
    i_coulomb) and the mismatch fit's (1, sign(T_twin) / 2, T_twin / k), as the module docstring defines them.
    ``motion``: :func:`commanded_motion` of ``t_s``, ``q_set_rad``, ``params`` when the caller has it."""
    motion = _motion_for(t_s, q_set_rad, params, motion)
    torque = twin["T_gear_Nm"]
    flank = np.where(np.abs(torque) > FLANK_SHARE * np.abs(torque).max(axis=0), np.sign(torque), np.nan)
    windup = torque / np.asarray(params.gear.stiffness_Nm_per_rad)
    ones = np.ones_like(torque)
    return [ones, twin["i_q_A"], motion.i_coulomb_A], [ones, 0.5 * np.nan_to_num(flank), windup]


def current_fit(t_s: NDArray, q_set_rad: NDArray, residual_A: NDArray, twin: dict[str, NDArray], params: RobotParams,
                payload_kg: float = 0.0, payload_held: NDArray | None = None, motion: CommandedMotion | None = None
                ) -> tuple[NDArray, NDArray, NDArray]:
    """The current fit over all joints (module docstring): ``(coef, se)`` of the per-joint estimates, ``(6, 3)``
    each (offset, gain error, Coulomb scale error), and the nuisance's ``(4, 2)`` (CoM x, y, z, latency; estimate
    and SE).  ``motion``: as :func:`projection_columns` takes it.  The CoM columns are ``twin["com_A_per_m"]``
    ``(n, 6, 3)`` [A/m] when given (noise-free twins with the CoM shifted: :mod:`ur5fault.health.twin_regressors`,
    what campaigns with ``twin_com_twins`` and ``ur5fault diagnose`` for their detectors pass), else the CoM's
    gravity torque in closed form (:func:`ur5fault.health.twin_fit.com_columns`, zero where ``payload_held`` is
    false)."""
    motion = _motion_for(t_s, q_set_rad, params, motion)
    cols, _ = projection_columns(t_s, q_set_rad, twin, params, motion)
    n = residual_A.shape[0]
    com = payload_com_columns(q_set_rad, twin, params, payload_kg, payload_held, lambda: motion.flange)
    nuisance = np.concatenate([com, latency_column(twin["i_q_A"], motion.dt_s)[:, :, None]], axis=2)  # (n, 6, 4)
    per_joint = np.zeros((n, N_JOINTS, 3 * N_JOINTS))
    for j in range(N_JOINTS):
        for k, col in enumerate(cols):
            per_joint[:, j, 3 * j + k] = col[:, j]
    w = 1.0 / noise_scale(residual_A)  # joints with noisier currents count less
    fit = hac_fit(np.concatenate([per_joint, nuisance], axis=2) * w[None, :, None], residual_A * w[None, :],
                  RCOND_NUISANCE)
    k = 3 * N_JOINTS
    return (fit.coef[:k].reshape(N_JOINTS, 3), fit.se[:k].reshape(N_JOINTS, 3),
            np.stack([fit.coef[k:], fit.se[k:]], axis=1))


def twin_features(t_s: NDArray, q_set_rad: NDArray, meas: dict[str, NDArray], twin: dict[str, NDArray],
                  params: RobotParams, payload_kg: float = 0.0, payload_held: NDArray | None = None,
                  motion: CommandedMotion | None = None) -> dict[str, float]:
    """Twin residual features of one run.

    Args:
        t_s: log times ``(n_log,)`` [s].
        q_set_rad: commanded joint angles ``(n_log, 6)``.
        meas, twin: the run's and its twin's ``q_FB_rad``, ``q_M_FB_rad``, ``i_FB_A`` (``(n_log, 6)``): the
            residuals are their differences.  ``twin`` also the motor current ``i_q_A`` and gear torque
            ``T_gear_Nm`` the projections' shapes are taken from: those of the same twin **simulated without
            sensor noise** (:mod:`ur5fault.health.twin_regressors`).  The noisy twin's own signals carry the
            loops' answer to its sensor noise, correlated with its reading that the residual subtracts: an
            errors-in-variables bias (wrist 2's healthy gain estimate +0.43 median on the full dataset with twin
            format 2; docs/diagnostics.md, "Wrist 2's gain estimate on healthy runs").  Optionally
            ``com_A_per_m`` ``(n_log, 6, 3)``: the current fit's payload CoM columns (:func:`current_fit`).
        params: the twin's model (gear ratio and stiffness, torque constant, friction levels).
        payload_kg: the configured payload mass (the robot knows it) [kg]; 0: no centre-of-mass columns.
        payload_held: ``(n_log,)`` whether the payload is held (the gripper commands); None: throughout.
        motion: :func:`commanded_motion` of ``t_s``, ``q_set_rad`` and ``params``, when the caller has it (the
            runs of a batch share it); None: computed here.
    """
    motion = _motion_for(t_s, q_set_rad, params, motion)
    ratio = np.asarray(params.gear.ratio)
    mis_m = meas["q_M_FB_rad"] / ratio - meas["q_FB_rad"]
    mis_t = twin["q_M_FB_rad"] / ratio - twin["q_FB_rad"]
    res = {"current": meas["i_FB_A"] - twin["i_FB_A"], "position": meas["q_FB_rad"] - twin["q_FB_rad"],
           "mismatch": mis_m - mis_t}
    masks = motion.masks
    com = payload_com_columns(q_set_rad, twin, params, payload_kg, payload_held, lambda: motion.flange)
    cur_coef, cur_se, nuisance = current_fit(t_s, q_set_rad, res["current"], {**twin, "com_A_per_m": com}, params,
                                             payload_kg, payload_held, motion)
    # the gear torque the mismatch fit and the flank shares read: the twin's, with the payload CoM the current fit
    # found fed back (twin residuals format 11; twin_fit.com_corrected_torque)
    torque = com_corrected_torque(twin["T_gear_Nm"], com, nuisance[:3, 0], nuisance[:3, 1], params)
    _, mismatch_cols = projection_columns(t_s, q_set_rad, {**twin, "T_gear_Nm": torque}, params, motion)
    f: dict[str, float] = {}
    estimates = []
    for j in range(N_JOINTS):
        s = f"_j{j + 1}"
        for sig, unit in SIGNAL_UNITS.items():
            r = res[sig][:, j]
            for stat in ("mean", "rms"):
                for cond, key in CONDITIONS.items():
                    m = masks[key][:, j]
                    v = float("nan")
                    if m.any():
                        v = float(np.nanmean(r[m])) if stat == "mean" else float(np.sqrt(np.nanmean(r[m] ** 2)))
                    f[f"twin_{sig}_{stat}_{unit}_{cond}{s}"] = v
        mis = hac_fit(np.stack([col[:, j] for col in mismatch_cols], axis=1)[:, None, :], res["mismatch"][:, j:j + 1])
        for name, v in zip(ESTIMATE_UNITS, (*cur_coef[j], *mis.coef)):
            f[f"twin_est_{name}{s}"] = float(v)
        estimates.append((np.concatenate([cur_coef[j], mis.coef]), np.concatenate([cur_se[j], mis.se])))
    for j, (coef, se) in enumerate(estimates):
        for name, v, e in zip(ESTIMATE_UNITS, coef, se):
            f[f"twin_est_{name}_se_j{j + 1}"] = float(e)
            f[f"twin_est_{name}_t_j{j + 1}"] = _t(v, e)
    for name, (v, e) in zip(NUISANCE_UNITS, nuisance):
        f[f"twin_est_{name}"] = float(v)
        f[f"twin_est_{name}_t"] = _t(v, e)
    for j, share in enumerate(flank_share(torque)):
        f[f"twin_gear_flank_share_j{j + 1}"] = float(share)
    for j, r in enumerate(noise_ratio(meas["i_FB_A"], twin["i_FB_A"], masks[NOISE_CONDITION])):
        f[f"twin_current_noise_ratio_rest_j{j + 1}"] = float(r)
    return f


def _t(value: float, se: float) -> float:
    """estimate / SE; NaN where the SE is NaN or zero (the estimate not identified)."""
    return float(value / se) if np.isfinite(se) and se > 0 else float("nan")

"""The drive step compiled with numba: the equations of ``gearbox.py``, ``friction.py``, ``lugre.py``,
``motor.py``, ``power.py``, ``controller.py`` and ``sensors.py`` in the same order, as loops
over runs and joints.  Row indices come from ``state.PI`` / ``state.XI`` (frozen here as
constants).  Keep in step with the numpy modules: ``tests/sim/test_kernel.py`` compares them.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
from numba import njit

from .layout import PARAM_NAMES, PI, STATE_NAMES, XI

#: CRC-32 of the row layout these kernels were written for.  numba's cache (``cache=True``) checks only this
#: file's time stamp, not ``layout.py``'s, and the rows below are frozen into the compiled code: a layout
#: changed with this file untouched would reuse cached kernels that index the wrong rows (seen once as a
#: segfault after a merge).  A changed layout therefore stops here until this number is updated, which also
#: changes this file and so invalidates the cache.
LAYOUT_CRC32 = 3071488245
if zlib.crc32(("|".join(PARAM_NAMES) + "#" + "|".join(STATE_NAMES)).encode()) != LAYOUT_CRC32:
    raise ImportError("ur5fault/sim/drive/layout.py changed: update LAYOUT_CRC32 in ur5fault/sim/drive/kernel.py "
                      "(and check the row constants below) so numba recompiles the cached kernels")

# parameter rows
RATIO, K, C, BACKLASH_RAD, T_COULOMB, T_STATIC, FV, EPS = (
    PI[n] for n in ("ratio", "k", "c", "backlash_rad", "t_coulomb", "t_static", "fv", "eps"))
DECAY, GAIN_IV, CROSS, KE, KT, JR = (PI[n] for n in ("decay", "gain_iv", "cross", "ke", "kt", "jr"))
COG_AMP, COG_PER, V_LIM, I_MAX = (PI[n] for n in ("cog_amp", "cog_per", "v_lim", "i_max"))
RES_NOISE, RES_LSB, RES_OFF, ENC_NOISE, ENC_LSB = (PI[n] for n in ("res_noise", "res_lsb", "res_off", "enc_noise",
                                                                    "enc_lsb"))
ENCV_NOISE, ENCV_LSB, CUR_NOISE, CUR_LSB, CUR_GAIN, CUR_OFF = (
    PI[n] for n in ("encv_noise", "encv_lsb", "cur_noise", "cur_lsb", "cur_gain", "cur_off"))
POS_KP, SPD_KP, SPD_KI, CUR_KP, CUR_KI, FF = (PI[n] for n in ("pos_kp", "spd_kp", "spd_ki", "cur_kp", "cur_ki", "ff"))
RATIO_NOM, KE_NOM, CROSS_NOM = PI["ratio_nom"], PI["ke_nom"], PI["cross_nom"]
RES_C0, ENC_C0, CUR_A, CUR_C0, CUR_C1 = PI["res_c0"], PI["enc_c0"], PI["cur_a"], PI["cur_c0"], PI["cur_c1"]
LUGRE, SIGMA0, SIGMA1, SHARE = PI["lugre"], PI["sigma0"], PI["sigma1"], PI["share"]
MH_SIN, MH_COS, MH_PER = PI["mh_sin"], PI["mh_cos"], PI["mh_per"]
LOAD_FRIC = PI["load_fric"]
# state rows
TH_M, W_M, I_Q, I_D, V_Q, V_D = (XI[n] for n in ("th_m", "w_m", "i_q", "i_d", "v_q", "v_d"))
INTEG_V, INTEG_Q, INTEG_D = XI["integ_v"], XI["integ_q"], XI["integ_d"]
Y_RES, DY_RES, Y_ENC, DY_ENC, Y_IQ, Y_ID = (XI[n] for n in ("y_res", "dy_res", "y_enc", "dy_enc", "y_iq", "y_id"))
Q_FB, TH_FB, W_FB, IQ_FB, ID_FB, I_REF = (XI[n] for n in ("q_fb", "th_fb", "w_fb", "iq_fb", "id_fb", "i_ref"))
T_ID, T_F, Q_PREV, TH_PREV, IQ_PREV, ID_PREV = (XI[n] for n in ("t_id", "t_f", "q_prev", "th_prev", "iq_prev",
                                                               "id_prev"))
Z_L, Z_M, F_L, S_L, QD_PREV, T_F_M = (XI[n] for n in ("z_l", "z_m", "f_l", "s_l", "qd_prev", "t_f_m"))
MEMO_L, MEMO_M = XI["zl_w"], XI["zm_w"]  # first of six memo rows per side (layout.MEMO_NAMES)
LEVEL_FLOOR_NM, SMALL_X = 1e-12, 1e-4  # as lugre.py


@njit(cache=True, inline="always")
def _read(x, noise_std, z, lsb):
    v = x + noise_std * z
    if lsb > 0.0:
        return np.rint(v / lsb) * lsb
    return v


@njit(cache=True, inline="always")
def _clip(x, lim):
    return min(max(x, -lim), lim)


@njit(cache=True, inline="always")
def _level(w, tc, ts, rate):
    """friction.stribeck_level: (g, dg/d|w|)."""
    th = np.tanh(rate * abs(w))
    excess = ts - tc
    return excess * (1.0 - th) + tc, -excess * rate * (1.0 - th * th)


@njit(cache=True, inline="always")
def _levels(X, P, r, j):
    """friction.load_levels: the Coulomb and static levels under the step's gear torque ``X[T_ID]``."""
    extra = P[LOAD_FRIC, r, j] * abs(X[T_ID, r, j])
    return P[T_COULOMB, r, j] + extra, P[T_STATIC, r, j] + extra


@njit(cache=True, inline="always")
def _decay(s0, w, g, dt):
    """lugre._decay: (x, e, r)."""
    x = s0 * abs(w) * dt / max(g, LEVEL_FLOOR_NM)
    e = math.exp(-x)
    if x < SMALL_X:
        return x, e, 1.0 - x / 2.0 + x * x / 6.0
    return x, e, -math.expm1(-x) / x


@njit(cache=True, inline="always")
def _sign(w):
    return 1.0 if w > 0.0 else (-1.0 if w < 0.0 else 0.0)


@njit(cache=True, inline="always")
def _lugre_factors(X, P, r, j, m, w, dt, rate):
    """The LuGre law's factors at speed w: Stribeck level g, dg/d|w| (``friction.stribeck_level``) and the bristle
    decay's x, exp(-x), (1 - exp(-x)) / x (``lugre._decay``), memoised in the six rows from ``m`` (pure functions
    of w for the run's parameters, so a repeated speed returns the values computed before, bit for bit; not with
    load-dependent friction, whose levels also follow the gear torque: recomputed there)."""
    if X[m, r, j] == w and P[LOAD_FRIC, r, j] == 0.0:
        return X[m + 1, r, j], X[m + 2, r, j], X[m + 3, r, j], X[m + 4, r, j], X[m + 5, r, j]
    tc, ts = _levels(X, P, r, j)
    g, dg = _level(w, tc, ts, rate)
    x, e, rr = _decay(P[SIGMA0, r, j], w, g, dt)  # (_decay floors g itself)
    X[m, r, j], X[m + 1, r, j], X[m + 2, r, j], X[m + 3, r, j], X[m + 4, r, j], X[m + 5, r, j] = w, g, dg, x, e, rr
    return g, dg, x, e, rr


@njit(cache=True, inline="always")
def _friction(X, P, r, j, m, z, w, dt, rate):
    """friction.friction_step at speed w: (z+, T_f, S) of the joint's law (``m``: the side's memo rows)."""
    fv = P[FV, r, j]
    if P[LUGRE, r, j] == 0.0:
        tc, ts = _levels(X, P, r, j)
        g, dg = _level(w, tc, ts, rate)
        eps = P[EPS, r, j]
        y = w / eps
        t_over_y = 1.0 if abs(y) < 1e-8 else np.tanh(y) / y
        return 0.0, g * t_over_y * y + fv * w, g * t_over_y / eps + fv
    s0, s1 = P[SIGMA0, r, j], P[SIGMA1, r, j]
    g, dg, x, e, rr = _lugre_factors(X, P, r, j, m, w, dt, rate)
    g = max(g, LEVEL_FLOOR_NM)
    phi = dt * rr
    z1 = e * z + phi * w
    k = s0 + s1 / dt
    torque = k * z1 - (s1 / dt) * z + fv * w
    dx = s0 * dt * _sign(w) * (g - abs(w) * dg) / (g * g)
    psi = -0.5 + x / 3.0 - x * x / 8.0 if x < SMALL_X else (e * (1.0 + x) - 1.0) / (x * x)
    dz1 = -z * e * dx + phi + w * dt * psi * dx
    return z1, torque, max(k * dz1 + fv, 0.0)


@njit(cache=True, inline="always")
def _bristle(X, P, r, j, m, z, w, dt, rate):
    """friction.bristle_update (``m``: the side's memo rows)."""
    if P[LUGRE, r, j] == 0.0:
        return 0.0
    _, _, _, e, rr = _lugre_factors(X, P, r, j, m, w, dt, rate)
    return e * z + dt * rr * w


@njit(cache=True, inline="always")
def servo_rj(X, P, r, j, q_set, qd_set, nz, ts):
    """Joint ``j`` of run ``r`` at a servo instant: sensors sampled (noise, hold, quantisation), then position ->
    speed -> current loops and the inverter limit (``sensors.read``, ``controller.*``, ``power.limit_voltage``).
    ``nz``: the sample's unit noise ``(5, 6)``."""
    q_fb = _read(X[Y_RES, r, j], P[RES_NOISE, r, j], nz[0, j], P[RES_LSB, r, j]) + P[RES_OFF, r, j]
    th_fb = _read(X[Y_ENC, r, j], P[ENC_NOISE, r, j], nz[1, j], P[ENC_LSB, r, j])
    w_fb = _read(X[DY_ENC, r, j], P[ENCV_NOISE, r, j], nz[2, j], P[ENCV_LSB, r, j])
    g = P[CUR_GAIN, r, j]
    iq_fb = g * _read(X[Y_IQ, r, j], P[CUR_NOISE, r, j], nz[3, j], P[CUR_LSB, r, j]) + P[CUR_OFF, r, j]
    id_fb = g * _read(X[Y_ID, r, j], P[CUR_NOISE, r, j], nz[4, j], P[CUR_LSB, r, j])
    # position loop
    w_ref = P[RATIO_NOM, r, j] * (P[FF, r, j] * qd_set + P[POS_KP, r, j] * (q_set - q_fb))
    # speed loop
    i_max = P[I_MAX, r, j]
    err = w_ref - w_fb
    integ_v = _clip(X[INTEG_V, r, j] + P[SPD_KI, r, j] * ts * err, i_max)
    i_ref = _clip(P[SPD_KP, r, j] * err + integ_v, i_max)
    # current loops
    v_max = P[V_LIM, r, j]
    cross = P[CROSS_NOM, r, j]
    kp, ki = P[CUR_KP, r, j], P[CUR_KI, r, j]
    e_q = i_ref - iq_fb
    e_d = -id_fb
    integ_q = _clip(X[INTEG_Q, r, j] + ki * ts * e_q, v_max)
    integ_d = _clip(X[INTEG_D, r, j] + ki * ts * e_d, v_max) if cross != 0.0 else 0.0
    v_q = kp * e_q + integ_q + P[KE_NOM, r, j] * w_fb + cross * w_fb * id_fb
    v_d = kp * e_d + integ_d - cross * w_fb * iq_fb if cross != 0.0 else 0.0
    # inverter
    mag = math.sqrt(v_d * v_d + v_q * v_q)
    scale = min(1.0, v_max / max(mag, 1e-300))
    X[Q_FB, r, j], X[TH_FB, r, j], X[W_FB, r, j] = q_fb, th_fb, w_fb
    X[IQ_FB, r, j], X[ID_FB, r, j], X[I_REF, r, j] = iq_fb, id_fb, i_ref
    X[INTEG_V, r, j], X[INTEG_Q, r, j], X[INTEG_D, r, j] = integ_v, integ_q, integ_d
    X[V_D, r, j], X[V_Q, r, j] = v_d * scale, v_q * scale


@njit(cache=True, inline="always")
def physics_rj(X, P, r, j, q, qd, dt, stribeck, has_cogging):
    """Joint ``j`` of run ``r`` (link at ``q``, ``qd``) over one physics step: windings, gear eq. (1), friction
    eq. (2), rotor; returns the link torque (its friction part to be applied implicitly with the joint damping
    ``X[S_L]``)."""
    i_d, i_q, w_m, th_m = X[I_D, r, j], X[I_Q, r, j], X[W_M, r, j], X[TH_M, r, j]
    X[IQ_PREV, r, j], X[ID_PREV, r, j] = i_q, i_d
    # motor.electrical_step
    coupling = P[CROSS, r, j] * w_m
    decay, gain = P[DECAY, r, j], P[GAIN_IV, r, j]
    i_d_new = decay * i_d + gain * (X[V_D, r, j] + coupling * i_q)
    i_q_new = decay * i_q + gain * (X[V_Q, r, j] - coupling * i_d - P[KE, r, j] * w_m)
    # gearbox.gear_torque
    N = P[RATIO, r, j]
    th = th_m / N - q
    dth = w_m / N - qd
    k, c, backlash_rad = P[K, r, j], P[C, r, j], P[BACKLASH_RAD, r, j]
    t_low = k * th + c * dth
    t_high = t_low - k * backlash_rad
    if backlash_rad == 0.0:
        t_id = t_low
    elif th > backlash_rad:
        t_id = max(t_high, 0.0)
    elif th < 0.0:
        t_id = min(t_low, 0.0)
    else:
        t_id = 0.0
    X[T_ID, r, j] = t_id  # the friction levels below follow it (load-dependent friction)
    # link-side friction at the current speed (applied implicitly by MuJoCo)
    share = P[SHARE, r, j]
    _, f_l, s_l = _friction(X, P, r, j, MEMO_L, X[Z_L, r, j], qd, dt, stribeck)
    f_l, s_l = (1.0 - share) * f_l, (1.0 - share) * s_l
    # rotor, motor-side friction solved implicitly (friction.implicit_speed)
    t_m = P[KT, r, j] * i_q_new
    if has_cogging:  # motor.ripple_torque
        x = P[MH_PER, r, j] * th_m
        t_m = (t_m + P[COG_AMP, r, j] * np.sin(P[COG_PER, r, j] * th_m)
               + (P[MH_SIN, r, j] * np.sin(x) + P[MH_COS, r, j] * np.cos(x)))
    X[TH_PREV, r, j], X[Q_PREV, r, j] = th_m, q
    u = w_m / N
    if share > 0.0:
        _, f_m, s_m = _friction(X, P, r, j, MEMO_M, X[Z_M, r, j], u, dt, stribeck)
    else:  # no motor-side friction: skip its evaluation (the bristle state stays as it is)
        f_m, s_m = 0.0, 0.0
    w_new = w_m + dt * ((t_m - t_id / N) - share * f_m / N) / (P[JR, r, j] + dt * (share * s_m / (N * N)))
    X[T_F_M, r, j] = share * (f_m + s_m * (w_new / N - u))
    if share > 0.0:
        X[Z_M, r, j] = _bristle(X, P, r, j, MEMO_M, X[Z_M, r, j], w_new / N, dt, stribeck)
    X[W_M, r, j] = w_new
    X[TH_M, r, j] = th_m + dt * w_new  # symplectic: the new speed
    X[I_D, r, j], X[I_Q, r, j] = i_d_new, i_q_new
    X[F_L, r, j], X[S_L, r, j], X[QD_PREV, r, j] = f_l, s_l, qd
    return t_id - f_l + s_l * qd


@njit(cache=True, inline="always")
def sensors_rj(X, P, r, j, q, qd, dt, stribeck):
    """Joint ``j`` of run ``r`` after the MuJoCo step (link at ``q``, ``qd``): applied friction and link bristles
    at the reached speed, then the analog sensor filters (first-order-hold discretisations)."""
    X[T_F, r, j] = X[F_L, r, j] + X[S_L, r, j] * (qd - X[QD_PREV, r, j]) + X[T_F_M, r, j]
    X[Z_L, r, j] = _bristle(X, P, r, j, MEMO_L, X[Z_L, r, j], qd, dt, stribeck)
    y, dy, u0 = X[Y_RES, r, j], X[DY_RES, r, j], X[Q_PREV, r, j]
    c = RES_C0
    X[Y_RES, r, j] = P[c, r, j] * y + P[c + 1, r, j] * dy + P[c + 2, r, j] * u0 + P[c + 3, r, j] * q
    X[DY_RES, r, j] = P[c + 4, r, j] * y + P[c + 5, r, j] * dy + P[c + 6, r, j] * u0 + P[c + 7, r, j] * q
    y, dy, u0, u1 = X[Y_ENC, r, j], X[DY_ENC, r, j], X[TH_PREV, r, j], X[TH_M, r, j]
    c = ENC_C0
    X[Y_ENC, r, j] = P[c, r, j] * y + P[c + 1, r, j] * dy + P[c + 2, r, j] * u0 + P[c + 3, r, j] * u1
    X[DY_ENC, r, j] = P[c + 4, r, j] * y + P[c + 5, r, j] * dy + P[c + 6, r, j] * u0 + P[c + 7, r, j] * u1
    a, c0, c1 = P[CUR_A, r, j], P[CUR_C0, r, j], P[CUR_C1, r, j]
    X[Y_IQ, r, j] = a * X[Y_IQ, r, j] + c0 * X[IQ_PREV, r, j] + c1 * X[I_Q, r, j]
    X[Y_ID, r, j] = a * X[Y_ID, r, j] + c0 * X[ID_PREV, r, j] + c1 * X[I_D, r, j]


# -- the three calls of a lockstep batch step (``NumbaDrive``); the whole-run loop (``sim/steploop.py``) calls the
# per-joint functions above directly
@njit(cache=True)
def servo(X, P, q_set, qd_set, nz, ts):
    """:func:`servo_rj` for every run and joint; ``nz``: unit noise ``(n_runs, 5, 6)``."""
    n, nj = X.shape[1], X.shape[2]
    for r in range(n):
        for j in range(nj):
            servo_rj(X, P, r, j, q_set[r, j], qd_set[r, j], nz[r], ts)


@njit(cache=True)
def physics(X, P, q, qd, tau, dt, stribeck, has_cogging):
    """:func:`physics_rj` for every run and joint, the link torques into ``tau``."""
    n, nj = X.shape[1], X.shape[2]
    for r in range(n):
        for j in range(nj):
            tau[r, j] = physics_rj(X, P, r, j, q[r, j], qd[r, j], dt, stribeck, has_cogging)


@njit(cache=True)
def sensors(X, P, q, qd, dt, stribeck):
    """:func:`sensors_rj` for every run and joint."""
    n, nj = X.shape[1], X.shape[2]
    for r in range(n):
        for j in range(nj):
            sensors_rj(X, P, r, j, q[r, j], qd[r, j], dt, stribeck)

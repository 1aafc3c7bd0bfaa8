"""Drive-chain state and per-run parameters of a batch, and the two interchangeable
implementations of one drive step:

* :class:`NumpyDrive` - the reference: the readable, unit-tested functions of
  ``drive/*.py`` applied to ``(n_runs, 6)`` arrays;
* :class:`NumbaDrive` - the fast path: the same equations compiled with numba
  (``drive/kernel.py``), looping over runs and joints in machine code.

Both expose the same attributes (``th_m``, ``q_fb``, ``i_q``, ... all ``(n_runs, 6)``) and
three methods the engine calls: :meth:`servo` at servo instants, :meth:`physics` before
and :meth:`sensors` after each MuJoCo step (the link's friction is applied by MuJoCo with the
joint damping ``s_l``, its bristles updated after the step at the speed the link reached).
They agree to rounding (numpy's vectorised ``tanh`` and libm's differ in the last bit), which
``tests/sim/test_kernel.py`` checks.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from . import controller as ctl
from . import friction as fr
from . import gearbox, motor, power, sensors
from .layout import MEMO_NAMES, PARAM_NAMES, PI, STATE_NAMES, XI  # noqa: F401  (re-exported for callers)


def pack_params(p, g, a) -> NDArray:
    """Packed parameter array ``(n_params, n_runs, 6)`` from the robot parameters ``p`` (``RobotParams``), the
    controller gains ``g`` (``controller.design_gains``) and the run arrays ``a`` (``RunArrays``)."""
    dt = p.physics_dt_s
    n = a.n_runs
    out = np.zeros((len(PARAM_NAMES), n, 6))
    R, L = a.motor_resistance_ohm, a.motor_inductance_H
    decay = np.exp(-R * dt / L)
    pmsm0 = a.motor_is_pmsm[0]
    kt_nom = np.asarray(p.motor.torque_constant_Nm_per_A)
    s = p.sensors
    c_res = sensors.second_order_coefficients(s.resolver_bw_Hz, s.resolver_damping, dt)
    c_enc = sensors.second_order_coefficients(s.encoder_bw_Hz, s.encoder_damping, dt)
    c_cur = sensors.first_order_coefficients(s.current_bw_Hz, dt)
    values = {
        "ratio": a.gear_ratio, "k": a.gear_stiffness_Nm_per_rad, "c": a.gear_damping_Nms_per_rad,
        "backlash_rad": a.backlash_rad, "t_coulomb": a.friction_coulomb_Nm, "t_static": a.friction_static_Nm,
        "fv": fr.viscous_coefficient(a.friction_viscous_Nms_per_rad, a.friction_temp_coeff_per_K, a.temperature_C,
                                     p.friction.reference_temp_C),
        "eps": a.friction_sign_smoothing_rad_s, "decay": decay, "gain_iv": (1.0 - decay) / R,
        "cross": np.where(a.motor_is_pmsm, a.motor_pole_pairs * L, 0.0), "ke": a.motor_ke_V_s_per_rad,
        "kt": a.motor_kt_Nm_per_A, "jr": a.motor_rotor_inertia_kgm2, "cog_amp": a.cogging_Nm,
        "cog_per": a.cogging_periods_per_rev, "v_lim": power.voltage_limit(p.power.bus_voltage_V, a.motor_is_pmsm),
        "i_max": a.current_limit_A, "res_noise": a.resolver_noise_rad, "res_lsb": a.resolver_lsb_rad,
        "res_off": a.resolver_offset_rad, "enc_noise": a.encoder_noise_rad, "enc_lsb": a.encoder_lsb_rad,
        "encv_noise": a.encoder_speed_noise_rad_s, "encv_lsb": a.encoder_speed_lsb_rad_s,
        "cur_noise": a.current_noise_A, "cur_lsb": a.current_lsb_A, "cur_gain": a.current_gain,
        "cur_off": a.current_offset_A,
        "pos_kp": g.pos_kp_per_s, "spd_kp": g.speed_kp_A_s_per_rad, "spd_ki": g.speed_ki_A_per_rad,
        "cur_kp": g.cur_kp_V_per_A, "cur_ki": g.cur_ki_V_per_A_s, "ff": np.asarray(p.controller.velocity_feedforward),
        "ratio_nom": np.asarray(p.gear.ratio), "ke_nom": motor.back_emf_constant(kt_nom, pmsm0),
        "cross_nom": np.where(pmsm0, np.asarray(p.motor.pole_pairs) * np.asarray(p.motor.inductance_H), 0.0),
        **{f"res_c{i}": c_res[i] for i in range(8)}, **{f"enc_c{i}": c_enc[i] for i in range(8)},
        "cur_a": c_cur[0], "cur_c0": c_cur[1], "cur_c1": c_cur[2],
        "lugre": a.friction_is_lugre, "sigma0": a.friction_presliding_stiffness_Nm_per_rad,
        "sigma1": a.friction_bristle_damping_Nms_per_rad, "share": a.friction_motor_side_share,
        "mh_sin": a.motor_harmonic_Nm[..., 0], "mh_cos": a.motor_harmonic_Nm[..., 1],
        "mh_per": a.motor_harmonic_per_rev, "load_fric": a.friction_load_coeff,
    }
    for name, v in values.items():
        out[PI[name]] = np.broadcast_to(np.asarray(v, dtype=float), (n, 6))
    return out


def initial_state(P: NDArray, q: NDArray, bias: NDArray) -> NDArray:
    """Consistent equilibrium at rest: gears pre-deflected by the static load on the flank it
    pushes, currents and integrators holding it, filters at their steady values."""
    X = np.zeros((len(STATE_NAMES),) + q.shape)
    k, backlash_rad, N, kt = P[PI["k"]], P[PI["backlash_rad"]], P[PI["ratio"]], P[PI["kt"]]
    th_rel = np.where(bias >= 0.0, backlash_rad + bias / k, bias / k)
    th_m = N * (q + th_rel)
    i_q = bias / (N * kt)
    R = np.where(P[PI["gain_iv"]] > 0, (1.0 - P[PI["decay"]]) / P[PI["gain_iv"]], 0.0)
    X[XI["th_m"]] = th_m
    X[XI["i_q"]] = i_q
    X[XI["v_q"]] = R * i_q
    X[XI["integ_v"]] = P[PI["cur_gain"]] * i_q + P[PI["cur_off"]]  # the current the controller sees and holds
    X[XI["integ_q"]] = R * i_q
    X[XI["y_res"]] = q
    X[XI["y_enc"]] = th_m
    X[XI["y_iq"]] = i_q
    X[XI["q_fb"]] = q + P[PI["res_off"]]  # the resolver's reading (offset included)
    X[XI["th_fb"]] = th_m
    X[XI["iq_fb"]] = i_q
    X[XI["i_ref"]] = i_q
    X[XI["t_id"]] = bias
    X[XI["zl_w"]] = X[XI["zm_w"]] = np.nan  # the kernel's memo is empty
    return X


class _Views:
    """Named views of the packed state rows (``drive.th_m`` is ``X[XI['th_m']]``)."""

    def __getattr__(self, name: str) -> NDArray:
        if name in XI:
            return self.X[XI[name]]
        raise AttributeError(name)


def has_ripple(P: NDArray) -> bool:
    """Some run carries a torque periodic in the motor angle (``cogging`` or ``motor_harmonic``)."""
    return bool(np.any(P[PI["cog_amp"]] != 0.0) or np.any(P[PI["mh_sin"]] != 0.0) or np.any(P[PI["mh_cos"]] != 0.0))


class NumpyDrive(_Views):
    """Reference implementation: the drive modules' vectorised functions."""

    def __init__(self, P: NDArray, X: NDArray, dt: float, ts: float, stribeck: float) -> None:
        self.P, self.X, self.dt, self.ts, self.stribeck = P, X, dt, ts, stribeck
        self.has_cogging = has_ripple(P)

    def _p(self, name):
        return self.P[PI[name]]

    def servo(self, q_set: NDArray, qd_set: NDArray, nz: NDArray) -> None:
        """``q_set``, ``qd_set``: each run's setpoint ``(n_runs, 6)``; ``nz``: unit noise ``(n_runs, 5, 6)``."""
        p, X = self._p, self.X
        X[XI["q_fb"]] = sensors.read(self.y_res, p("res_noise"), nz[:, 0], p("res_lsb")) + p("res_off")
        X[XI["th_fb"]] = sensors.read(self.y_enc, p("enc_noise"), nz[:, 1], p("enc_lsb"))
        X[XI["w_fb"]] = sensors.read(self.dy_enc, p("encv_noise"), nz[:, 2], p("encv_lsb"))
        X[XI["iq_fb"]] = p("cur_gain") * sensors.read(self.y_iq, p("cur_noise"), nz[:, 3], p("cur_lsb")) + p("cur_off")
        X[XI["id_fb"]] = p("cur_gain") * sensors.read(self.y_id, p("cur_noise"), nz[:, 4], p("cur_lsb"))
        w_ref = ctl.position_loop(q_set, qd_set, self.q_fb, p("pos_kp"), p("ff"), p("ratio_nom"))
        X[XI["i_ref"]], X[XI["integ_v"]] = ctl.speed_loop(w_ref, self.w_fb, self.integ_v, p("spd_kp"), p("spd_ki"),
                                                          self.ts, p("i_max"))
        vd, vq, X[XI["integ_d"]], X[XI["integ_q"]] = ctl.current_loop(
            self.i_ref, self.id_fb, self.iq_fb, self.w_fb, self.integ_d, self.integ_q, p("cur_kp"), p("cur_ki"),
            self.ts, p("ke_nom"), p("cross_nom"), p("v_lim"))
        X[XI["v_d"]], X[XI["v_q"]] = power.limit_voltage(vd, vq, p("v_lim"))

    def _levels(self) -> tuple[NDArray, NDArray]:
        """Coulomb and static levels [N*m] under this step's gear torque (``friction.load_levels``)."""
        p = self._p
        return fr.load_levels(p("t_coulomb"), p("t_static"), p("load_fric"), self.t_id)

    def _friction(self, z: NDArray, w: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        p = self._p
        tc, ts = self._levels()
        return fr.friction_step(p("lugre") != 0.0, z, w, tc, ts, p("fv"), self.stribeck, p("eps"), p("sigma0"),
                                p("sigma1"), self.dt)

    def _bristle(self, z: NDArray, w: NDArray) -> NDArray:
        p = self._p
        tc, ts = self._levels()
        return fr.bristle_update(p("lugre") != 0.0, z, w, tc, ts, self.stribeck, p("sigma0"), self.dt)

    def physics(self, q: NDArray, qd: NDArray) -> NDArray:
        """Windings, gear, friction and rotor over one step; returns the link torque whose friction part the
        multibody must apply implicitly with the joint damping :attr:`s_l` (see ``friction.py``)."""
        p, X, dt = self._p, self.X, self.dt
        X[XI["iq_prev"]], X[XI["id_prev"]] = self.i_q, self.i_d
        X[XI["i_d"]], X[XI["i_q"]] = motor.electrical_step(self.i_d, self.i_q, self.v_d, self.v_q, self.w_m,
                                                           p("decay"), p("gain_iv"), p("cross"), p("ke"))
        N, share = p("ratio"), p("share")
        X[XI["t_id"]] = gearbox.gear_torque(self.th_m / N - q, self.w_m / N - qd, p("k"), p("c"), p("backlash_rad"))
        # link side: torque at the current speed and its slope; MuJoCo applies T_f + S (w+ - w) implicitly
        _, f_l, s_l = self._friction(self.z_l, qd)
        X[XI["f_l"]], X[XI["s_l"]], X[XI["qd_prev"]] = (1.0 - share) * f_l, (1.0 - share) * s_l, qd
        # rotor, with the motor side's friction (joint-side law at the rotor speed / N) solved implicitly
        t_m = p("kt") * self.i_q
        if self.has_cogging:
            t_m = t_m + motor.ripple_torque(self.th_m, p("cog_amp"), p("cog_per"), p("mh_sin"), p("mh_cos"),
                                            p("mh_per"))
        u = self.w_m / N
        _, f_m, s_m = self._friction(self.z_m, u)
        X[XI["th_prev"]], X[XI["q_prev"]] = self.th_m, q
        w_new = fr.implicit_speed(self.w_m, t_m - self.t_id / N, share * f_m / N, share * s_m / (N * N), p("jr"), dt)
        X[XI["t_f_m"]] = share * (f_m + s_m * (w_new / N - u))
        X[XI["z_m"]] = np.where(share > 0.0, self._bristle(self.z_m, w_new / N), self.z_m)
        X[XI["w_m"]] = w_new
        X[XI["th_m"]] = self.th_m + dt * w_new
        return self.t_id - self.f_l + self.s_l * qd

    def sensors(self, q: NDArray, qd: NDArray) -> None:
        """After the multibody step (link at ``q``, ``qd``): link bristles, applied friction, sensor filters."""
        p, X = self._p, self.X
        X[XI["t_f"]] = self.f_l + self.s_l * (qd - self.qd_prev) + self.t_f_m
        X[XI["z_l"]] = self._bristle(self.z_l, qd)
        c_res = np.stack([p(f"res_c{i}") for i in range(8)])
        c_enc = np.stack([p(f"enc_c{i}") for i in range(8)])
        c_cur = np.stack([p("cur_a"), p("cur_c0"), p("cur_c1")])
        X[XI["y_res"]], X[XI["dy_res"]] = sensors.second_order_step(self.y_res, self.dy_res, self.q_prev, q, c_res)
        X[XI["y_enc"]], X[XI["dy_enc"]] = sensors.second_order_step(self.y_enc, self.dy_enc, self.th_prev, self.th_m,
                                                                    c_enc)
        X[XI["y_iq"]] = sensors.first_order_step(self.y_iq, self.iq_prev, self.i_q, c_cur)
        X[XI["y_id"]] = sensors.first_order_step(self.y_id, self.id_prev, self.i_d, c_cur)


class NumbaDrive(_Views):
    """Fast path: ``drive/kernel.py`` compiled with numba, same equations and order."""

    def __init__(self, P: NDArray, X: NDArray, dt: float, ts: float, stribeck: float) -> None:
        from ..jitcache import protect
        from . import kernel

        protect(kernel)  # its numba cache verified on read (jitcache.py)
        self.k = kernel
        self.P, self.X, self.dt, self.ts, self.stribeck = P, X, dt, ts, stribeck
        self.has_cogging = has_ripple(P)
        self.tau = np.zeros(X.shape[1:])

    def servo(self, q_set: NDArray, qd_set: NDArray, nz: NDArray) -> None:
        self.k.servo(self.X, self.P, q_set, qd_set, nz, self.ts)

    def physics(self, q: NDArray, qd: NDArray) -> NDArray:
        self.k.physics(self.X, self.P, q, qd, self.tau, self.dt, self.stribeck, self.has_cogging)
        return self.tau

    def sensors(self, q: NDArray, qd: NDArray) -> None:
        self.k.sensors(self.X, self.P, q, qd, self.dt, self.stribeck)


DRIVES = {"numpy": NumpyDrive, "numba": NumbaDrive}

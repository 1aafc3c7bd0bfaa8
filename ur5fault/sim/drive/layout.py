"""Row layout of the packed drive arrays, shared by the numpy reference (``state.py``) and the
compiled kernel (``kernel.py``) so that neither imports the other.

``P`` holds per-run, per-joint parameters ``(len(PARAM_NAMES), n_runs, 6)``; ``X`` the drive state
``(len(STATE_NAMES), n_runs, 6)``.  ``PI`` / ``XI`` map a name to its row.
"""

from __future__ import annotations

# names of the per-run, per-joint parameters (rows of the packed array P)
PARAM_NAMES = (
    "ratio", "k", "c", "backlash_rad", "t_coulomb", "t_static", "fv", "eps", "decay", "gain_iv", "cross", "ke", "kt",
    "jr", "cog_amp", "cog_per", "v_lim", "i_max", "res_noise", "res_lsb", "res_off", "enc_noise", "enc_lsb",
    "encv_noise", "encv_lsb", "cur_noise", "cur_lsb", "cur_gain", "cur_off",
    # controller (nominal: the controller does not know the faults)
    "pos_kp", "spd_kp", "spd_ki", "cur_kp", "cur_ki", "ff", "ratio_nom", "ke_nom", "cross_nom",
    # sensor filter coefficients (per joint, broadcast over runs)
    "res_c0", "res_c1", "res_c2", "res_c3", "res_c4", "res_c5", "res_c6", "res_c7",
    "enc_c0", "enc_c1", "enc_c2", "enc_c3", "enc_c4", "enc_c5", "enc_c6", "enc_c7",
    "cur_a", "cur_c0", "cur_c1",
    # friction law (1 = LuGre, 0 = smooth sign), LuGre sigma0 and sigma1, motor-side share
    "lugre", "sigma0", "sigma1", "share",
    # motor-angle harmonic (effect ``motor_harmonic``): sin and cos amplitudes [N*m, motor side], periods per turn
    "mh_sin", "mh_cos", "mh_per",
    # load-dependent friction (effect ``load_friction``): Coulomb and static levels grow by load_fric * |T_gear| [-]
    "load_fric",
)
#: drive state (rows of the packed array X)
STATE_NAMES = (
    "th_m", "w_m", "i_q", "i_d", "v_q", "v_d", "integ_v", "integ_q", "integ_d",
    "y_res", "dy_res", "y_enc", "dy_enc", "y_iq", "y_id",
    "q_fb", "th_fb", "w_fb", "iq_fb", "id_fb", "i_ref", "t_id", "t_f", "q_prev", "th_prev", "iq_prev", "id_prev",
    # friction: bristle states (link, motor side), the link share's torque and implicit slope at the step's start
    # speed, that speed, and the motor share's applied torque (joint-side units)
    "z_l", "z_m", "f_l", "s_l", "qd_prev", "t_f_m",
)
#: the compiled kernel's memo of the LuGre law's speed-dependent factors, link side then motor side: the speed they
#: were computed at (NaN: none yet), the Stribeck level g and dg/d|w|, and the bristle decay's x, exp(-x) and
#: (1 - exp(-x)) / x.  Not model state: the bristle update after a step and the friction of the next step see the
#: same speed, so the second evaluation reuses the first (the numpy reference recomputes).  Rows after STATE_NAMES.
MEMO_NAMES = ("zl_w", "zl_g", "zl_dg", "zl_x", "zl_e", "zl_r", "zm_w", "zm_g", "zm_dg", "zm_x", "zm_e", "zm_r")
STATE_NAMES = STATE_NAMES + MEMO_NAMES
PI = {name: i for i, name in enumerate(PARAM_NAMES)}
XI = {name: i for i, name in enumerate(STATE_NAMES)}

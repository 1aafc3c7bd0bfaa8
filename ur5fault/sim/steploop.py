"""The whole step loop of a batch compiled: every physics step of every run in machine code, no Python per step.

Per run and physics step, in the order of the lockstep loop (``engine._step_lockstep``), with the same per-joint
functions (``drive/kernel.py``: ``servo_rj``, ``physics_rj``, ``sensors_rj``; ``terms.py``: ``load_torque_rj``,
``gravity_moment_j``): at servo instants the setpoint (with the run's delay), the servo step and the health check;
the drive's physics and the data-driven terms' load torque into ``qfrc_applied``, the friction slope into the
model's ``dof_damping``; the payload mass at gripper events; ``mj_step`` of MuJoCo's C library through its address
(``mjlib.py``); the sensors after the step; logging into preallocated arrays.  Runs of a batch are independent, so
the loop is over runs outside and steps inside, optionally spread over threads (numba ``prange``).

Python returns only between chunks: every ``NOISE_CHUNK_SAMPLES`` servo samples (the runs' random streams are
drawn there from their numpy generators, by compiled code, ``draw_normals``: the reference loop's streams) and at
progress points.  The result equals the lockstep loop with the compiled drive bit for bit
(``tests/sim/test_steploop.py``).
"""

from __future__ import annotations

import inspect
import sys
import zlib
from pathlib import Path

import numba
import numpy as np
from numba import njit, prange

from . import gravity, jitcache, mjlib, terms
from .axes import N_JOINTS
from .drive import kernel
from .drive.kernel import Q_FB, S_L, physics_rj, sensors_rj, servo_rj
from .drive.layout import PARAM_NAMES, STATE_NAMES
from .gravity import gravity_moment_j
from .mjlib import as_f64ptr, call_step, uncounted
from .terms import load_torque_rj

#: CRC-32 of everything compiled into this module's cached functions besides this file: numba's cache checks only
#: this file's time stamp, so a change of the drive kernel, the term functions, the pointer helpers or the row
#: layout would otherwise reuse stale machine code.  A change stops here until this number is updated (which
#: changes this file and so recompiles); see LAYOUT_CRC32 in ``drive/kernel.py``.
SOURCES_CRC32 = 2378207239


def sources_crc32() -> int:
    """CRC-32 of the code this module compiles in (see :data:`SOURCES_CRC32`)."""
    text = "|".join(PARAM_NAMES) + "#" + "|".join(STATE_NAMES)
    for mod in (kernel, mjlib):
        text += Path(mod.__file__).read_text()
    for fn in (load_torque_rj, gravity_moment_j):
        text += inspect.getsource(fn.py_func)
    return zlib.crc32(text.encode())


if sources_crc32() != SOURCES_CRC32:
    raise ImportError(f"the code compiled into ur5fault/sim/steploop.py changed: set SOURCES_CRC32 = {sources_crc32()} "
                      "there so numba recompiles the cached loop")

#: rows of the packed drive state and parameters, compiled into the loop as constants
X_ROWS, P_ROWS = len(STATE_NAMES), len(PARAM_NAMES)

# columns of the per-run address table (``addresses``)
MODEL, DATA, QPOS, QVEL, QFRC, DAMPING, MASS_MATRIX, XIPOS, XANCHOR, XAXIS, BODY_MASS, BODY_INERTIA = range(12)
#: run status codes of the compiled loop (``engine.Status``: ok, diverged, protective_stop)
OK, DIVERGED, PROTECTIVE_STOP = 0, 1, 2


def addresses(models, datas) -> np.ndarray:
    """``(n_runs, 12)`` addresses of each run's model, data and the fields the loop reads or writes."""
    out = np.empty((len(models), 12), dtype=np.intp)
    for r, (m, d) in enumerate(zip(models, datas)):
        out[r] = (m._address, d._address, d.qpos.ctypes.data, d.qvel.ctypes.data, d.qfrc_applied.ctypes.data,
                  m.dof_damping.ctypes.data, d.M.ctypes.data, d.xipos.ctypes.data, d.xanchor.ctypes.data,
                  d.xaxis.ctypes.data, m.body_mass.ctypes.data, m.body_inertia.ctypes.data)
    return out


@njit(cache=True)
def _advance(r, s0, s1, si0, noise, bt, tm):
    """Run ``r`` from physics step ``s0`` to ``s1`` (``s0`` a servo instant; ``noise[r, 0]`` is servo sample
    ``si0``).  ``bt``: the batch (:func:`batch_tuple`); ``tm``: the terms (:func:`terms_tuple`)."""
    (fn, adr, sizes, X, P, q_set_s, qd_set_s, delay, sps, dt, ts, stribeck, has_cogging, limits, model_damping,
     payload_kg, cube2, gripped, change, log, src, log_every, active, status, event) = bt
    nv, n_m, nbody, njnt, pb = sizes[0], sizes[1], sizes[2], sizes[3], sizes[4]
    # every array the inlined functions take is used through a view numba does not reference-count (``uncounted``:
    # otherwise an atomic increment and decrement per array and call); the owners outlive this call
    link, grav_on, m_diag, subtree, up = tm[0], tm[1], uncounted(tm[2]), uncounted(tm[3]), uncounted(tm[4])
    amp_j, per_j, coul, coul_w, strib, strib_v, visc, quad, grav_scale, sign_w, hold, hold_w, last_sign = tm[5]
    amp_j, per_j, coul, coul_w = uncounted(amp_j), uncounted(per_j), uncounted(coul), uncounted(coul_w)
    strib, strib_v, visc, quad = uncounted(strib), uncounted(strib_v), uncounted(visc), uncounted(quad)
    grav_scale, hold, hold_w = uncounted(grav_scale), uncounted(hold), uncounted(hold_w)
    last_sign = uncounted(last_sign)
    q_set_s, qd_set_s, noise = uncounted(q_set_s), uncounted(qd_set_s), uncounted(noise)
    qpos = numba.carray(as_f64ptr(adr[r, QPOS]), (nv,))
    qvel = numba.carray(as_f64ptr(adr[r, QVEL]), (nv,))
    qfrc = numba.carray(as_f64ptr(adr[r, QFRC]), (nv,))
    damping = numba.carray(as_f64ptr(adr[r, DAMPING]), (nv,))
    mass_matrix = numba.carray(as_f64ptr(adr[r, MASS_MATRIX]), (n_m,))
    xipos = numba.carray(as_f64ptr(adr[r, XIPOS]), (nbody, 3))
    xanchor = numba.carray(as_f64ptr(adr[r, XANCHOR]), (njnt, 3))
    xaxis = numba.carray(as_f64ptr(adr[r, XAXIS]), (njnt, 3))
    body_mass = numba.carray(as_f64ptr(adr[r, BODY_MASS]), (nbody,))
    body_inertia = numba.carray(as_f64ptr(adr[r, BODY_INERTIA]), (nbody, 3))
    # the run's drive state and parameters: one contiguous block each (``run`` passes them run-major, ``(n_runs,
    # rows, 6)``: in the batch layout ``(rows, n_runs, 6)`` a run's rows lie n_runs * 48 bytes apart, and at 128
    # runs they fall into a few cache sets and evict each other; measured, 128 runs: 4.3 us per run-step against
    # 3.1 us), viewed as the kernels' ``(rows, 1, 6)`` of run index 0 without numba's reference count (``uncounted``).
    # The shapes are the layout's constants (``run`` checks them): every row is then a fixed offset from the block's
    # start, where with the arrays' own shapes each row's address was computed once and mostly kept on the stack
    nj = N_JOINTS
    xs = numba.carray(as_f64ptr(X.ctypes.data + r * X_ROWS * nj * 8), (X_ROWS, 1, nj))
    ps = numba.carray(as_f64ptr(P.ctypes.data + r * P_ROWS * nj * 8), (P_ROWS, 1, nj))
    for step in range(s0, s1):
        if step % sps == 0:
            si = step // sps
            k = max(si - delay[r], 0)
            nz = noise[r, si - si0]
            for j in range(nj):
                servo_rj(xs, ps, 0, j, q_set_s[k, j], qd_set_s[k, j], nz, ts)
            # run health: a diverged or tripped run stops here and its remaining log stays NaN
            bad, trip, worst, jw = False, False, -1.0, 0
            for j in range(nj):
                if not np.isfinite(qpos[j]) or abs(qpos[j]) > limits[0]:
                    bad = True
                e = abs(q_set_s[k, j] - xs[Q_FB, 0, j])
                if e > limits[1]:
                    trip = True
                if e > worst:
                    worst, jw = e, j
            if bad or trip:
                active[r] = False
                status[r] = DIVERGED if bad else PROTECTIVE_STOP
                event[r, 0], event[r, 1] = step, jw
                break
        for j in range(nj):
            tau = physics_rj(xs, ps, 0, j, qpos[j], qvel[j], dt, stribeck, has_cogging)
            if link:
                g = gravity_moment_j(j, body_mass, xipos, xanchor, xaxis, subtree, up) if grav_on else 0.0
                tau = tau - load_torque_rj(r, j, qpos[j], qvel[j], mass_matrix[m_diag[j]], dt, g, amp_j, per_j, coul,
                                           coul_w, strib, strib_v, visc, quad, grav_scale, sign_w, hold, hold_w,
                                           last_sign)
            qfrc[j] = tau
            # the friction's slope on top of the model's own joint damping: MuJoCo's Euler step applies both
            # implicitly
            damping[j] = model_damping[j] + xs[S_L, 0, j]
        if change[step]:
            mass = payload_kg[r] * gripped[step]
            body_mass[pb] = mass
            for c in range(3):
                body_inertia[pb, c] = mass * cube2 / 6.0  # multibody.payload_inertia
        call_step(fn, adr[r, MODEL], adr[r, DATA])
        for j in range(nj):
            sensors_rj(xs, ps, 0, j, qpos[j], qvel[j], dt, stribeck)
        if (step + 1) % log_every == 0:
            li = (step + 1) // log_every - 1
            for s in range(src.shape[0]):
                row = src[s]
                for j in range(nj):
                    log[s, r, li, j] = qpos[j] if row < 0 else xs[row, 0, j]


@njit(cache=True)
def advance_serial(s0, s1, si0, noise, bt, tm):
    """:func:`_advance` for every active run, one after the other."""
    active = bt[22]
    for r in range(active.shape[0]):
        if active[r]:
            _advance(r, s0, s1, si0, noise, bt, tm)


@njit(cache=True, parallel=True)
def advance_threads(s0, s1, si0, noise, bt, tm):
    """:func:`_advance` for every active run, runs spread over numba's threads (the tuples are unpacked and
    rebuilt inside: a parallel loop's body cannot take tuples of arrays from outside)."""
    (fn, adr, sizes, X, P, q_set_s, qd_set_s, delay, sps, dt, ts, stribeck, has_cogging, limits, model_damping,
     payload_kg, cube2, gripped, change, log, src, log_every, active, status, event) = bt
    link, grav_on, m_diag, subtree, up, fields = tm
    amp_j, per_j, coul, coul_w, strib, strib_v, visc, quad, grav_scale, sign_w, hold, hold_w, last_sign = fields
    for r in prange(active.shape[0]):
        if active[r]:
            _advance(r, s0, s1, si0, noise,
                     (fn, adr, sizes, X, P, q_set_s, qd_set_s, delay, sps, dt, ts, stribeck, has_cogging, limits,
                      model_damping, payload_kg, cube2, gripped, change, log, src, log_every, active, status, event),
                     (link, grav_on, m_diag, subtree, up, (amp_j, per_j, coul, coul_w, strib, strib_v, visc, quad,
                                                           grav_scale, sign_w, hold, hold_w, last_sign)))


@njit(cache=True)
def draw_normals(rng, out):
    """``rng.standard_normal(out.shape, out=out)`` for a C-contiguous ``out``, compiled: the same numbers in the same
    order and the generator left in the same state (numba's support of numpy's ``Generator`` runs numpy's ziggurat
    on the generator's own bit state), about a third of numpy's cost (PCG64: 3.4 against 9.4 ns per number, i.e.
    0.09 us less per run-step at 15 numbers per physics step)."""
    flat = out.reshape(-1)
    for i in range(flat.size):
        flat[i] = rng.standard_normal()


def term_arrays(a, last_sign: np.ndarray) -> tuple:
    """The run-array fields of the link-torque terms in :func:`terms.load_torque_rj`'s order."""
    return (a.term_joint_harmonic_Nm, a.term_joint_harmonic_per_rev, a.term_coulomb_Nm, a.term_coulomb_width_rad_s,
            a.term_stribeck_Nm, a.term_stribeck_speed_rad_s, a.term_viscous_Nms_per_rad,
            a.term_quadratic_Nms2_per_rad2, a.term_gravity_scale, terms.STRIBECK_SIGN_WIDTH_RAD_S, a.term_holding_Nm,
            a.term_holding_speed_rad_s, last_sign)


def terms_tuple(hook, mb, n_runs: int) -> tuple:
    """The terms' part of the loop's arguments: switches, mass-matrix diagonal, subtree, up vector, fields."""
    ids = mb.ids
    a = hook.a
    last_sign = hook.last_sign if hook.last_sign is not None else np.zeros((n_runs, a.term_coulomb_Nm.shape[1]))
    last_sign = np.ascontiguousarray(last_sign, dtype=np.float64)  # the loop views every array as C-contiguous
    hook.last_sign = last_sign  # the loop updates it in place
    return (bool(hook.link_torque), bool(hook.gravity), np.asarray(ids.m_diag, dtype=np.intp), ids.subtree,
            np.ascontiguousarray(ids.up * float(np.linalg.norm(mb.models[0].opt.gravity))),
            tuple(np.ascontiguousarray(f) if isinstance(f, np.ndarray) else f for f in term_arrays(a, last_sign)))


def run(mb, X, P, setpoints, delay_k, rngs, timing, payload, logging, hook, progress, nthread: int,
        limits: tuple[float, float], noise_shape: tuple[int, int, int], progress_step: float):
    """Every physics step of every run in compiled code, Python only between chunks of servo samples.

    Args:
        mb: the runs' ``LoopMultibody`` (one MuJoCo model and data per run), started and at the first payload.
        X, P: packed drive state (advanced in place) and parameters.
        setpoints: ``(q_set, qd_set)`` at servo instants ``(n_servo, 6)``.
        delay_k: each run's setpoint delay in servo samples.
        rngs: each run's noise generator (drawn in the reference loop's order).
        timing: ``(n_steps, steps_per_servo, dt, servo_period, stribeck_rate, has_cogging)``.
        payload: ``(payload_kg per run, gripped per step (n_steps + 1,), change per step (n_steps,) bool)``.
        logging: ``(log_every, n_log, source rows (-1 = joint angle))``.
        hook: the data-driven terms (``terms.TermHook``).
        progress: called with the finished fraction, or None; every ``progress_step`` of the run.
        nthread: runs spread over this many threads (1: one after the other).
        limits: runaway and protective-stop thresholds [rad].
        noise_shape: (servo samples per chunk, channels, joints).

    Returns:
        ``(log (n_signals, n_runs, n_log, 6), status codes (n_runs,), event (n_runs, 2): step and joint)``.
    """
    from .multibody import PAYLOAD_CUBE_M

    n_steps, sps, dt, ts, stribeck, has_cogging = timing
    if X.shape[0] != X_ROWS or P.shape[0] != P_ROWS or X.shape[2] != N_JOINTS or P.shape[2] != N_JOINTS:
        raise ValueError(f"drive arrays {X.shape}, {P.shape}: the compiled loop takes ({X_ROWS}, n, {N_JOINTS}) and "
                         f"({P_ROWS}, n, {N_JOINTS})")
    log_every, n_log, src = logging
    n = X.shape[1]
    # run-major copies for the loop (each run's rows contiguous, ``_advance``), written back at the end
    X_runs = np.ascontiguousarray(X.transpose(1, 0, 2), dtype=np.float64)
    P_runs = np.ascontiguousarray(P.transpose(1, 0, 2), dtype=np.float64)
    m0 = mb.models[0]
    sizes = np.array([m0.nv, m0.nM, m0.nbody, m0.njnt, mb.ids.payload], dtype=np.intp)
    log = np.full((len(src), n, n_log, X.shape[2]), np.nan)
    active = np.ones(n, dtype=np.bool_)
    status = np.zeros(n, dtype=np.int8)
    event = np.zeros((n, 2), dtype=np.intp)
    bt = (mjlib.MJ_STEP_ADDRESS, addresses(mb.models, mb.datas), sizes, X_runs, P_runs,
          np.ascontiguousarray(setpoints[0], dtype=np.float64), np.ascontiguousarray(setpoints[1], dtype=np.float64),
          np.asarray(delay_k, dtype=np.intp), int(sps), float(dt), float(ts), float(stribeck), bool(has_cogging),
          np.asarray(limits, dtype=float), np.asarray(mb.model_damping, dtype=float), np.asarray(payload[0], float),
          float(PAYLOAD_CUBE_M**2), np.asarray(payload[1], float), np.asarray(payload[2], np.bool_), log,
          np.asarray(src, dtype=np.intp), int(log_every), active, status, event)
    tm = terms_tuple(hook, mb, n)
    chunk = noise_shape[0]
    noise = np.empty((n,) + tuple(noise_shape))
    threads_before = numba.get_num_threads()  # numba's setting is the process's: put back after this run
    if nthread > 1:
        numba.set_num_threads(min(nthread, numba.config.NUMBA_NUM_THREADS))
        advance = advance_threads
    else:
        advance = advance_serial
    next_progress = 0.0
    s = 0
    try:
        while s < n_steps and active.any():
            si = s // sps
            si0 = si - si % chunk
            if si % chunk == 0:
                for r in range(n):
                    draw_normals(rngs[r], noise[r])  # rngs[r].standard_normal(noise_shape, out=noise[r]), compiled
            end = min(n_steps, (si0 + chunk) * sps)
            if progress is not None:
                if s >= next_progress * n_steps:
                    progress(s / n_steps)
                    next_progress += progress_step
                end = min(end, max(s + sps, -(-int(np.ceil(next_progress * n_steps)) // sps) * sps))
            advance(s, end, si0, noise, bt, tm)
            s = end
    finally:
        numba.set_num_threads(threads_before)
    X[...] = X_runs.transpose(1, 0, 2)
    return log, status, event


# the numba caches of everything compiled here verified on read (a damaged file is compiled again, jitcache.py)
jitcache.protect(kernel, mjlib, terms, gravity, sys.modules[__name__])

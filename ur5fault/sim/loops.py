"""The two step loops of a batch and what they share: the preparation (setpoints, payload events, the multibody
at a consistent start at rest, the drive chain holding it), the run-health limits and the logged signals.

* :func:`step_compiled` - every physics step in compiled code (``steploop.py``), the default;
* :func:`step_lockstep` - the reference: a Python loop over physics steps applying the drive to ``(n_runs, 6)``
  arrays (the numpy modules, or one compiled call per stage) and stepping the multibody, which the compiled loop
  equals bit for bit with the compiled drive (``tests/sim/test_steploop.py``).

Step order (semi-implicit Euler for the whole chain):

1. at servo instants: sample the sensors (noise, sample-and-hold, quantisation) and run
   position -> speed -> current loops; the inverter limits and holds the voltage;
2. winding currents (exact R-L decay);
3. gear torque, eq. (1), from rotor and link states; friction, eq. (2) (smooth or LuGre), its
   motor-side share solved implicitly with the rotor;
4. rotor speed and angle; link torque ``T = T_id - T_f`` into ``qfrc_applied`` with the friction's
   slope as joint damping, which MuJoCo's Euler step applies implicitly; ``mj_step``;
5. link bristle states at the reached speed; analog sensor filters; logging.
"""

from __future__ import annotations

import dataclasses
import enum

import numpy as np

from .axes import N_JOINTS
from .drive.layout import XI
from .drive.state import DRIVES, initial_state, pack_params
from .result import SimResult
from .run_arrays import RunArrays
from .terms import TermHook
from .trajectories import Trajectory

#: Tracking error that trips a protective stop [rad] (assumption: UR stops on large
#: position deviation; 0.1 rad is far above any healthy or modelled-fault value).
PROTECTIVE_STOP_RAD = 0.1
#: |joint angle| beyond which a run counts as diverged [rad] (assumption: the UR5's joint range is +-360 deg
#: = +-6.3 rad (../shared/ur5-facts.md), so 50 rad is only reached by a numerically exploding run).
RUNAWAY_LIMIT_RAD = 50.0
#: unit-noise draws per servo sample and joint, in the order the drive's servo step reads them
#: (``drive/state.py`` ``NumpyDrive.servo`` and ``drive/kernel.py`` ``servo``: ``nz[:, 0..4]``).
NOISE_CHANNELS = ("resolver", "encoder_angle", "encoder_speed", "current_q", "current_d")
#: servo samples of noise drawn at once per run (memory (n_runs, 2000, 5, 6) doubles, ~0.5 MB per run; a
#: chunk only amortises the generator call and does not change the stream: draws are in sample order)
NOISE_CHUNK_SAMPLES = 2000
#: fraction of the run between two calls of ``run(progress=...)``
PROGRESS_STEP = 0.02

class Status(str, enum.Enum):
    """Outcome of a run."""

    OK = "ok"
    DIVERGED = "diverged"
    PROTECTIVE_STOP = "protective_stop"


@dataclasses.dataclass
class Batch:
    """What a step loop needs, prepared once per :meth:`Simulator.run` (batch axis first)."""

    n_steps: int
    log_every: int
    q_set_s: np.ndarray  # setpoints at servo instants (n_servo, 6)
    qd_set_s: np.ndarray
    gripped_step: np.ndarray  # gripper closed at physics step k (n_steps + 1,)
    change: np.ndarray  # payload changes at physics step k (n_steps,) bool
    mb: object  # LoopMultibody or BatchMultibody, started at rest
    terms: TermHook
    drive: object  # NumbaDrive or NumpyDrive, at the consistent initial state
    q0: np.ndarray  # starting joint angles (n_runs, 6)
    delay_k: np.ndarray  # setpoint latency per run in whole servo samples (effect "delay")
    rngs: list

    @property
    def n_log(self) -> int:
        return self.n_steps // self.log_every


def prepare(sim, traj: Trajectory, runs: list, a: RunArrays, n_steps: int, log_every: int, stepper: str) -> Batch:
    """Setpoints, payload events, the multibody at a consistent start at rest and the drive chain holding it
    (``sim``: the ``engine.Simulator``; ``runs``: its ``RunSpec`` list)."""
    p = sim.params
    dt, ts = p.physics_dt_s, p.controller.servo_period_s
    n_servo = n_steps // p.steps_per_servo + 1
    q_set_s, qd_set_s = traj.interpolate(np.arange(n_servo) * ts)
    gripped_step = traj.gripped(np.arange(n_steps + 1) * dt)
    change = np.zeros(n_steps, dtype=bool)
    change[1:] = gripped_step[1:n_steps] != gripped_step[:n_steps - 1]
    mb = sim._multibody(a, stepper)
    terms = TermHook.build(a)
    terms.prepare_model(mb)
    mb.set_payload(a.payload_kg * gripped_step[0])
    # the link where its resolver reads the first setpoint: a resolver offset has been there since the robot was
    # switched on, so the position loop has long held the true link off by it (starting the link at the setpoint
    # instead gave every run with a resolver offset a step of the offset at t = 0, a transient no robot shows)
    q = np.tile(q_set_s[0], (a.n_runs, 1)) - a.resolver_offset_rad
    bias = mb.start(q)
    bias = bias + terms.static_load(q, mb, dt)  # the terms' static load is held from the start
    P = pack_params(p, sim.gains, a)
    drive = DRIVES[sim.drive](P, initial_state(P, q, bias), dt, ts, p.friction.stribeck_rate_s_per_rad)
    return Batch(n_steps, log_every, q_set_s, qd_set_s, gripped_step, change, mb, terms, drive, q,
                 np.rint(a.setpoint_delay_s / ts).astype(int), [np.random.default_rng(r.seed) for r in runs])


def diverged_reason(step: int, dt: float) -> str:
    return f"non-finite or runaway joint state at t={step * dt:.4f} s"


def tripped_reason(step: int, dt: float, joint: int) -> str:
    return f"tracking error of joint {joint + 1} above {PROTECTIVE_STOP_RAD} rad at t={step * dt:.4f} s"


def step_compiled(sim, b: Batch, a: RunArrays, progress):
    """Every physics step in compiled code (``steploop.py``); returns the log, status and reasons."""
    from . import steploop

    p = sim.params
    dt = p.physics_dt_s
    src = [-1 if name == "q_rad" else XI[LOG_SOURCES[name]] for name in SimResult.JOINT_SIGNALS]
    arr, codes, event = steploop.run(
        b.mb, b.drive.X, b.drive.P, (b.q_set_s, b.qd_set_s), b.delay_k, b.rngs,
        (b.n_steps, p.steps_per_servo, dt, p.controller.servo_period_s, p.friction.stribeck_rate_s_per_rad,
         b.drive.has_cogging),
        (a.payload_kg, b.gripped_step, b.change), (b.log_every, b.n_log, src), b.terms, progress, sim.nthread,
        (RUNAWAY_LIMIT_RAD, PROTECTIVE_STOP_RAD), (NOISE_CHUNK_SAMPLES, len(NOISE_CHANNELS), N_JOINTS), PROGRESS_STEP)
    log = {name: arr[i] for i, name in enumerate(SimResult.JOINT_SIGNALS)}
    status, reason = [Status.OK] * len(codes), [""] * len(codes)
    for r in np.flatnonzero(codes):
        step, joint = int(event[r, 0]), int(event[r, 1])
        if codes[r] == steploop.DIVERGED:
            status[r], reason[r] = Status.DIVERGED, diverged_reason(step, dt)
        else:
            status[r], reason[r] = Status.PROTECTIVE_STOP, tripped_reason(step, dt, joint)
    return log, status, reason


def step_lockstep(sim, b: Batch, a: RunArrays, progress):
    """The reference loop: per physics step, the drive over the whole batch (numpy or one compiled call per stage)
    and the multibody step; returns the log, status and reasons."""
    p = sim.params
    dt, sps = p.physics_dt_s, p.steps_per_servo
    n, n_steps, mb, drive = a.n_runs, b.n_steps, b.mb, b.drive
    q, qd = b.q0, np.zeros_like(b.q0)
    delayed = bool(np.any(b.delay_k))
    noise = np.empty((n, NOISE_CHUNK_SAMPLES, len(NOISE_CHANNELS), N_JOINTS))
    log = {name: np.full((n, b.n_log, N_JOINTS), np.nan) for name in SimResult.JOINT_SIGNALS}
    logged = [(log[name], name) for name in SimResult.JOINT_SIGNALS]
    active = np.ones(n, dtype=bool)
    status, reason = [Status.OK] * n, [""] * n
    next_progress = 0.0
    for step in range(n_steps):
        if step % sps == 0:
            si = step // sps
            ci = si % NOISE_CHUNK_SAMPLES
            if ci == 0:
                for r in range(n):
                    noise[r] = b.rngs[r].standard_normal((NOISE_CHUNK_SAMPLES, len(NOISE_CHANNELS), N_JOINTS))
            if delayed:
                k = np.maximum(si - b.delay_k, 0)
                q_set_now, qd_set_now = b.q_set_s[k], b.qd_set_s[k]
            else:
                q_set_now = np.broadcast_to(b.q_set_s[si], (n, N_JOINTS))
                qd_set_now = np.broadcast_to(b.qd_set_s[si], (n, N_JOINTS))
            drive.servo(q_set_now, qd_set_now, noise[:, ci])
            # run health: a diverged or tripped run is frozen and its remaining log left NaN
            bad = ~np.all(np.isfinite(q), axis=1) | np.any(np.abs(q) > RUNAWAY_LIMIT_RAD, axis=1)
            err = np.abs(q_set_now - drive.q_fb)
            for r in np.flatnonzero(active & (bad | np.any(err > PROTECTIVE_STOP_RAD, axis=1))):
                active[r] = False
                status[r] = Status.DIVERGED if bad[r] else Status.PROTECTIVE_STOP
                reason[r] = diverged_reason(step, dt) if bad[r] else tripped_reason(step, dt, int(np.argmax(err[r])))
            if progress is not None and step >= next_progress * n_steps:
                progress(step / n_steps)
                next_progress += PROGRESS_STEP
        tau = drive.physics(q, qd) - b.terms.step_load(q, qd, mb, dt)
        if b.change[step]:
            mb.set_payload(a.payload_kg * b.gripped_step[step])
        mb.qfrc_applied[:] = tau
        # the friction's slope on top of the model's own joint damping: MuJoCo's Euler step applies both implicitly
        mb.dof_damping[:] = mb.model_damping + drive.s_l
        mb.step(active)
        q = mb.qpos.copy()
        qd = mb.qvel.copy()
        drive.sensors(q, qd)
        if (step + 1) % b.log_every == 0:
            li = (step + 1) // b.log_every - 1
            for arr, name in logged:
                arr[:, li] = getattr(drive, LOG_SOURCES[name]) if name != "q_rad" else q
            if not active.all():
                for arr, _ in logged:
                    arr[~active, li] = np.nan
    return log, status, reason


#: logged signal -> drive state row
LOG_SOURCES = {
    "q_rad": "q", "q_FB_rad": "q_fb", "q_M_rad": "th_m", "q_M_FB_rad": "th_fb", "w_M_FB_rad_s": "w_fb",
    "i_ref_A": "i_ref", "i_FB_A": "iq_fb", "i_q_A": "i_q", "i_d_A": "i_d", "v_q_V": "v_q", "v_d_V": "v_d",
    "T_gear_Nm": "t_id", "T_f_Nm": "t_f",
}

"""The batched engine: MuJoCo multibody plus six drive chains per run, stepped in lockstep.

Runs of one batch share a trajectory; each has its own MuJoCo model copy (payload, TCP)
and data, its own parameter row (:mod:`ur5fault.sim.run_arrays`) and its own random stream
(seeded by the run's ``seed`` only, so a faulty run and its healthy twin with the same
seed see the same sensor noise).  Two step loops run the same steps: the compiled one
(``steploop.py``, the default) runs every physics step of a run in machine code; the lockstep
loop (``_step_lockstep``, the reference) applies the drive chain to ``(n_runs, 6)`` arrays per
physics step (numpy modules or one compiled call per stage) and steps the multibody.

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
import logging
import time
from collections.abc import Callable, Sequence
from importlib import resources
from pathlib import Path

import mujoco
import numpy as np

from ..errors import ParameterError
from .axes import N_JOINTS
from .drive import controller as ctl
from .drive.layout import XI
from .drive.state import DRIVES, initial_state, pack_params
from .effects import EffectSpec
from .interfaces import Multibody
from .multibody import BatchMultibody, LoopMultibody
from .params import RobotParams, load_params
from .result import SimResult
from .run_arrays import RunArrays, build_run_arrays
from .terms import TermHook
from .trajectories import Trajectory

_log = logging.getLogger(__name__)

#: the packaged MJCF (package data, so it is found from an installed wheel too)
DEFAULT_MODEL_PATH = Path(str(resources.files("ur5fault") / "models" / "ur5.xml"))

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
#: step loops of :class:`Simulator` (``stepper``)
STEPPERS = ("compiled", "batch", "loop")


class Status(str, enum.Enum):
    """Outcome of a run."""

    OK = "ok"
    DIVERGED = "diverged"
    PROTECTIVE_STOP = "protective_stop"


@dataclasses.dataclass(frozen=True)
class RunSpec:
    """One run of a batch: identifier, noise seed and the effects it carries."""

    run_id: str
    seed: int = 0
    effects: tuple[EffectSpec, ...] = ()


class Simulator:
    """Loads the MJCF once; :meth:`run` simulates batches of runs on a trajectory.

    Args:
        params: robot and drive parameters (default: ``data/ur5_drive.yaml``).
        model_path: MJCF file (default: the packaged ``ur5fault/models/ur5.xml``).
        stepper: ``"compiled"`` (every physics step of a run in compiled code, ``steploop.py``; needs the
            compiled drive), ``"batch"`` (a Python loop over physics steps stepping all runs in lockstep with
            MuJoCo's threaded ``mujoco.batch``) or ``"loop"`` (the same with plain ``mj_step`` per run).  Default:
            ``"compiled"`` with the numba drive, ``"batch"`` with the numpy drive.
        nthread: threads of the compiled loop (runs spread over them) or of the batch stepper.
        drive: ``"numba"`` (compiled kernel, fast) or ``"numpy"`` (the reference modules).
    """

    def __init__(self, params: RobotParams | None = None, model_path: str | Path | None = None,
                 stepper: str | None = None, nthread: int = 1, drive: str = "numba") -> None:
        if drive not in DRIVES:
            raise ParameterError(f"drive = {drive!r} is not valid; choose one of: {', '.join(DRIVES)}")
        if stepper is None:
            stepper = "compiled" if drive == "numba" else "batch"
        if stepper not in STEPPERS:
            raise ParameterError(f"stepper = {stepper!r} is not valid; choose one of: {', '.join(STEPPERS)}")
        if stepper == "compiled" and drive != "numba":
            raise ParameterError(f"stepper = 'compiled' runs the compiled drive only, not drive = {drive!r}; "
                                 "choose stepper batch or loop for it")
        if int(nthread) < 1:
            raise ParameterError(f"nthread = {nthread} must be at least 1")
        self.stepper, self.nthread, self.drive = stepper, int(nthread), drive
        self.params = params if params is not None else load_params()
        self.model_path = Path(model_path) if model_path is not None else DEFAULT_MODEL_PATH
        self.model = mujoco.MjModel.from_xml_path(str(self.model_path))
        self.model.opt.timestep = self.params.physics_dt_s
        # the payload's centre of mass may move off its body origin at run time (effect payload_com):
        # MuJoCo skips body_ipos for bodies compiled with coinciding frames, so clear that flag
        payload = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "payload")
        self.model.body_sameframe[payload] = 0
        m = self.model
        self.tcp_site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tcp")
        p = self.params
        self.gains = ctl.design_gains(
            p.controller,
            p.motor.inductance_H,
            p.motor.resistance_ohm,
            p.motor.rotor_inertia_kgm2,
            p.motor.torque_constant_Nm_per_A,
            p.gear.ratio,
        )

    def _stepper_for_run(self) -> tuple[str, str]:
        """The stepper this run uses, and why it is not the configured one ("" if it is): the compiled loop
        cannot call Python back from inside ``mj_step`` (a callback set with ``mujoco.set_mjcb_passive`` and
        the like), so such a batch runs in the lockstep loop over plain ``mj_step``."""
        if self.stepper != "compiled":
            return self.stepper, ""
        from . import mjlib

        why = mjlib.unavailable_reason()
        if not why and mjlib.python_callbacks_set():
            why = f"MuJoCo callback {', '.join(mjlib.python_callbacks_set())} is set"
        return ("loop", why) if why else ("compiled", "")

    def _multibody(self, a: RunArrays, stepper: str) -> Multibody:
        tcp = np.asarray(self.params.tcp_offset_m)
        if stepper in ("loop", "compiled"):
            return LoopMultibody(self.model, a.n_runs, tcp, a.payload_com_m)
        return BatchMultibody(self.model, a.n_runs, tcp, a.payload_com_m, self.nthread)

    # ------------------------------------------------------------------ public API
    def run(
        self,
        trajectory: Trajectory,
        runs: Sequence[RunSpec],
        *,
        log_period_s: float = 1e-3,
        duration_s: float | None = None,
        progress: Callable[[float], None] | None = None,
    ) -> SimResult:
        """Simulate ``runs`` in lockstep on ``trajectory``.

        Args:
            trajectory: setpoints and payload events shared by the batch.
            runs: the runs; one run is a batch of one.
            log_period_s: spacing of logged samples [s]; a multiple of the physics step.
            duration_s: simulated time [s] (default: the trajectory's duration).
            progress: called with the finished fraction (0..1) about every 2 % of the run.

        Returns:
            A :class:`SimResult` with signals shaped ``(n_runs, n_log, 6)``.
        """
        if not runs:
            raise ParameterError("run() needs at least one RunSpec")
        p = self.params
        dt = p.physics_dt_s
        log_every = round(log_period_s / dt)
        if log_every < 1 or abs(log_every * dt - log_period_s) > 1e-12:
            raise ParameterError(f"log_period_s = {log_period_s:g} must be a whole multiple of physics_dt_s = {dt:g}")
        duration = trajectory.duration_s if duration_s is None else float(duration_s)
        n_steps = int(round(duration / dt))
        if n_steps < 1:
            raise ParameterError(f"duration_s = {duration} s is shorter than one physics step")
        a = build_run_arrays(p, [r.effects for r in runs], trajectory.default_payload_kg)
        _log.info("simulating %d run(s) x %d physics steps of %g s on %s (drive %s, stepper %s, %d thread(s))",
                  len(runs), n_steps, dt, trajectory.name, self.drive, self.stepper, self.nthread)
        t0 = time.perf_counter()
        res = _integrate(self, trajectory, list(runs), a, n_steps, log_every, progress)
        _log.info("simulated %d run(s) in %.2f s wall; status: %s", len(runs), time.perf_counter() - t0,
                  ", ".join(f"{r}={s}" for r, s in zip(res.run_ids, res.status)) if len(runs) <= 8
                  else {s: res.status.count(s) for s in set(res.status)})
        for r, s, why in zip(res.run_ids, res.status, res.reason):
            if s != Status.OK.value:
                _log.debug("run %s: %s (%s)", r, s, why)
        return res


@dataclasses.dataclass
class _Batch:
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


def _prepare(sim: Simulator, traj: Trajectory, runs: list[RunSpec], a: RunArrays, n_steps: int, log_every: int,
             stepper: str) -> _Batch:
    """Setpoints, payload events, the multibody at a consistent start at rest and the drive chain holding it."""
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
    q = np.tile(q_set_s[0], (a.n_runs, 1))
    bias = mb.start(q)
    bias = bias + terms.static_load(q, mb, dt)  # the terms' static load is held from the start
    P = pack_params(p, sim.gains, a)
    drive = DRIVES[sim.drive](P, initial_state(P, q, bias), dt, ts, p.friction.stribeck_rate_s_per_rad)
    return _Batch(n_steps, log_every, q_set_s, qd_set_s, gripped_step, change, mb, terms, drive, q,
                  np.rint(a.setpoint_delay_s / ts).astype(int), [np.random.default_rng(r.seed) for r in runs])


def _integrate(sim: Simulator, traj: Trajectory, runs: list[RunSpec], a: RunArrays, n_steps: int,
               log_every: int, progress) -> SimResult:
    stepper, why = sim._stepper_for_run()
    if why:
        _log.warning("the compiled step loop cannot run this batch (%s): the lockstep loop runs it", why)
    b = _prepare(sim, traj, runs, a, n_steps, log_every, stepper)
    if stepper == "compiled":
        log, status, reason = _step_compiled(sim, b, a, progress)
    else:
        log, status, reason = _step_lockstep(sim, b, a, progress)
    if progress is not None:
        progress(1.0)
    t_log = (np.arange(b.n_log) + 1) * log_every * sim.params.physics_dt_s
    b.terms.apply_sensor_terms(log, t_log)  # sensor terms act on the logged readings
    for r in np.flatnonzero(b.mb.warnings() > 0):
        if status[r] is Status.OK:
            status[r], reason[r] = Status.DIVERGED, "MuJoCo reported a simulation warning (instability)"
    q_set_log, _ = traj.interpolate(t_log)
    return SimResult.build(sim.params, sim.model_path, sim.tcp_site, traj, runs, a, t_log, q_set_log, log,
                           [s.value for s in status], reason, b.mb.run_models())


def _diverged(step: int, dt: float) -> str:
    return f"non-finite or runaway joint state at t={step * dt:.4f} s"


def _tripped(step: int, dt: float, joint: int) -> str:
    return f"tracking error of joint {joint + 1} above {PROTECTIVE_STOP_RAD} rad at t={step * dt:.4f} s"


def _step_compiled(sim: Simulator, b: _Batch, a: RunArrays, progress):
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
            status[r], reason[r] = Status.DIVERGED, _diverged(step, dt)
        else:
            status[r], reason[r] = Status.PROTECTIVE_STOP, _tripped(step, dt, joint)
    return log, status, reason


def _step_lockstep(sim: Simulator, b: _Batch, a: RunArrays, progress):
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
                reason[r] = _diverged(step, dt) if bad[r] else _tripped(step, dt, int(np.argmax(err[r])))
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

"""The batched engine: MuJoCo multibody plus six drive chains per run, stepped in lockstep.

Runs of one batch share a trajectory; each has its own MuJoCo model copy (payload, TCP)
and data, its own parameter row (:mod:`ur5fault.sim.run_arrays`) and its own random stream
(seeded by the run's ``seed`` only, so a faulty run and its healthy twin with the same
seed see the same sensor noise).  Per physics step the drive chain is one set of numpy
expressions over ``(n_runs, 6)`` arrays; only ``mj_step`` is called per run.

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
        stepper: ``"batch"`` (MuJoCo's threaded ``mujoco.batch``) or ``"loop"`` (plain ``mj_step`` per run).
        nthread: threads of the batch stepper.
        drive: ``"numba"`` (compiled kernel, fast) or ``"numpy"`` (the reference modules).
    """

    def __init__(self, params: RobotParams | None = None, model_path: str | Path | None = None,
                 stepper: str = "batch", nthread: int = 1, drive: str = "numba") -> None:
        if stepper not in ("batch", "loop"):
            raise ParameterError(f"stepper = {stepper!r} is not valid; choose one of: batch, loop")
        if drive not in DRIVES:
            raise ParameterError(f"drive = {drive!r} is not valid; choose one of: {', '.join(DRIVES)}")
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

    def _multibody(self, a: RunArrays) -> Multibody:
        tcp = np.asarray(self.params.tcp_offset_m)
        if self.stepper == "loop":
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
        _log.info("simulating %d run(s) x %d physics steps of %g s on %s (drive %s, stepper %s)", len(runs), n_steps,
                  dt, trajectory.name, self.drive, self.stepper)
        t0 = time.perf_counter()
        res = _integrate(self, trajectory, list(runs), a, n_steps, log_every, progress)
        _log.info("simulated %d run(s) in %.2f s wall; status: %s", len(runs), time.perf_counter() - t0,
                  ", ".join(f"{r}={s}" for r, s in zip(res.run_ids, res.status)) if len(runs) <= 8
                  else {s: res.status.count(s) for s in set(res.status)})
        for r, s, why in zip(res.run_ids, res.status, res.reason):
            if s != Status.OK.value:
                _log.debug("run %s: %s (%s)", r, s, why)
        return res


def _integrate(sim: Simulator, traj: Trajectory, runs: list[RunSpec], a: RunArrays, n_steps: int,
               log_every: int, progress) -> SimResult:
    p = sim.params
    dt = p.physics_dt_s
    sps = p.steps_per_servo
    ts = p.controller.servo_period_s
    n = len(runs)

    # setpoints at servo instants and payload events at physics steps
    n_servo = n_steps // sps + 1
    q_set_s, qd_set_s = traj.interpolate(np.arange(n_servo) * ts)
    gripped_step = traj.gripped(np.arange(n_steps + 1) * dt)
    change_steps = set((np.flatnonzero(np.diff(gripped_step.astype(int))) + 1).tolist())

    # multibody, consistent start at rest, drive chain
    mb = sim._multibody(a)
    # >>> data-driven terms hook (ur5fault/sim/terms.py): None unless some run carries a term effect
    terms = TermHook.build(a)
    if terms is not None:
        terms.prepare_model(mb)
    # <<<
    mb.set_payload(a.payload_kg * gripped_step[0])
    q = np.tile(q_set_s[0], (n, 1))
    bias = mb.start(q)
    if terms is not None and terms.link_torque:  # >>> term hook: the terms' static load is held from the start
        bias = bias + terms.load_torque(q, np.zeros_like(q), np.ones_like(q), dt,
                                        mb.gravity_torque() if terms.gravity else None)
    qd = np.zeros((n, N_JOINTS))
    P = pack_params(sim, a)
    drive = DRIVES[sim.drive](P, initial_state(P, q, bias), dt, ts, p.friction.stribeck_rate_s_per_rad)

    # setpoint latency per run, in whole servo samples (effect "delay")
    delay_k = np.rint(a.setpoint_delay_s / ts).astype(int)
    delayed = bool(np.any(delay_k))
    rngs = [np.random.default_rng(r.seed) for r in runs]
    noise = np.empty((n, NOISE_CHUNK_SAMPLES, len(NOISE_CHANNELS), N_JOINTS))

    n_log = n_steps // log_every
    log = {name: np.full((n, n_log, N_JOINTS), np.nan) for name in SimResult.JOINT_SIGNALS}
    logged = [(log[name], name) for name in SimResult.JOINT_SIGNALS]
    active = np.ones(n, dtype=bool)
    status = [Status.OK] * n
    reason = [""] * n
    next_progress = 0.0

    for step in range(n_steps):
        if step % sps == 0:
            si = step // sps
            ci = si % NOISE_CHUNK_SAMPLES
            if ci == 0:
                for r in range(n):
                    noise[r] = rngs[r].standard_normal((NOISE_CHUNK_SAMPLES, len(NOISE_CHANNELS), N_JOINTS))
            if delayed:
                k = np.maximum(si - delay_k, 0)
                q_set_now, qd_set_now = q_set_s[k], qd_set_s[k]
            else:
                q_set_now = np.broadcast_to(q_set_s[si], (n, N_JOINTS))
                qd_set_now = np.broadcast_to(qd_set_s[si], (n, N_JOINTS))
            drive.servo(q_set_now, qd_set_now, noise[:, ci])
            # run health: a diverged or tripped run is frozen and its remaining log left NaN
            bad = ~np.all(np.isfinite(q), axis=1) | np.any(np.abs(q) > RUNAWAY_LIMIT_RAD, axis=1)
            trip = np.any(np.abs(q_set_now - drive.q_fb) > PROTECTIVE_STOP_RAD, axis=1)
            if bad.any() or trip.any():
                for r in np.flatnonzero(active & (bad | trip)):
                    active[r] = False
                    if bad[r]:
                        status[r] = Status.DIVERGED
                        reason[r] = f"non-finite or runaway joint state at t={step * dt:.4f} s"
                    else:
                        j = int(np.argmax(np.abs(q_set_now[r] - drive.q_fb[r])))
                        status[r] = Status.PROTECTIVE_STOP
                        reason[r] = (f"tracking error of joint {j + 1} above {PROTECTIVE_STOP_RAD} rad "
                                     f"at t={step * dt:.4f} s")
            if progress is not None and step >= next_progress * n_steps:
                progress(step / n_steps)
                next_progress += PROGRESS_STEP

        tau = drive.physics(q, qd)
        if terms is not None and terms.link_torque:  # >>> term hook: load torques of data-driven terms
            tau = tau - terms.load_torque(q, qd, mb.mass_diagonal(), dt,
                                         mb.gravity_torque() if terms.gravity else None)
        if step in change_steps:
            mb.set_payload(a.payload_kg * gripped_step[step])
        mb.qfrc_applied[:] = tau
        # the friction's slope on top of the model's own joint damping: MuJoCo's Euler step applies both implicitly
        mb.dof_damping[:] = mb.model_damping + drive.s_l
        mb.step(active)
        q = mb.qpos.copy()
        qd = mb.qvel.copy()
        drive.sensors(q, qd)

        if (step + 1) % log_every == 0:
            li = (step + 1) // log_every - 1
            for arr, name in logged:
                arr[:, li] = getattr(drive, LOG_SOURCES[name]) if name != "q_rad" else q
            if not active.all():
                for arr, _ in logged:
                    arr[~active, li] = np.nan

    if progress is not None:
        progress(1.0)
    if terms is not None:  # >>> term hook: sensor terms on the logged readings
        terms.apply_sensor_terms(log, (np.arange(n_log) + 1) * log_every * dt)
    for r in np.flatnonzero(mb.warnings() > 0):
        if status[r] is Status.OK:
            status[r], reason[r] = Status.DIVERGED, "MuJoCo reported a simulation warning (instability)"
    t_log = (np.arange(n_log) + 1) * log_every * dt
    q_set_log, _ = traj.interpolate(t_log)
    return SimResult.build(sim.params, sim.model_path, sim.tcp_site, traj, runs, a, t_log, q_set_log, log,
                           [s.value for s in status], reason,
                           mb.run_models())


#: logged signal -> drive state row
LOG_SOURCES = {
    "q_rad": "q", "q_FB_rad": "q_fb", "q_M_rad": "th_m", "q_M_FB_rad": "th_fb", "w_M_FB_rad_s": "w_fb",
    "i_ref_A": "i_ref", "i_FB_A": "iq_fb", "i_q_A": "i_q", "i_d_A": "i_d", "v_q_V": "v_q", "v_d_V": "v_d",
    "T_gear_Nm": "t_id", "T_f_Nm": "t_f",
}

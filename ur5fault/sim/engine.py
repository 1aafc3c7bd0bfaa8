"""The batched engine: MuJoCo multibody plus six drive chains per run, stepped in lockstep.

Runs of one batch share a trajectory; each has its own MuJoCo model copy (payload, TCP)
and data, its own parameter row (:mod:`ur5fault.sim.run_arrays`) and its own random stream
(seeded by the run's ``seed`` only, so a faulty run and its healthy twin with the same
seed see the same sensor noise).  Two step loops run the same steps: the compiled one
(``steploop.py``, the default) runs every physics step of a run in machine code; the lockstep
loop (``loops.step_lockstep``, the reference) applies the drive chain to ``(n_runs, 6)`` arrays per
physics step (numpy modules or one compiled call per stage) and steps the multibody.

The step order is in :mod:`ur5fault.sim.loops`.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import numbers
import os
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from importlib import resources
from pathlib import Path

import mujoco
import numpy as np

from ..errors import ParameterError
from ..util.checks import check_number, is_integer, short
from .budget import check_memory, sim_bytes
from .drive import controller as ctl
from .drive.state import DRIVES
from .effects import EffectSpec
from .interfaces import Multibody
from .loops import (  # noqa: F401  (the run-health limits and noise layout stay importable here)
    LOG_SOURCES,
    NOISE_CHANNELS,
    NOISE_CHUNK_SAMPLES,
    PROGRESS_STEP,
    PROTECTIVE_STOP_RAD,
    RUNAWAY_LIMIT_RAD,
    Status,
    prepare,
    step_compiled,
    step_lockstep,
)
from .multibody import BatchMultibody, LoopMultibody
from .params import RobotParams, load_params
from .result import SimResult
from .run_arrays import RunArrays, build_run_arrays
from .runspec import MAX_SEED, RunSpec  # noqa: F401  (engine.RunSpec stays importable: users build batches with it)
from .trajectories import Trajectory

_log = logging.getLogger(__name__)

#: the packaged MJCF (package data, so it is found from an installed wheel too)
DEFAULT_MODEL_PATH = Path(str(resources.files("ur5fault") / "models" / "ur5.xml"))

#: step loops of :class:`Simulator` (``stepper``)
STEPPERS = ("compiled", "batch", "loop")


def has_no_constraints(model: mujoco.MjModel) -> bool:
    """Whether ``model`` can have no constraint rows at all: no equality constraints, joint or tendon limits,
    friction loss, and no contacts (switched off, or no geom that collides)."""
    contacts_off = bool(model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT) or not (
        np.any(model.geom_contype) or np.any(model.geom_conaffinity))
    return (model.neq == 0 and not np.any(model.jnt_limited) and not np.any(model.dof_frictionloss)
            and not np.any(model.tendon_limited) and not np.any(model.tendon_frictionloss) and contacts_off)


def skip_constraint_stage(model: mujoco.MjModel) -> None:
    """Switch MuJoCo's constraint stage off (``mjDSBL_CONSTRAINT``) for a model without constraints
    (:func:`has_no_constraints`, as the packaged UR5): it makes no rows, so the accelerations and every state are
    the same bit for bit, and each ``mj_step`` skips the stage's set-up (measured: about 5 % of a bare step of the
    packaged model, docs/performance.md).  A model with any constraint is left as it is."""
    if has_no_constraints(model):
        model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT


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
        if not is_integer(nthread) or nthread < 1:
            raise ParameterError(f"nthread = {short(nthread)} must be a whole number, at least 1")
        if params is not None and not isinstance(params, RobotParams):
            raise ParameterError(f"params = {short(params)} must be a RobotParams (load_params(path, overrides)) or "
                                 "None for the packaged parameters")
        if model_path is not None and not isinstance(model_path, (str, os.PathLike)):
            raise ParameterError(f"model_path = {short(model_path)} must be the path of an MJCF file, or None for "
                                 "the packaged model")
        self.stepper, self.nthread, self.drive = stepper, int(nthread), drive
        self.params = params if params is not None else load_params()
        self.model_path = Path(model_path) if model_path is not None else DEFAULT_MODEL_PATH
        if not self.model_path.is_file():
            raise ParameterError(f"model_path = {str(self.model_path)!r}: no such file (an MJCF model, e.g. the "
                                 f"packaged {DEFAULT_MODEL_PATH.name})")
        self.model = mujoco.MjModel.from_xml_path(str(self.model_path))
        self.model.opt.timestep = self.params.physics_dt_s
        # the payload's centre of mass may move off its body origin at run time (effect payload_com):
        # MuJoCo skips body_ipos for bodies compiled with coinciding frames, so clear that flag
        payload = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "payload")
        self.model.body_sameframe[payload] = 0
        skip_constraint_stage(self.model)
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
        from .jitcache import protect

        protect(mjlib)  # its numba cache verified on read (jitcache.py)
        why = mjlib.unavailable_reason()
        if not why and mjlib.python_callbacks_set():
            why = f"MuJoCo callback {', '.join(mjlib.python_callbacks_set())} is set"
        return ("loop", why) if why else ("compiled", "")

    def _multibody(self, a: RunArrays, stepper: str | None = None) -> Multibody:
        """The runs' multibody for ``stepper`` (default: the configured one); the compiled loop steps per-run
        models and data, as the plain loop does."""
        stepper = stepper or self.stepper
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

        Raises:
            ParameterError: a bad argument, named with its value and what is valid (checked before anything is
                simulated), or a batch whose log would not fit in the memory available.
        """
        _check_trajectory(trajectory)
        runs = _checked_runs(_run_list(runs))
        if progress is not None and not callable(progress):
            raise ParameterError(f"progress = {short(progress)} must be a function of the finished fraction "
                                 "(0..1), or None")
        p = self.params
        dt = p.physics_dt_s
        log_period_s = check_number(log_period_s, "log_period_s", 0.0, math.inf, "s", lo_open=True)
        log_every = round(log_period_s / dt)
        if log_every < 1 or abs(log_every * dt - log_period_s) > 1e-12:
            raise ParameterError(f"log_period_s = {log_period_s:g} must be a whole multiple of physics_dt_s = {dt:g}")
        # any finite length (the command line's and YAML's 3600 s cap is theirs); check_memory bounds the log
        duration = trajectory.duration_s if duration_s is None else check_number(duration_s, "duration_s", 0.0,
                                                                                  math.inf, "s", lo_open=True)
        n_steps = int(round(duration / dt))
        if n_steps < 1:
            raise ParameterError(f"duration_s = {duration} s is shorter than one physics step")
        if n_steps < log_every:
            raise ParameterError(f"duration_s = {duration:g} s is shorter than one log period (log_period_s = "
                                 f"{log_period_s:g} s): nothing would be logged")
        check_memory(sim_bytes(len(runs), n_steps // log_every),
                     f"run(): {len(runs)} run(s) of {duration:g} s logged every {log_period_s:g} s",
                     "simulate fewer runs at once, a shorter duration_s or a longer log_period_s")
        a = build_run_arrays(p, [r.effects for r in runs], trajectory.default_payload_kg)
        _log.info("simulating %d run(s) x %d physics steps of %g s on %s (drive %s, stepper %s, %d thread(s))",
                  len(runs), n_steps, dt, trajectory.name, self.drive, self.stepper, self.nthread)
        t0 = time.perf_counter()
        from .mjlog import no_log_file
        from .mjtimers import timers_off

        # MuJoCo's stage timers cost a quarter of a step here and are never read; its log file would put a
        # MUJOCO_LOG.TXT in the user's folder for every unstable run, whose status the result records anyway
        with timers_off(), no_log_file():
            res = _integrate(self, trajectory, runs, a, n_steps, log_every, progress)
        _log.info("simulated %d run(s) in %.2f s wall; status: %s", len(runs), time.perf_counter() - t0,
                  ", ".join(f"{r}={s}" for r, s in zip(res.run_ids, res.status)) if len(runs) <= 8
                  else {s: res.status.count(s) for s in set(res.status)})
        for r, s, why in zip(res.run_ids, res.status, res.reason):
            if s != Status.OK.value:
                _log.debug("run %s: %s (%s)", r, s, why)
        return res


def _check_trajectory(trajectory: object) -> None:
    if not isinstance(trajectory, Trajectory):
        hint = (f"get_trajectory({trajectory!r}) builds the one of that name" if isinstance(trajectory, str)
                else "build one with get_trajectory(name, ...) or pick_and_place(...)")
        raise ParameterError(f"run(): trajectory = {short(trajectory)} must be a Trajectory; {hint}")


def _run_list(runs: object) -> list:
    """``runs`` as a list: any iterable of runs but a single RunSpec, a string or a mapping; at least one run."""
    if isinstance(runs, RunSpec):
        raise ParameterError(f"run(): runs = {short(runs)} must be a list of RunSpec; one run is a batch of one: "
                             "[RunSpec(...)]")
    if isinstance(runs, (str, bytes, Mapping)) or not isinstance(runs, Iterable):
        raise ParameterError(f"run(): runs = {short(runs)} must be a list of RunSpec(run_id, seed, effects)")
    out = list(runs)
    if not out:
        raise ParameterError("run() needs at least one RunSpec")
    return out


def _checked_runs(runs: Sequence[RunSpec]) -> list[RunSpec]:
    """The runs, each a RunSpec with its own run_id, a non-empty one-line string (the result finds runs by id: a
    second run of one id would be unreachable by name) and an integer seed in [0, MAX_SEED], made a Python int (a
    numpy integer would not go into the result file's JSON metadata)."""
    seen: set[str] = set()
    out = []
    for i, r in enumerate(runs):
        if not isinstance(r, RunSpec):
            raise ParameterError(f"runs[{i}] = {type(r).__name__}: each run is a RunSpec(run_id, seed, effects)")
        if not isinstance(r.run_id, str) or not r.run_id.strip() or "\n" in r.run_id:
            raise ParameterError(f"runs[{i}]: run_id = {short(r.run_id)} must be a non-empty one-line string (the "
                                 "result finds the run by it)")
        if isinstance(r.seed, bool) or not isinstance(r.seed, numbers.Integral) or not 0 <= r.seed <= MAX_SEED:
            raise ParameterError(f"RunSpec {r.run_id!r}: seed = {r.seed!r} must be an integer in [0, {MAX_SEED}]")
        if not isinstance(r.effects, (tuple, list)) or not all(isinstance(e, EffectSpec) for e in r.effects):
            raise ParameterError(f"RunSpec {r.run_id!r}: effects = {r.effects!r}: each effect is an EffectSpec; build "
                                 "it with make_effect(name, joint, **sizes)")
        if r.run_id in seen:
            raise ParameterError(f"runs[{i}]: run_id {r.run_id!r} is given twice; give each run its own run_id")
        seen.add(r.run_id)
        out.append(r if type(r.seed) is int else dataclasses.replace(r, seed=int(r.seed)))
    return out


def _integrate(sim: Simulator, traj: Trajectory, runs: list[RunSpec], a: RunArrays, n_steps: int,
               log_every: int, progress) -> SimResult:
    stepper, why = sim._stepper_for_run()
    if why:
        _log.warning("the compiled step loop cannot run this batch (%s): the lockstep loop runs it", why)
    b = prepare(sim, traj, runs, a, n_steps, log_every, stepper)
    if stepper == "compiled":
        log, status, reason = step_compiled(sim, b, a, progress)
    else:
        log, status, reason = step_lockstep(sim, b, a, progress)
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



"""A campaign's cost, estimated before anything runs: physics steps, compute time and memory.

Hard limits refuse a campaign outright (memory beyond what the machine has, more than
:data:`MAX_RUN_STEPS` physics steps); a large campaign (more than :data:`CONFIRM_RUNS` runs or
:data:`CONFIRM_RUN_STEPS` steps) needs ``--yes`` on the command line.  Where the per-step and
per-sample figures come from: :mod:`ur5fault.sim.budget`.
"""

from __future__ import annotations

import dataclasses
import os

from ..config import parse_trajectory
from ..errors import ParameterError
from ..sim.budget import check_memory, core_hours, fmt_bytes, sim_bytes
from ..sim.params import load_params
from ..util.checks import check_count
from .batches import plan_batches
from .digital_twin import regressor_runs, twin_id
from .runs import trajectory_specs
from .spec import Campaign

#: assumption: above a thousand runs or 2e9 physics steps (~2.4 core-hours at 4.3 us per
#: run-step), a typo in a sweep list is more likely than intent, so the user confirms with --yes
CONFIRM_RUNS = 1000
CONFIRM_RUN_STEPS = 2e9
#: assumption: 1e12 physics steps (~1200 core-hours) is beyond what one campaign folder should hold
MAX_RUN_STEPS = 1e12


@dataclasses.dataclass(frozen=True)
class CostEstimate:
    """What a campaign will cost (before resume: every run counted)."""

    n_runs: int
    run_steps: float
    core_hours: float
    processes: int
    runs_at_once: int
    max_logged: int
    memory_bytes: float

    def describe(self) -> str:
        return (f"{self.n_runs} runs, {self.run_steps:.3g} physics steps (about {self.core_hours:.3g} core-hours), "
                f"about {fmt_bytes(self.memory_bytes)} of memory")


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS reports it)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def effective_jobs(requested: int | None) -> tuple[int, str | None]:
    """Worker processes to use and a note when ``requested`` was capped at the core count."""
    cores = available_cores()
    if requested is None:
        return cores, None
    requested = check_count(requested, "--jobs", 1)
    if requested > cores:
        return cores, f"--jobs {requested} capped at the {cores} cores available"
    return requested, None


def estimate(camp: Campaign, jobs: int) -> CostEstimate:
    """Steps, compute time and peak memory of running every run of ``camp`` on ``jobs`` processes."""
    dt = load_params(overrides=dict(camp.base_params)).physics_dt_s
    durations = {}
    for spec in trajectory_specs(camp.runs):
        durations[repr(spec)] = camp.duration_s or parse_trajectory(spec, "trajectory").duration_s
    steps = sum(round(durations[repr(rc.cond["trajectory"])] / dt) for rc in camp.runs)
    grid_at_once = 0
    if camp.twin_residuals:  # every run's digital twin (one per distinct known conditions and seed)
        twins = {twin_id(rc): rc for rc in camp.runs}
        steps += sum(round(durations[repr(rc.cond["trajectory"])] / dt) for rc in twins.values())
        for batch in plan_batches(camp, camp.runs, jobs):  # + each batch's noise-free regressor twins
            n_grid = len(regressor_runs(camp, batch, 0.0)[1])  # (their count does not depend on the temperature)
            steps += n_grid * round(durations[repr(batch[0].cond["trajectory"])] / dt)
            grid_at_once = max(grid_at_once, n_grid)
    max_logged = int(max(durations.values()) / camp.log_period_s)
    n = len(camp.runs)
    per_worker = -(-n // max(1, jobs))
    runs_at_once = min(n, 2 * max(1, min(camp.batch_size - 1, per_worker)))  # plan_batches: a chunk + its twins
    if camp.twin_residuals:
        runs_at_once += max(1, min(camp.batch_size - 1, per_worker)) + grid_at_once  # + its digital, regressor twins
    processes = max(1, min(jobs, n))
    memory = sim_bytes(runs_at_once, max_logged, processes) + sim_bytes(0, 0)  # + the parent process
    return CostEstimate(n, float(steps), core_hours(steps), processes, runs_at_once, max_logged, memory)


def check_limits(camp: Campaign, est: CostEstimate) -> None:
    """Refuse a campaign beyond the hard limits (memory, total steps), with the estimate."""
    if est.run_steps > MAX_RUN_STEPS:
        raise ParameterError(f"campaign {camp.name}: {est.describe()}; above the limit of {MAX_RUN_STEPS:g} "
                             "physics steps: split the sweep or shorten duration_s")
    check_memory(est.memory_bytes, f"campaign {camp.name} ({est.processes} processes x {est.runs_at_once} runs "
                 f"x {est.max_logged} logged samples)", "raise log_period_s, lower batch_size or --jobs")


def beyond_confirmation(n_runs: float, run_steps: float) -> bool:
    """Whether a campaign of ``n_runs`` runs and ``run_steps`` physics steps needs ``--yes``."""
    return n_runs > CONFIRM_RUNS or run_steps > CONFIRM_RUN_STEPS


def needs_yes_because(cost: str) -> str:
    """The refusal of a campaign :func:`beyond_confirmation`: ``cost`` (what it would run, as a sentence) and the
    rule, for a fault campaign (:func:`confirmation_needed`) and a life campaign
    (``health.prognostics.spec.life_confirmation_needed``) alike."""
    return f"{cost}; more than {CONFIRM_RUNS} runs or {CONFIRM_RUN_STEPS:g} steps needs --yes to start"


def confirmation_needed(camp: Campaign, est: CostEstimate) -> str | None:
    """Why this fault campaign needs ``--yes`` (too many runs or steps), or None."""
    if beyond_confirmation(est.n_runs, est.run_steps):
        return needs_yes_because(f"campaign {camp.name}: {est.describe()}")
    return None

"""What a simulation will cost, estimated before it starts, and the limits that refuse runaways.

Numbers and where they come from:

- :data:`BYTES_PER_LOGGED_SAMPLE`: traced Python/numpy peak of ``Simulator.run`` plus one run's
  wide table and its features, per run and logged sample: 1343 B measured here (8 runs x 20 000
  samples, tracemalloc), 1600-1700 B in docs/performance.md (batches of 8-32, 2 s); the larger is used.
- :data:`PROCESS_BASE_BYTES`: maximum RSS of a process that imported ur5fault and ran one step,
  292 MB measured here.
- :data:`US_PER_RUN_STEP`: 4.3 us per run-step, the lockstep batch of 32 in docs/performance.md
  (used only to put an hours figure in messages).
- The limits themselves are assumptions, stated where they are defined.
"""

from __future__ import annotations

import os

from ..errors import ParameterError

BYTES_PER_LOGGED_SAMPLE = 1700
PROCESS_BASE_BYTES = 300e6
US_PER_RUN_STEP = 4.3
#: refuse a simulation whose estimate exceeds this share of the memory available now (assumption:
#: leave room for the OS, the page cache and the estimate's own error)
MEMORY_FRACTION = 0.8
#: simulated time of one run [s] (assumption: an hour of robot time, 72 million steps at 50 us,
#: is beyond any fault campaign; longer studies are split into runs)
MAX_DURATION_S = 3600.0


def available_memory_bytes() -> float:
    """Memory available to new allocations now: ``MemAvailable`` (Linux), else physical memory."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return float("inf")


def fmt_bytes(n: float) -> str:
    for unit, size in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.1f} {unit}"
    return f"{n:.0f} B"


def sim_bytes(runs_at_once: int, n_logged: int, processes: int = 1) -> float:
    """Estimated peak memory of ``processes`` processes each simulating ``runs_at_once`` runs of
    ``n_logged`` logged samples."""
    return processes * (PROCESS_BASE_BYTES + runs_at_once * n_logged * BYTES_PER_LOGGED_SAMPLE)


def check_memory(estimate_bytes: float, what: str, way_out: str) -> None:
    """Refuse when ``estimate_bytes`` exceeds :data:`MEMORY_FRACTION` of the available memory."""
    avail = available_memory_bytes()
    if estimate_bytes > MEMORY_FRACTION * avail:
        raise ParameterError(f"{what} needs about {fmt_bytes(estimate_bytes)} of memory, more than "
                             f"{MEMORY_FRACTION:.0%} of the {fmt_bytes(avail)} available; {way_out}")


def core_hours(run_steps: float) -> float:
    """Rough compute time of ``run_steps`` physics steps [core-hours] (see :data:`US_PER_RUN_STEP`)."""
    return run_steps * US_PER_RUN_STEP * 1e-6 / 3600.0

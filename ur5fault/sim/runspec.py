"""One run of a batch, as the engine takes it and its result records it."""

from __future__ import annotations

import dataclasses

from .effects import EffectSpec

#: the largest noise seed: what a Parquet int64 column (the run files' seed) holds
MAX_SEED = 2**63 - 1


@dataclasses.dataclass(frozen=True)
class RunSpec:
    """One run of a batch: identifier, noise seed and the effects it carries.

    Attributes:
        run_id: the run's name in its result: a non-empty one-line string, unique within the batch.
            :class:`~ur5fault.sim.result.SimResult` finds a run by it (``to_pandas("worn")``), writes it in the
            run's metadata, and keeps the batch's order (``SimResult.run_ids``), so an index finds a run too.
            It is a label, not an input: two runs that differ only in run_id simulate the same numbers.
        seed: the noise seed, an integer in ``[0, MAX_SEED]`` (a numpy integer is made a Python int).
        effects: the run's effects, each built with :func:`~ur5fault.sim.effects.make_effect`, applied in order:
            the same effect given twice on one joint is not refused here (a campaign puts its faults on top of a
            model overlay's on purpose): one that sets a value (``backlash``) keeps the last, one that scales
            (``coulomb_friction``) compounds (1.5 then 2.0 is 3.0). The command line and YAML files refuse such a
            repeat (``ur5fault.config.refuse_repeats``); call it on your effects for the same check.

    :meth:`ur5fault.sim.engine.Simulator.run` checks all three before simulating and refuses a bad one by name.
    """

    run_id: str
    seed: int = 0
    effects: tuple[EffectSpec, ...] = ()

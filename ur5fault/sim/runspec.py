"""One run of a batch, as the engine takes it and its result records it."""

from __future__ import annotations

import dataclasses

from .effects import EffectSpec

#: the largest noise seed: what a Parquet int64 column (the run files' seed) holds
MAX_SEED = 2**63 - 1


@dataclasses.dataclass(frozen=True)
class RunSpec:
    """One run of a batch: identifier, noise seed and the effects it carries."""

    run_id: str
    seed: int = 0
    effects: tuple[EffectSpec, ...] = ()

"""One progress implementation for every long task (simulate, campaigns, the discrepancy search):
tqdm's ``auto`` flavour, which draws a widget in a notebook and a bar on a terminal, and stays
silent when the output is not interactive (a CI log, a file) or when the caller asks for quiet.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


def bar(total: float, desc: str, unit: str = "it", enabled: bool = True, **kwargs: Any):
    """A tqdm bar; ``enabled=False`` (``--quiet``) or a non-interactive stream gives a silent one."""
    from tqdm.auto import tqdm

    # disable=None: tqdm switches itself off when stderr is not a terminal (no log spam in CI)
    return tqdm(total=total, desc=desc, unit=unit, disable=None if enabled else True, dynamic_ncols=True,
                **kwargs)


def fraction_callback(pbar) -> Callable[[float], None]:
    """Adapter for :meth:`ur5fault.sim.engine.Simulator.run`'s ``progress(fraction)`` on a bar of total 1."""

    def update(frac: float) -> None:
        pbar.n = round(min(max(frac, 0.0), 1.0), 4)
        pbar.refresh()

    return update


class CampaignProgress:
    """Reports finished runs of a campaign: to a tqdm bar, to a callback ``(done, total, eta_s)``, or nowhere."""

    def __init__(self, progress: bool | Callable[[int, int, float], None], total: int) -> None:
        self.total = total
        self.callback = progress if callable(progress) else None
        self.bar = None if self.callback else bar(total, "campaign", "run", enabled=bool(progress))
        self.start_done: int | None = None

    def __call__(self, done: int, elapsed_s: float) -> None:
        if self.start_done is None:
            self.start_done = done
        if self.callback is not None:
            new = done - self.start_done
            eta = (self.total - done) * elapsed_s / new if new > 0 else float("nan")
            self.callback(done, self.total, eta)
        elif self.bar is not None:
            if self.bar.n == 0 and done and self.start_done == done:
                self.bar.reset(total=self.total)
                self.bar.update(done)  # runs already on disk from an earlier invocation
            else:
                self.bar.update(done - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def campaign_progress(progress: bool | Callable[[int, int, float], None], total: int) -> CampaignProgress:
    return CampaignProgress(progress, total)

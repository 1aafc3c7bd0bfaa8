"""The workflow's progress on one bar: one unit per stage of :class:`~ur5fault.discrepancy.model.DiscrepancyModel`."""

from __future__ import annotations


class StageBar:
    """Progress of the workflow on one tqdm bar (``ur5fault.util.progress``): one unit per stage."""

    NAMES = ("screening the library", "discovering terms", "refining the findings", "judging")

    def __init__(self, enabled: bool) -> None:
        from ..util import progress

        self.bar = progress.bar(len(self.NAMES), "discrepancy", "stage", enabled=enabled,
                                bar_format=progress.PERCENT_FORMAT)
        self.k = 0

    def start(self, name: str):
        self.k = self.NAMES.index(name)
        self.bar.set_description(f"discrepancy: {name}")
        self.bar.n = self.k
        self.bar.refresh()

        def frac(f: float) -> None:
            self.bar.n = round(self.k + min(max(f, 0.0), 1.0), 3)
            self.bar.refresh()

        return frac

    def close(self) -> None:
        self.bar.n = len(self.NAMES)
        self.bar.close()

"""The discrepancy workflow: where do model and measurement disagree, which effect of the library
explains it, which term outside the library does, add them to the model, and show the gap shrink on
data not used for fitting.

Modules: ``replay`` (the log through the model), ``library`` (screening the effect registry),
``discovery`` (the dictionary of terms), ``candidates``, ``statistics`` (the tests a finding must pass),
``search`` (selection and refinement), ``model`` (the estimator), ``report`` (sentences and files),
``cli`` (``ur5fault discrepancy``).  See docs/discrepancy.md.
"""

from .model import DiscrepancyModel, Finding
from .replay import WORKFLOW_SEED, Replay
from .report import sentence, summary, write_report

__all__ = ["DiscrepancyModel", "Finding", "Replay", "WORKFLOW_SEED", "sentence", "summary", "write_report"]

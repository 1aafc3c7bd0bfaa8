"""The discrepancy workflow: where do model and measurement disagree, which effect of the library
explains it, which term outside the library does, add them to the model, and show the gap shrink on
data not used for fitting.

The log's replay through the model and its residual analysis are :mod:`ur5fault.twin`'s.
Modules: ``library`` (screening the effect registry),
``discovery`` (the dictionary of terms), ``candidates``, ``statistics`` (the tests a finding must pass),
``search`` (selection), ``refinement`` (re-simulation), ``judging`` (findings after re-simulation),
``model`` (the estimator), ``report`` (sentences and files), ``cli`` (``ur5fault discrepancy``).
See docs/discrepancy.md.
"""

from .judging import Finding
from .model import WORKFLOW_SEED, DiscrepancyModel
from .report import sentence, summary, write_report

__all__ = ["DiscrepancyModel", "Finding", "WORKFLOW_SEED", "sentence", "summary", "write_report"]

"""Health work on top of the simulator: what a run's signals say about the robot's condition.

- :mod:`.features`: the seed paper's health features of one run.
- :mod:`.diagnostics`: the diagnostics benchmark (``ur5fault benchmark``): detectors, localisers and fault-kind
  classifiers scored on a labelled campaign.
"""

"""Prognostics: wear that grows with use (wear.py), life campaigns run to failure (spec.py,
fleet.py, life_store.py) and the remaining-useful-life benchmark ``ur5fault prognose`` (rul.py,
metrics.py, benchmark.py, report.py)."""

"""Prognostics: wear that grows with use (wear.py), life campaigns run to failure (spec.py,
fleet.py, life_inspection.py, life_resume.py, life_store.py) and the remaining-useful-life benchmark
``ur5fault prognose`` (life_table.py, rul.py, prediction.py, metrics.py, benchmark.py, report.py; its command line's
choices in twin_choices.py)."""

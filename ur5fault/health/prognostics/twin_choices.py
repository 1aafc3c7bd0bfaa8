"""The names ``ur5fault prognose`` takes for its twin estimator's set-up, in a module that imports nothing: the
command's parser (``prognose --help`` too) is built before any estimator module is loaded (1.4 s of numpy, pandas
and MuJoCo), and the choices it offers are the ones the estimators accept, written once here."""

#: where the twin's friction rise per degree of clearance and per 10^6 cycles comes from: "learned" from the
#: inspections (twin_friction.py), or the fleet's wear "law" as the manifest states it (``--twin-friction``)
TWIN_FRICTION = ("learned", "law")
#: ways of calibrating the twin (``TwinRUL.calibration``, ``--twin-calibration``): "direction" the task's calibration
#: corrected by its calibration units of nearby directions of growth, "task" the task's, "pooled" all tasks' at once
CALIBRATIONS = ("direction", "task", "pooled")

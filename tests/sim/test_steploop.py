"""The compiled step loop (ur5fault/sim/steploop.py) against the lockstep loop it replaces and the numpy reference.

* Against the lockstep loop with the compiled drive (same per-joint functions, same MuJoCo calls): bit for bit,
  every signal and status, for a batch carrying every effect of the registry, payload grip and release events
  inside the run, a run that trips, and on threads.
* Against the numpy reference modules: within the self-perturbation baseline of ``test_kernel.py`` (libm's and
  numpy's tanh differ in the last bit), every joint and signal, every effect of the registry.
"""

from __future__ import annotations

import dataclasses
import logging

import mujoco
import numpy as np
import pytest

from ur5fault import RunSpec, Simulator, make_effect, pick_and_place
from ur5fault.errors import ParameterError
from ur5fault.sim.effects import REGISTRY
from ur5fault.sim.params import load_params

DUR = 0.5


def every_effect(fraction: float) -> list[RunSpec]:
    """One run per registered effect, each parameter ``fraction`` of the way from "absent" to its upper bound
    (from mid-range where a value is required), on joints 1..6 in turn; plus a healthy run."""
    runs = [RunSpec("healthy", 1)]
    for i, (name, eff) in enumerate(sorted(REGISTRY.items())):
        values = {q.name: (q.lo + q.hi) / 2 if q.absent is None else q.absent + (q.hi - q.absent) * fraction
                  for q in eff.params}
        runs.append(RunSpec(name, i % 4, (make_effect(name, 1 + i % 6 if eff.per_joint else None, **values),)))
    return runs


def grip_inside(duration_s: float):
    """The pick-and-place with its gripper closing and opening inside the first ``duration_s``."""
    return dataclasses.replace(pick_and_place(), payload_events=((0.4 * duration_s, True), (0.7 * duration_s, False)))


def _same(a, b):
    assert a.status == b.status and a.reason == b.reason
    for k in a.signals:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    np.testing.assert_array_equal(a.tcp_m, b.tcp_m)


@pytest.fixture(scope="module")
def registry_batch():
    runs = every_effect(0.1) + [RunSpec("trips", 0, (make_effect("torque_constant", 2, scale=0.2),
                                                      make_effect("payload", mass_kg=5.0)))]
    return runs, Simulator().run(grip_inside(DUR), runs, duration_s=DUR)


def test_compiled_equals_lockstep_bit_for_bit_for_every_effect(registry_batch):
    runs, fast = registry_batch
    assert Simulator().stepper == "compiled"
    _same(fast, Simulator(stepper="loop").run(grip_inside(DUR), runs, duration_s=DUR))


def test_compiled_on_threads_equals_one_thread_bit_for_bit(registry_batch):
    import numba

    runs, fast = registry_batch
    before = numba.get_num_threads()
    numba.set_num_threads(1)  # a caller's own setting, which the threaded run used to leave at 2
    try:
        _same(fast, Simulator(nthread=2).run(grip_inside(DUR), runs, duration_s=DUR))
        assert numba.get_num_threads() == 1  # numba's thread count is the process's: set for the run only
    finally:
        numba.set_num_threads(before)


def test_a_trip_stops_its_run_only():
    runs = [RunSpec("ok", 0), RunSpec("weak", 0, (make_effect("torque_constant", "shoulder_lift_joint", scale=0.2),
                                                    make_effect("payload", mass_kg=5.0)))]
    fast = Simulator().run(pick_and_place(), runs, duration_s=4.0)
    assert fast.status == ("ok", "protective_stop") and "joint 2" in fast.reason[1]
    _same(fast, Simulator(stepper="batch").run(pick_and_place(), runs, duration_s=4.0))


@pytest.mark.parametrize("duration_s", [1.0, pytest.param(None, marks=pytest.mark.slow)], ids=["1s", "whole_run"])
def test_compiled_agrees_with_numpy_reference_for_every_effect(duration_s):
    p = load_params()
    nudged = load_params(overrides={"friction": {"coulomb_Nm": [c * (1 + 1e-12) for c in p.friction.coulomb_Nm]}})
    runs = every_effect(0.1)
    traj = grip_inside(duration_s or pick_and_place().duration_s)
    ref = Simulator(p, drive="numpy").run(traj, runs, duration_s=duration_s)
    fast = Simulator(p).run(traj, runs, duration_s=duration_s)
    base = Simulator(nudged).run(traj, runs, duration_s=duration_s)
    assert ref.status == fast.status == base.status
    assert fast.status.count("ok") >= len(runs) - 1, fast.status
    for s in fast.signals:
        per_joint = np.nanmax(np.abs(fast[s] - ref[s]), axis=(0, 1))
        baseline = np.nanmax(np.abs(base[s] - fast[s]))
        assert np.all(per_joint <= 10 * baseline), (s, per_joint, baseline)


def test_progress_is_reported_in_order_up_to_one():
    seen = []
    Simulator().run(pick_and_place(), [RunSpec("r", 0)], duration_s=0.5, progress=seen.append)
    assert seen[0] == 0.0 and seen[-1] == 1.0 and np.all(np.diff(seen) > 0) and len(seen) >= 40


def test_a_python_mujoco_callback_is_refused_by_name_and_runs_in_the_lockstep_loop(caplog):
    runs = [RunSpec("r", 2, (make_effect("backlash", 2, backlash_deg=0.1),))]

    def passive(m, d):
        d.qfrc_passive[1] -= 0.5 * np.tanh(d.qvel[1] / 0.01)

    fast, simple = Simulator(), Simulator(stepper="loop")
    mujoco.set_mjcb_passive(passive)
    try:
        with caplog.at_level(logging.WARNING, logger="ur5fault.sim.engine"):
            res = fast.run(pick_and_place(), runs, duration_s=0.2)
        loop = simple.run(pick_and_place(), runs, duration_s=0.2)
    finally:
        mujoco.set_mjcb_passive(None)
    assert "mjcb_passive" in caplog.text and "lockstep loop runs it" in caplog.text
    _same(res, loop)
    assert not np.array_equal(res["i_FB_A"], fast.run(pick_and_place(), runs, duration_s=0.2)["i_FB_A"])


def test_compiled_stepper_needs_the_compiled_drive():
    with pytest.raises(ParameterError, match="runs the compiled drive only"):
        Simulator(stepper="compiled", drive="numpy")
    with pytest.raises(ParameterError, match="at least 1"):
        Simulator(nthread=0)
    assert Simulator(drive="numpy").stepper == "batch"

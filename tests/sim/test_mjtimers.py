"""MuJoCo's stage timers off while ur5fault steps (sim/mjtimers.py): off inside a run on either stepper, back on
after, counted over nested and concurrent users, and the physics the same bit for bit with and without them."""

from __future__ import annotations

import threading

import mujoco
import numpy as np
import pytest

from ur5fault import RunSpec, Simulator, pick_and_place
from ur5fault.sim.mjlib import LIB
from ur5fault.sim.mjtimers import SWITCH, TimerSwitch, timers_off

pytestmark = pytest.mark.skipif(LIB is None, reason="no libmujoco.so beside the mujoco package")


@pytest.fixture
def timers_on():
    """The premise of the switch: these Python bindings install a C clock as mjcb_time (MuJoCo 4.0's do); with
    bindings that set none there is nothing to switch off."""
    if not SWITCH.is_on():
        pytest.skip("these MuJoCo bindings set no stage timer (mjcb_time is NULL)")


def test_the_bindings_time_every_step_unless_switched_off(timers_on):
    with timers_off():
        assert not SWITCH.is_on()
    assert SWITCH.is_on()


def test_nested_users_leave_the_timers_off_until_the_last_one_leaves(timers_on):
    with timers_off():
        with timers_off():
            assert not SWITCH.is_on()
        assert not SWITCH.is_on()  # the outer user is still stepping
    assert SWITCH.is_on()


def test_concurrent_users_restore_the_pointer_whatever_order_they_leave_in(timers_on):
    switch = TimerSwitch(LIB)
    before = switch.is_on()
    first_in, second_in, first_out = threading.Event(), threading.Event(), threading.Event()
    seen = {}

    def first():
        with switch.off():
            first_in.set()
            second_in.wait(5)
        first_out.set()

    def second():
        first_in.wait(5)
        with switch.off():
            second_in.set()
            first_out.wait(5)
            seen["off_after_first_left"] = not switch.is_on()

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert seen["off_after_first_left"]
    assert switch.is_on() == before


def test_an_exception_inside_still_restores_the_timers(timers_on):
    with pytest.raises(RuntimeError):
        with timers_off():
            raise RuntimeError("boom")
    assert SWITCH.is_on()


@pytest.mark.parametrize("stepper", ["compiled", "loop"])
def test_a_run_steps_without_timers_and_puts_them_back(stepper, timers_on):
    during = []
    Simulator(stepper=stepper).run(pick_and_place(), [RunSpec("r", 0)], duration_s=0.2,
                                   progress=lambda f: during.append(SWITCH.is_on()))
    assert during and not any(during)
    assert SWITCH.is_on()


def test_the_physics_does_not_read_the_clock():
    # the same steps of the packaged model, with MuJoCo's timers and without: every state equal bit for bit
    model = Simulator().model
    states = []
    for switched_off in (False, True):
        d = mujoco.MjData(model)
        d.qpos[:] = pick_and_place().q_set_rad[0]
        d.qfrc_applied[:] = [5.0, -20.0, 8.0, 1.0, -0.5, 0.2]
        if switched_off:
            with timers_off():
                for _ in range(2000):
                    mujoco.mj_step(model, d)
        else:
            for _ in range(2000):
                mujoco.mj_step(model, d)
        states.append(np.concatenate([d.qpos, d.qvel, d.qacc]))
    assert np.array_equal(states[0], states[1])

"""Every named finding with its rivals (``ur5fault/discrepancy/rivals.py``), on residuals made here: a rival
whose column is (nearly) the finding's own shape is listed with its own size; one whose column is another
shape is not, neither at the linearised pre-selection nor at the held-out judgement."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.discrepancy.candidates import LibraryCandidate
from ur5fault.discrepancy.rivals import MAX_RIVALS, differ_most, held_out_delta_bic, in_place, judge_rival, noise_hint
from ur5fault.discrepancy.search import columns_of
from ur5fault.discrepancy.statistics import MIN_DELTA_BIC

N = 4000
N_FIT = 2400


def _shapes():
    """On joint 0 (one signal x 6 joints): a gravity-like current of one sign that hardly varies (the shape a
    current gain or a torque constant makes), a constant (an offset's shape) and a speed-odd Coulomb-like shape."""
    t = np.arange(N) * 0.008
    gravity = 1.0 + 0.005 * np.sin(2 * np.pi * t / 9.0)
    speed = np.sin(2 * np.pi * t / 7.0) + 0.3 * np.sin(2 * np.pi * t / 2.3)
    return gravity, np.ones(N), np.tanh(speed / 0.05)


def _residuals(seed: int = 5):
    """The finding (a gain: 0.1 x the gravity shape on joint 0) named in a model whose residual is white noise of
    unit sigma: ``e_named`` with it, ``e_place`` without it."""
    rng = np.random.default_rng(seed)
    gravity, _, _ = _shapes()
    e_named = rng.normal(size=(N, 6))
    change = np.zeros((N, 6))
    change[:, 0] = 10.0 * gravity  # the finding's change, 10 sigma
    return e_named + change, e_named, change


def _joint0() -> np.ndarray:
    ch = np.zeros(6, dtype=bool)
    ch[0] = True
    return ch


def test_a_collinear_rival_is_listed_with_its_own_size():
    e_place, e_named, _ = _residuals()
    _, const, _ = _shapes()
    col = np.zeros((N, 6))
    col[:, 0] = 5.0 * const  # an offset's change at its linearised size: the gravity shape within 0.5 % (0.05 sigma)
    got = judge_rival(e_place, col, e_named, N_FIT, _joint0())
    assert got is not None
    a, ratio, dbic = got
    # its own size: the 10-sigma change of mean ~1.0 taken up by 5 x a constant, so ~2 x its linearised size
    assert a == pytest.approx(2.0, rel=0.02)
    assert ratio > 0.5 and dbic < MIN_DELTA_BIC


def test_a_rival_of_another_shape_is_not_listed():
    e_place, e_named, _ = _residuals()
    _, _, coulomb = _shapes()
    col = np.zeros((N, 6))
    col[:, 0] = 5.0 * coulomb  # speed-odd, orthogonal to a current of one sign
    assert judge_rival(e_place, col, e_named, N_FIT, _joint0()) is None


def test_a_nearly_collinear_rival_beyond_the_noise_is_not_listed():
    # the gravity shape with a ripple of 30 % added: on 1600 held-out samples of unit noise it leaves 10 x 0.3 /
    # sqrt(2) ~ 2 sigma RMS unexplained, far more than MIN_DELTA_BIC
    e_place, e_named, _ = _residuals()
    gravity, _, coulomb = _shapes()
    col = np.zeros((N, 6))
    col[:, 0] = 10.0 * gravity + 3.0 * np.sin(np.arange(N) * 0.05)
    assert judge_rival(e_place, col, e_named, N_FIT, _joint0()) is None


def test_the_held_out_delta_bic_is_zero_for_the_same_residual_and_grows_with_what_is_left():
    rng = np.random.default_rng(1)
    e = rng.normal(size=(1000, 2))
    assert held_out_delta_bic(e, e) == 0.0
    assert held_out_delta_bic(e, e + 0.5) > MIN_DELTA_BIC


def test_the_linearised_preselection_takes_collinear_library_effects_only():
    e_place, e_named, _ = _residuals()
    gravity, const, coulomb = _shapes()
    cands = [LibraryCandidate("torque_constant", 0, param="scale", x0=1.0, probe=0.9),
             LibraryCandidate("current_sensor_offset", 0, param="offset_A", x0=0.0, probe=0.1),
             LibraryCandidate("coulomb_friction", 0, param="scale", x0=1.0, probe=1.5),
             LibraryCandidate("current_sensor_offset", 1, param="offset_A", x0=0.0, probe=0.1)]
    X = np.zeros((4, N, 6))
    # per unit coefficient: a torque constant 1 lower (an unknown current of ~100 sigma on this joint) and 1 A
    X[0, :, 0] = -100.0 * gravity
    X[1, :, 0] = 100.0 * const
    X[2, :, 0] = 100.0 * coulomb
    X[3, :, 1] = 100.0 * const
    got = in_place(X, e_place, e_named, cands, columns_of(cands), taken=set(), joint=0)
    names = [cands[k].effect for k, _ in got]
    # the torque constant (the same shape) and the offset (within 0.5 %) take the finding's place; the Coulomb
    # shape and another joint's offset do not
    assert set(names) == {"torque_constant", "current_sensor_offset"} and len(got) <= MAX_RIVALS
    assert all(cands[k].joint == 0 for k, _ in got)
    th = dict((cands[k].effect, float(t[0])) for k, t in got)
    assert th["torque_constant"] == pytest.approx(-0.1, rel=0.02)  # a torque constant x0.9: a gain of 1.1
    assert th["current_sensor_offset"] == pytest.approx(0.1, rel=0.03)
    # a kept finding is not its own rival
    taken = {cands[0].label}
    assert [cands[k].effect for k, _ in in_place(X, e_place, e_named, cands, columns_of(cands), taken, 0)] == [
        "current_sensor_offset"]


def test_what_tells_two_shapes_apart_is_where_they_differ_most():
    from ur5fault.logs import MeasuredLog

    n = 1000
    t = np.arange(n + 1) * 0.008
    q = np.zeros((n + 1, 6))
    q[:, 0] = np.where(t < 4.0, 0.0, 0.5 * (t - 4.0))  # at rest, then at speed
    log = MeasuredLog("made", t, q, q, np.zeros((n + 1, 6)))
    a = np.ones(n)  # an offset's change
    b = np.where(t[1:] < 4.0, 1.0, 0.2)  # a shape equal to it at rest, different at speed
    assert "at speed" in differ_most(log, n, np.zeros((n, 6)), a, b, 0)
    assert differ_most(log, n, np.zeros((n, 6)), a, b, None) == ""


def _readings(gain_truth: float, named_gain: float = 1.2, n: int = 6000, seed: int = 3):
    """Joint 1 at rest throughout: the measured reading (a current-sensor gain ``gain_truth`` on a unit-noise
    sensor; 1: none) and the replay with a named gain ``named_gain`` (its sensor that much louder)."""
    rng = np.random.default_rng(seed)
    base = 2.0 * np.ones((n, 6))  # a held load: the reading's second difference is its noise
    sigma = 0.01
    meas = gain_truth * (base + sigma * rng.standard_normal((n, 6)))
    named = named_gain * (base + sigma * rng.standard_normal((n, 6)))
    return np.ones((n, 6), bool), meas, named


GAIN, TORQUE = "current_sensor_gain", "torque_constant"


def test_the_sensors_noise_tells_a_current_gain_from_a_torque_constant_loss():
    rest, meas, named = _readings(1.2)
    hint = noise_hint(rest, meas, named, 1, (GAIN, 1.2), (TORQUE, 1 / 1.2))
    # the rival's replay: the model's own sensor, 1 / 1.2 as loud as the named gain's
    assert "x1.0" in hint and "x1.2" in hint and "the current sensor gain fits" in hint, hint
    rest, meas, named = _readings(1.0)  # the truth a torque constant: the sensor as loud as the model's
    hint = noise_hint(rest, meas, named, 1, (GAIN, 1.2), (TORQUE, 1 / 1.2))
    assert "the torque constant fits" in hint, hint
    # the torque constant named, the gain its rival: the same answer
    rest, meas, named = _readings(1.2, named_gain=1.0)
    assert "the current sensor gain fits" in noise_hint(rest, meas, named, 1, (TORQUE, 1 / 1.2), (GAIN, 1.2))
    # other pairs get no such hint; a joint that never rests gets none
    assert noise_hint(rest, meas, named, 1, (GAIN, 1.2), ("current_sensor_offset", 0.1)) == ""
    assert noise_hint(np.zeros_like(rest), meas, named, 1, (GAIN, 1.2), (TORQUE, 1 / 1.2)) == ""


def test_a_gain_within_the_noise_ratios_error_is_too_close_to_tell():
    # a named gain of 1.01: the two models' sensors one sampling error apart (about 1.8 % at 6,000 samples)
    rest, meas, named = _readings(1.0, named_gain=1.01)
    hint = noise_hint(rest, meas, named, 1, (GAIN, 1.01), (TORQUE, 1 / 1.01))
    assert hint.endswith("too close to tell on this log"), hint

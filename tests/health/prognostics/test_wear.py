"""Wear laws against their closed forms, monotonicity and determinism under a seed."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.errors import ParameterError
from ur5fault.health.prognostics.wear import (
    WearLaw,
    advance_backlash_deg,
    friction_scale,
    gear_work_J,
    stiffness_scale,
    unit_rates_deg_per_MJ,
    wear_effects,
)

LAW = WearLaw(backlash_rate_deg_per_MJ=1e-3, unit_sigma=0.3, work_scale_MJ=0.05)


def test_gamma_increment_mean_and_variance_match_the_closed_form():
    # E = c u, Var = c^2 u0 u for work u = cycles x W [MJ]; c set by hand, not by the code
    rates = np.full(6, 2e-3)
    work_J = np.array([10.0, 20.0, 30.0, 5.0, 1.0, 40.0])
    cycles = 50_000
    u_MJ = work_J * cycles * 1e-6
    incs = np.array([advance_backlash_deg(LAW, rates, np.zeros(6), work_J, cycles, 7, unit, 3)
                     for unit in range(4000)])
    mean_expected = 2e-3 * u_MJ
    var_expected = (2e-3) ** 2 * 0.05 * u_MJ
    se = np.sqrt(var_expected / len(incs))
    assert np.all(np.abs(incs.mean(0) - mean_expected) < 4 * se)
    # sample variance within ~4 standard errors of a gamma variance (relative s.e. ~ sqrt(2/n) and kurtosis)
    assert np.allclose(incs.var(0), var_expected, rtol=0.15)


def test_clearance_never_shrinks_and_zero_work_means_zero_wear():
    rates = unit_rates_deg_per_MJ(LAW, 0, 0)
    a = np.zeros(6)
    work = np.array([10.0, 0.0, 30.0, 5.0, 0.0, 1.0])
    for k in range(30):
        b = advance_backlash_deg(LAW, rates, a, work, 10_000, 0, 0, k)
        assert np.all(b >= a)
        assert b[1] == 0.0 and b[4] == 0.0
        a = b
    assert np.all(a[[0, 2, 3, 5]] > 0)


def test_deterministic_under_a_seed_and_keyed_by_unit_and_inspection():
    rates = unit_rates_deg_per_MJ(LAW, 5, 2)
    args = (np.zeros(6), np.full(6, 10.0), 80_000)
    a = advance_backlash_deg(LAW, rates, *args, 5, 2, 4)
    assert np.array_equal(a, advance_backlash_deg(LAW, rates, *args, 5, 2, 4))
    assert not np.array_equal(a, advance_backlash_deg(LAW, rates, *args, 5, 2, 5))
    assert not np.array_equal(a, advance_backlash_deg(LAW, rates, *args, 6, 2, 4))
    assert np.array_equal(rates, unit_rates_deg_per_MJ(LAW, 5, 2))
    assert not np.array_equal(rates, unit_rates_deg_per_MJ(LAW, 5, 3))


def test_unit_rates_are_lognormal_about_the_mean_coefficient():
    r = np.concatenate([unit_rates_deg_per_MJ(LAW, 1, u) for u in range(3000)])
    z = np.log(r / 1e-3)
    assert abs(z.mean()) < 4 * 0.3 / np.sqrt(z.size) and abs(z.std() - 0.3) < 0.01


def test_friction_and_stiffness_laws_by_hand():
    law = WearLaw(friction_per_deg=5.0, friction_per_Mcycle=0.05, stiffness_loss_per_deg=2.0, stiffness_floor=0.5)
    a = np.array([0.0, 0.02, 0.1, 0.3, 0.0, 0.0])
    # 1 + 5 x alpha + 0.05 x 2 (two million cycles)
    assert np.allclose(friction_scale(law, a, 2_000_000), [1.1, 1.2, 1.6, 2.6, 1.1, 1.1])
    # 1 - 2 alpha, floored at 0.5
    assert np.allclose(stiffness_scale(law, a), [1.0, 0.96, 0.8, 0.5, 1.0, 1.0])


def test_wear_effects_name_the_registry_effects():
    eff = wear_effects(WearLaw(friction_per_Mcycle=0.0), np.array([0.0, 0.02, 0, 0, 0, 0]), 0)
    assert [(e.name, e.joint) for e in eff] == [("backlash", 1), ("gear_stiffness", 1), ("coulomb_friction", 1)]
    assert eff[0].value("backlash_deg") == 0.02


def test_gear_work_of_a_constant_torque_at_constant_speed():
    t = np.linspace(0.0, 2.0, 2001)
    q = np.outer(t, [0.5, -1.0, 0, 0, 0, 2.0])          # rad: constant speeds 0.5, -1, 0, ..., 2 rad/s
    torque = np.tile([10.0, 4.0, 7.0, 0, 0, -1.0], (t.size, 1))
    # |T w| t by hand: 10 x 0.5 x 2 = 10 J, 4 x 1 x 2 = 8 J, 0, 0, 0, 1 x 2 x 2 = 4 J
    assert np.allclose(gear_work_J(t, q, torque), [10.0, 8.0, 0, 0, 0, 4.0])


@pytest.mark.parametrize("field, value", [("unit_sigma", -0.1), ("work_scale_MJ", 0.0),
                                          ("backlash_rate_deg_per_MJ", float("nan")), ("stiffness_floor", 2.0),
                                          ("friction_per_deg", True), ("unit_sigma", np.False_)])
def test_bad_constants_are_refused_by_name(field, value):
    with pytest.raises(ParameterError, match=f"life.wear.{field}"):
        WearLaw(**{field: value})


def test_numpy_constants_are_the_python_numbers_they_hold():
    """`WearLaw(friction_per_deg=np.int64(5))` was refused as no number, and an `np.float64` constant was kept as
    itself, whose repr (part of the twin cache's key) is not the float's."""
    law = WearLaw(friction_per_deg=np.int64(5), unit_sigma=np.float64(0.3), stiffness_floor=np.float32(0.5))
    assert law == WearLaw(friction_per_deg=5, unit_sigma=0.3, stiffness_floor=0.5)
    assert repr(law) == repr(WearLaw(friction_per_deg=5, unit_sigma=0.3, stiffness_floor=0.5))


def test_wear_kinds_are_the_effects_wear_puts_on_a_unit():
    from ur5fault.health.prognostics.wear import WEAR_KINDS, WearLaw, wear_effects

    names = {e.name for e in wear_effects(WearLaw(), np.full(6, 0.05), 1e6)}
    assert names == WEAR_KINDS

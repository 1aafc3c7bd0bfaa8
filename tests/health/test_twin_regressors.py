"""The twin fits' regressors from noise-free twins (ur5fault/health/twin_regressors.py): the payload grid and its
interpolation against hand-computed values, and (slow) against simulated twins: the noisy twin's own current as
the regressor biases wrist 2's gain estimate on a healthy run without payload by many standard errors, the
noise-free twin's does not; the grid's interpolation reproduces the exact noise-free twin; the payload
centre-of-mass columns from CoM-shifted noise-free twins predict a noise-free run whose true CoM is shifted
(an independent simulation) and, unlike the CoM's gravity torque in closed form, leave wrist 2's gain estimate of a
healthy run with its CoM shifted along the tool near zero."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ur5fault import RunSpec, Simulator, make_effect
from ur5fault.errors import ParameterError
from ur5fault.health.twin_features import current_fit
from ur5fault.health.twin_regressors import (
    COM_STEP_M,
    REGRESSOR_EFFECTS,
    RegressorGrid,
    com_difference,
    com_effects,
    payload_grid,
)
from ur5fault.sim.params import load_params


def test_payload_grid_brackets_every_mass_with_whole_kilograms():
    assert payload_grid([0.3, 2.7]) == (0.0, 1.0, 2.0, 3.0)
    assert payload_grid([1.0]) == (1.0,)  # a mass on the grid needs no neighbour
    assert payload_grid([0.0, 0.0]) == (0.0,)
    assert payload_grid([1.25], step_kg=0.5) == (1.0, 1.5)
    with pytest.raises(ParameterError, match="finite mass"):
        payload_grid([-0.1])


def _grid(params, temperature_C=28.0):
    n = 4
    i_a = np.stack([np.full((n, 6), 1.0), np.full((n, 6), 3.0)])  # currents at 1 kg and 2 kg
    torque = np.stack([np.full((n, 6), 10.0), np.full((n, 6), 30.0)])
    qd = np.zeros((n, 6))
    qd[:, 4] = 0.5  # wrist 2 moves at 0.5 rad/s
    return RegressorGrid(np.array([1.0, 2.0]), temperature_C, i_a, torque, qd, params)


def test_grid_interpolates_linearly_in_mass():
    params = load_params()
    i_a, torque = _grid(params).signals(1.25, 28.0)
    np.testing.assert_allclose(i_a, 1.5)  # a quarter of the way from 1 A to 3 A
    np.testing.assert_allclose(torque, 15.0)
    i_a, torque = _grid(params).signals(2.0, 28.0)
    np.testing.assert_allclose(i_a, 3.0)
    with pytest.raises(ValueError, match="outside the regressor grid"):
        _grid(params).signals(2.5, 28.0)


def test_grid_moves_the_viscous_friction_to_the_runs_temperature():
    params = load_params()
    fr = params.friction
    # by hand: f_v(T) = f_v,ref exp(-beta (T - T_ref)) on wrist 2, times its speed 0.5 rad/s; over K_t N for the current
    fv = [fr.viscous_Nms_per_rad[4] * math.exp(-fr.viscous_temp_coeff_per_K[4] * (t - fr.reference_temp_C))
          for t in (40.0, 28.0)]
    d_torque = (fv[0] - fv[1]) * 0.5
    i_a, torque = _grid(params).signals(1.0, 40.0)
    per_amp = params.motor.torque_constant_Nm_per_A[4] * params.gear.ratio[4]
    np.testing.assert_allclose(i_a[:, 4], 1.0 + d_torque / per_amp)
    np.testing.assert_allclose(torque[:, 4], 10.0 + d_torque)  # the default model has all friction on the link
    np.testing.assert_allclose(i_a[:, :4], 1.0)  # joints at rest: nothing changes
    assert d_torque < 0  # warmer oil, less viscous friction


def test_grid_refuses_signals_of_another_shape():
    params = load_params()
    g = _grid(params)
    with pytest.raises(ValueError, match="do not match"):
        RegressorGrid(g.payloads_kg, 28.0, g.i_A[:1], g.T_gear_Nm, g.qd, params)
    with pytest.raises(ValueError, match="increasing"):
        RegressorGrid(np.array([2.0, 1.0]), 28.0, g.i_A, g.T_gear_Nm, g.qd, params)


def test_com_columns_are_differences_per_metre_interpolated_in_mass():
    params = load_params()
    g = _grid(params)
    ref = np.ones((4, 6))
    shifted = np.stack([ref + 0.01 * (k + 1) for k in range(3)])  # x, y, z twins: 0.01, 0.02, 0.03 A more
    cols = com_difference(shifted, ref)
    assert cols.shape == (4, 6, 3)
    np.testing.assert_allclose(cols[0, 0], np.array([0.01, 0.02, 0.03]) / COM_STEP_M)
    com = np.stack([cols, 3.0 * cols])  # at 1 kg and 2 kg
    grid = RegressorGrid(g.payloads_kg, 28.0, g.i_A, g.T_gear_Nm, g.qd, params, com)
    np.testing.assert_allclose(grid.com_columns(1.25), 1.5 * cols)  # 0.75 * 1 + 0.25 * 3
    np.testing.assert_allclose(grid.com_columns(2.0), 3.0 * cols)
    with pytest.raises(ValueError, match="outside the regressor grid"):
        grid.com_columns(2.5)
    with pytest.raises(ValueError, match="CoM columns"):
        RegressorGrid(g.payloads_kg, 28.0, g.i_A, g.T_gear_Nm, g.qd, params, com[:, :, :, :2])
    with pytest.raises(ValueError, match="no centre-of-mass twins"):
        g.com_columns(1.0)


def test_campaign_batches_simulate_com_twins_above_zero_kg_only_with_the_option():
    from types import SimpleNamespace

    from ur5fault.campaign.digital_twin import regressor_id, regressor_runs

    batch = [SimpleNamespace(cond={"payload_kg": 0.4}), SimpleNamespace(cond={"payload_kg": 1.0})]
    grid, runs = regressor_runs(SimpleNamespace(base_effects=(), twin_com_twins=False), batch, 28.0)
    assert grid == (0.0, 1.0) and set(runs) == {regressor_id(0.0), regressor_id(1.0)}  # the option off
    grid, runs = regressor_runs(SimpleNamespace(base_effects=(), twin_com_twins=True), batch, 28.0)
    assert set(runs) == {regressor_id(0.0), regressor_id(1.0), *(regressor_id(1.0, ax) for ax in "xyz")}
    shift = runs[regressor_id(1.0, "z")][1][-1]
    assert shift.name == "payload_com" and dict(shift.values) == {"dx_m": 0.0, "dy_m": 0.0, "dz_m": COM_STEP_M}


#: wrist 2 (0-based)
WRIST_2 = 4


@pytest.fixture(scope="module")
def sims():
    from ur5fault.config import parse_trajectory

    traj = parse_trajectory({"name": "random_pick_and_place", "seed": 3}, "trajectory")

    def load(kg, temp=30.0):
        return make_effect("payload", mass_kg=kg), make_effect("temperature", temperature_C=temp)

    runs = [RunSpec("healthy 0", 11, load(0.0)), RunSpec("twin 0", 12345, load(0.0)),
            RunSpec("quiet 0", 12345, load(0.0) + REGRESSOR_EFFECTS),
            RunSpec("quiet 2.5", 1, load(2.5, 40.0) + REGRESSOR_EFFECTS),
            RunSpec("grid 2", 1, load(2.0, 28.0) + REGRESSOR_EFFECTS),
            RunSpec("grid 3", 1, load(3.0, 28.0) + REGRESSOR_EFFECTS)]
    sim = Simulator()
    res = sim.run(traj, runs, duration_s=6.3)
    assert all(s == "ok" for s in res.status)
    return sim, traj, res, {r.run_id: i for i, r in enumerate(runs)}


@pytest.mark.slow
def test_noise_free_regressors_remove_wrist_2s_healthy_gain_bias(sims):
    sim, traj, res, ids = sims
    resid = res["i_FB_A"][ids["healthy 0"]] - res["i_FB_A"][ids["twin 0"]]
    held = traj.gripped(res.t_s)
    est = {}
    for name, src in (("noisy", "twin 0"), ("quiet", "quiet 0")):
        coef, se, _ = current_fit(res.t_s, res.q_set_rad, resid, {"i_q_A": res["i_q_A"][ids[src]],
                                                                  "T_gear_Nm": res["T_gear_Nm"][ids[src]]},
                                  sim.params, 0.0, held)
        est[name] = coef[WRIST_2, 1] / se[WRIST_2, 1]
    # a healthy run's gain error is 0: its estimate should be within a few standard errors of 0. With the noisy
    # twin's current as the regressor it is not (errors in variables: docs/diagnostics.md)
    assert est["noisy"] > 10
    assert abs(est["quiet"]) < 3


@pytest.mark.slow
def test_grid_interpolation_reproduces_the_exact_noise_free_twin(sims):
    sim, _, res, ids = sims
    qd = np.gradient(res.q_set_rad, res.t_s[1] - res.t_s[0], axis=0)
    k = [ids["grid 2"], ids["grid 3"]]
    grid = RegressorGrid(np.array([2.0, 3.0]), 28.0, res["i_q_A"][k], res["T_gear_Nm"][k], qd, sim.params)
    i_a, torque = grid.signals(2.5, 40.0)
    exact_i, exact_t = res["i_q_A"][ids["quiet 2.5"]], res["T_gear_Nm"][ids["quiet 2.5"]]
    for j in range(6):
        # the shape is what the fit needs (a shape error attenuates an estimate by the correlation's share): wrist 2,
        # whose current is its load shared with stuck friction, measured 0.994 at 2.5 kg; the others above 0.999
        assert np.corrcoef(i_a[:, j], exact_i[:, j])[0, 1] > 0.98, j
        assert np.corrcoef(torque[:, j], exact_t[:, j])[0, 1] > 0.98, j


#: the true payload centre-of-mass shift of the CoM tests [m]: along the tool within the campaign's 0-8 cm, sideways
#: within its +-3 cm
TRUE_SHIFT_M = (0.02, -0.01, 0.05)


@pytest.fixture(scope="module")
def com_sims():
    from ur5fault.config import parse_trajectory

    traj = parse_trajectory({"name": "random_pick_and_place", "seed": 3}, "trajectory")
    load = (make_effect("payload", mass_kg=2.0), make_effect("temperature", temperature_C=28.0))
    dx, dy, dz = TRUE_SHIFT_M
    true = (make_effect("payload_com", dx_m=dx, dy_m=dy, dz_m=dz),)
    along = (make_effect("payload_com", dz_m=dz),)
    runs = [RunSpec("quiet", 1, load + REGRESSOR_EFFECTS), RunSpec("quiet shifted", 1, load + REGRESSOR_EFFECTS + true),
            RunSpec("healthy dz", 11, load + along), RunSpec("twin", 12345, load)]
    runs += [RunSpec(f"com {k}", 1, load + REGRESSOR_EFFECTS + e) for k, e in enumerate(com_effects())]
    sim = Simulator()
    res = sim.run(traj, runs, duration_s=4.0)  # the diagnostics campaign's run length
    assert all(s == "ok" for s in res.status)
    ids = {r.run_id: i for i, r in enumerate(runs)}
    cols = com_difference(res["i_q_A"][[ids[f"com {k}"] for k in range(3)]], res["i_q_A"][ids["quiet"]])
    return sim, traj, res, ids, cols


@pytest.mark.slow
def test_com_columns_predict_a_run_with_its_true_centre_of_mass_shifted(com_sims):
    _, _, res, ids, cols = com_sims
    effect = res["i_q_A"][ids["quiet shifted"]] - res["i_q_A"][ids["quiet"]]  # the shift's own simulation
    miss = effect - cols @ np.asarray(TRUE_SHIFT_M)
    rms = lambda a: np.sqrt(np.mean(a**2, axis=0))  # noqa: E731
    # J2-J5 carry the CoM's torque (the base and wrist 3 axes stay near vertical: 1-2 mA of effect); a linear model
    # of a 3 cm step over a 5 cm shift leaves the curvature (wrist 2's gain reading: 0.028 per cm at 1 cm, 0.033 at
    # 5 cm) and the axes' cross terms: a quarter of the effect is the bar (measured: 0.06 / 0.06 / 0.04 / 0.11)
    for j in (1, 2, 3, 4):
        assert rms(miss)[j] < 0.25 * rms(effect)[j], (j, rms(miss)[j], rms(effect)[j])


@pytest.mark.slow
def test_com_twins_leave_wrist_2s_gain_estimate_of_a_shift_along_the_tool_near_zero(com_sims):
    sim, traj, res, ids, cols = com_sims
    resid = res["i_FB_A"][ids["healthy dz"]] - res["i_FB_A"][ids["twin"]]
    twin = {"i_q_A": res["i_q_A"][ids["quiet"]], "T_gear_Nm": res["T_gear_Nm"][ids["quiet"]]}
    held = traj.gripped(res.t_s)
    gravity = current_fit(res.t_s, res.q_set_rad, resid, twin, sim.params, 2.0, held)
    twins = current_fit(res.t_s, res.q_set_rad, resid, {**twin, "com_A_per_m": cols}, sim.params, 2.0, held)
    # the run is healthy (gain error 0). 5 cm along the tool scales wrist 2's inertial current by about dz / L
    # (L ~ 0.25 m, the payload below wrist 2's axis) - a gain's signature - and has no gravity torque: the closed
    # form cannot fit it, the CoM twins can, and they find the shift
    assert gravity[0][WRIST_2, 1] > 0.1
    assert abs(twins[0][WRIST_2, 1]) < 0.05
    assert twins[2][2, 0] == pytest.approx(TRUE_SHIFT_M[2], abs=0.015)

"""The effect ``sensor_noise``: it scales the four white-noise sigmas of a run and nothing else, a scale of 0
gives readings equal to the quantised noise-free signal in the compiled kernel and the numpy reference alike,
and a noise-free run (what a digital twin is) does not depend on its noise seed."""

import numpy as np
import pytest

from ur5fault import RunSpec, Simulator, make_effect, pick_and_place
from ur5fault.sim.drive.state import XI, NumbaDrive, NumpyDrive, initial_state, pack_params
from ur5fault.sim.effect_appliers import NOISE_FIELDS
from ur5fault.sim.effects import NOISE_FREE
from ur5fault.sim.params import load_params
from ur5fault.sim.run_arrays import build_run_arrays

#: the packaged sensor parameters each run-array noise field comes from
SOURCE = {"resolver_noise_rad": "resolver_noise_rad", "encoder_noise_rad": "encoder_noise_rad",
          "encoder_speed_noise_rad_s": "encoder_speed_noise_rad_s", "current_noise_A": "current_noise_A"}


def test_scale_multiplies_the_noise_sigmas_of_its_run_on_every_joint_and_nothing_else():
    p = load_params()
    base = build_run_arrays(p, [(), ()], 1.0)
    arr = build_run_arrays(p, [(), (make_effect("sensor_noise", scale=0.25),)], 1.0)
    assert set(NOISE_FIELDS) == set(SOURCE)
    for field, name in SOURCE.items():  # against the parameter file's values, times the scale by hand
        np.testing.assert_array_equal(getattr(arr, field)[1], 0.25 * np.asarray(getattr(p.sensors, name)))
        np.testing.assert_array_equal(getattr(arr, field)[0], np.asarray(getattr(p.sensors, name)))
    others = [f for f in vars(arr) if f not in SOURCE]
    assert "resolver_lsb_rad" in others and "current_lsb_A" in others and "current_gain" in others
    for f in others:  # quantisation steps, offsets, gains: untouched
        np.testing.assert_array_equal(getattr(arr, f), getattr(base, f), err_msg=f)
    zero = build_run_arrays(p, [(NOISE_FREE,)], 1.0)
    assert all(not np.any(getattr(zero, f)) for f in SOURCE)


def _quantised(x, lsb):
    """Rounded to the nearest multiple of ``lsb`` (written here, not the model's ``sensors.quantise``)."""
    return np.where(lsb > 0, np.round(x / np.where(lsb > 0, lsb, 1.0)) * lsb, x)


@pytest.mark.parametrize("drive", [NumpyDrive, NumbaDrive], ids=["numpy", "numba"])
def test_noise_free_reading_is_the_quantised_signal(drive):
    """Run 1 carries ``NOISE_FREE`` (with a resolver offset and a current gain and offset, which stay), run 0 the
    model's noise; unit noise of +-50 is drawn for both, so that noise left in run 1 would show well above the
    quantisation step."""
    p = load_params()
    sim = Simulator(p)
    kept = (make_effect("resolver_offset", 2, offset_deg=0.3), make_effect("current_sensor_gain", 3, gain=1.1),
            make_effect("current_sensor_offset", 3, offset_A=0.05))
    P = pack_params(p, sim.gains, build_run_arrays(p, [kept, (*kept, NOISE_FREE)], 2.0))
    rng = np.random.default_rng(5)
    q = rng.uniform(-2, 2, (2, 6))
    X = initial_state(P, q, rng.uniform(-30, 30, (2, 6)))
    for row in ("y_res", "y_enc", "dy_enc", "y_iq", "y_id"):  # analog values off the quantisation grid
        X[XI[row]] += rng.uniform(-1, 1, (2, 6)) * 0.37
    a = build_run_arrays(p, [kept], 2.0)  # the run's steps, offsets and gain, from the run arrays

    def noise_free(r):
        g, off = a.current_gain[0], a.current_offset_A[0]
        return {"q_fb": _quantised(X[XI["y_res"]][r], a.resolver_lsb_rad[0]) + a.resolver_offset_rad[0],
                "th_fb": _quantised(X[XI["y_enc"]][r], a.encoder_lsb_rad[0]),
                "w_fb": _quantised(X[XI["dy_enc"]][r], a.encoder_speed_lsb_rad_s[0]),
                "iq_fb": g * _quantised(X[XI["y_iq"]][r], a.current_lsb_A[0]) + off,
                "id_fb": g * _quantised(X[XI["y_id"]][r], a.current_lsb_A[0])}

    d = drive(P, X.copy(), p.physics_dt_s, p.controller.servo_period_s, 10.0)
    d.servo(q + 1e-3, np.zeros_like(q), 50.0 * rng.choice([-1.0, 1.0], (2, 5, 6)))
    want, noisy = noise_free(1), noise_free(0)
    for k in want:
        np.testing.assert_array_equal(d.X[XI[k]][1], want[k], err_msg=k)
        assert np.all(d.X[XI[k]][0] != noisy[k]), f"{k}: the noisy run reads its signal without noise"


def test_noise_free_run_ignores_its_seed_and_equals_zero_noise_parameters():
    """Two seeds with ``NOISE_FREE`` and a run of a robot whose parameter file sets every noise sigma to 0 (the
    independent route) give the same signals bit for bit, and a run with noise does not."""
    p = load_params()
    quiet = load_params(overrides={"sensors": {k: [0.0] * 6 for k in SOURCE.values()}})
    runs = [RunSpec("a", 1, (NOISE_FREE,)), RunSpec("b", 2, (NOISE_FREE,)), RunSpec("n", 1)]
    res = Simulator(p).run(pick_and_place(), runs, duration_s=0.3)
    ref = Simulator(quiet).run(pick_and_place(), [RunSpec("z", 7)], duration_s=0.3)
    assert res.status == ("ok",) * 3 and ref.status == ("ok",)
    for s in ("q_rad", "q_FB_rad", "q_M_FB_rad", "i_q_A", "i_FB_A", "T_gear_Nm"):
        np.testing.assert_array_equal(res[s][0], res[s][1], err_msg=s)
        np.testing.assert_array_equal(res[s][0], ref[s][0], err_msg=s)
        assert np.any(res[s][2] != res[s][0]), f"{s}: the noisy run equals the noise-free one"


def test_noise_free_runs_of_kernel_and_reference_agree_within_the_self_perturbation_baseline():
    """As tests/sim/test_kernel.py for noisy runs: the compiled kernel and the numpy reference differ on a
    noise-free run by no more than the kernel moves when a Coulomb level changes by a relative 1e-12."""
    p = load_params()
    nudged = load_params(overrides={"friction": {"coulomb_Nm": [c * (1 + 1e-12) for c in p.friction.coulomb_Nm]}})
    runs = [RunSpec("h", 3, (NOISE_FREE,)), RunSpec("b", 3, (NOISE_FREE, make_effect("backlash", 2, backlash_deg=0.1)))]
    ref = Simulator(p, drive="numpy").run(pick_and_place(), runs, duration_s=0.5)
    fast = Simulator(p, drive="numba").run(pick_and_place(), runs, duration_s=0.5)
    base = Simulator(nudged, drive="numba").run(pick_and_place(), runs, duration_s=0.5)
    assert ref.status == fast.status == base.status == ("ok",) * 2
    for s in ("q_rad", "q_FB_rad", "i_q_A", "i_FB_A", "T_gear_Nm"):
        kernel = np.max(np.abs(fast[s] - ref[s]))
        baseline = np.max(np.abs(base[s] - fast[s]))
        assert kernel <= 10 * baseline, f"{s}: kernel vs numpy {kernel:.2e}, baseline {baseline:.2e}"

"""The discrepancy workflow's statistics and search on synthetic linear problems (no simulation):
values against Monte Carlo and closed forms, and the search's decisions on constructed cases."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from stand_in_candidates import Col

from ur5fault.discrepancy.refinement import polish, probe_batch
from ur5fault.discrepancy.search import columns_of, forward
from ur5fault.discrepancy.statistics import (
    BlockGram,
    collinearity,
    effective_n,
    generalisation,
    jackknife_se,
    rss_of,
    stability,
)

N, C = 4000, 2


def ar1(rng, rho, shape):
    """Unit-variance AR(1) noise along the first axis."""
    e = rng.standard_normal(shape)
    out = np.empty(shape)
    out[0] = e[0]
    for t in range(1, shape[0]):
        out[t] = rho * out[t - 1] + np.sqrt(1 - rho**2) * e[t]
    return out


def test_effective_n_follows_the_autocorrelation():
    rng = np.random.default_rng(1)
    for rho in (0.0, 0.5, 0.9):
        e = ar1(rng, rho, (N, C))
        assert effective_n(e) == pytest.approx(N * C * (1 - rho) / (1 + rho), rel=0.15)


def test_jackknife_standard_error_matches_monte_carlo_under_autocorrelation():
    """The block jackknife's error of a least-squares coefficient agrees with its scatter over many
    noise draws (AR(1), rho 0.9, where the white-noise formula would be 4x too small)."""
    rng = np.random.default_rng(2)
    t = np.linspace(0, 1, N)
    x = np.stack([np.sin(2 * np.pi * 3 * t), t - 0.5], axis=1)  # two channels
    X = x[None]  # (1, N, C)
    est, ses = [], []
    for _ in range(60):
        e = 0.7 * x + ar1(rng, 0.9, (N, C))
        bg = BlockGram.build(X, e)
        G, g, ee = bg.total()
        est.append(rss_of(G, g, ee, [0])[1][0])
        ses.append(jackknife_se(bg, [0])[0])
    assert np.mean(est) == pytest.approx(0.7, abs=3 * np.std(est) / np.sqrt(len(est)))
    assert 0.6 < np.median(ses) / np.std(est) < 1.6
    white = 1 / np.sqrt(np.sum(x**2))
    assert np.std(est) > 3 * white


def test_collinearity_is_the_squared_correlation():
    rng = np.random.default_rng(3)
    a, b = rng.standard_normal((2, N, C))
    c = 0.6 * a + 0.8 * b  # cos(c, a) = 0.6 for orthogonal unit-variance a, b
    bg = BlockGram.build(np.stack([a, b, c]), np.zeros((N, C)))
    G = bg.total()[0]
    assert collinearity(G, [0], [2]) == pytest.approx(0.36, abs=0.03)
    assert collinearity(G, [0, 1], [2]) == pytest.approx(1.0, abs=1e-9)
    assert collinearity(G, [], [2]) == 0.0


def test_stability_flags_an_estimate_that_changes_over_time():
    rng = np.random.default_rng(4)
    x = rng.standard_normal((N, C))
    steady = 0.5 * x + 0.1 * rng.standard_normal((N, C))
    drifting = np.where(np.arange(N)[:, None] < N // 2, 0.9, 0.1) * x + 0.1 * rng.standard_normal((N, C))
    for e, stable in ((steady, True), (drifting, False)):
        bg = BlockGram.build(x[None], e)
        G, g, ee = bg.total()
        th = rss_of(G, g, ee, [0])[1]
        assert stability(bg, [0], [0], th, 0.01).stable is stable


def test_a_rejected_candidate_does_not_end_the_search():
    """The largest improvement comes from a column whose coefficient is +4 in the first half of the log and
    -2 in the second (unstable); the search rejects it and goes on to name the two real ones."""
    rng = np.random.default_rng(5)
    t = np.arange(N)[:, None]
    real1, real2, artefact = rng.standard_normal((3, N, C))
    e = 0.8 * real1 + 0.5 * real2 + np.where(t < N // 2, 4.0, -2.0) * artefact + ar1(rng, 0.3, (N, C))
    X = np.stack([artefact, real1, real2, rng.standard_normal((N, C))])
    cands = [Col("artefact"), Col("real1"), Col("real2"), Col("noise")]
    sel = forward(BlockGram.build(X, e), e, X, cands, columns_of(cands), 3)
    assert [cands[k].label for k in sel.chosen] == ["real1", "real2"]
    assert sel.trace[0].label == "artefact" and not sel.trace[0].accepted and "unstable" in sel.trace[0].reason


def test_pure_noise_selects_nothing():
    rng = np.random.default_rng(6)
    X = rng.standard_normal((40, N, C))
    e = ar1(rng, 0.5, (N, C))
    cands = [Col(f"c{i}") for i in range(40)]
    assert forward(BlockGram.build(X, e), e, X, cands, columns_of(cands), 5).chosen == []


def test_generalisation_ratio():
    rng = np.random.default_rng(7)
    change = np.sin(np.linspace(0, 20, N))[:, None] * np.ones((1, C))
    noise = rng.standard_normal((N, C))
    true = generalisation(noise, noise + change)  # the finding removes exactly its change
    assert true.testable and true.ratio == pytest.approx(1.0, abs=0.1)
    spurious = generalisation(noise - change, noise)  # the finding adds a change the data do not have
    assert spurious.testable and spurious.ratio == pytest.approx(-1.0, abs=0.1) and not spurious.passes


@pytest.mark.parametrize("method", ["secant", "minimize"])
def test_refine_converges_on_a_mildly_nonlinear_model(method):
    """A stand-in simulator y(theta) = A theta + 0.3 (A theta)^2: from the linear estimate of probes at half
    the true size, one probe batch and either refiner reach the truth."""
    rng = np.random.default_rng(8)
    A = rng.standard_normal((2, N, C)) * 0.05
    truth = np.array([1.0, -0.6])

    def model(th):
        lin = np.tensordot(th, A, axes=1)
        return lin + 0.3 * lin**2

    meas = model(truth)

    @dataclasses.dataclass
    class Sim:
        ok: bool = True

    def evaluate(thetas):
        return [(Sim(), meas - model(th)) for th in thetas]

    J0 = np.stack([model(0.5 * truth[i] * np.eye(2)[i]) / (0.5 * truth[i]) for i in range(2)])
    e0 = meas - model(np.zeros(2))
    bg = BlockGram.build(J0, e0)
    G, g, ee = bg.total()
    th0 = rss_of(G, g, ee, [0, 1])[1]
    probes = [-th0[i] * np.eye(2)[i] for i in range(2)]  # each coefficient removed
    bounds = (np.full(2, -5.0), np.full(2, 5.0))
    first = probe_batch(evaluate, th0, probes, bounds, N // 2)
    assert np.allclose(first.e0, e0) and len(first.steps) == 4
    out = polish(evaluate, first.theta, first.J, bounds, N // 2, method)
    assert np.allclose(out.theta, truth, atol=0.02), (out.theta, len(out.steps))


def test_library_candidates_are_linearised_about_the_model_being_fitted():
    """Parameters without an "absent" value (friction share, temperature coefficient) start from the
    fitted model's own values (a user's overlay), not the packaged ones; the share is probed at the end
    of its range farther from that value."""
    from ur5fault.discrepancy.library import candidates
    from ur5fault.sim.params import load_params

    p = load_params(overrides={"friction": {"motor_side_share": [1.0, 0.0, 0.0, 0.0, 0.0, 0.3],
                                            "viscous_temp_coeff_per_K": [0.01, 0.02, 0.03, 0.02, 0.02, 0.02]}})
    share = {c.joint: (c.x0, c.probe) for c in candidates(0.7, params=p) if c.effect == "friction_share"}
    assert share[0] == (1.0, 0.0) and share[1] == (0.0, 1.0) and share[5] == (0.3, 1.0)
    temp = {c.joint: c.x0 for c in candidates(0.7, params=p) if c.effect == "viscous_temperature"}
    assert temp[0] == 0.01 and temp[2] == 0.03
    payload = [c for c in candidates(0.7, params=p) if c.effect == "payload"]
    assert [(c.x0, c.probe) for c in payload] == [(0.7, 1.2)]


def test_a_payload_near_the_rated_five_kg_is_probed_lighter():
    """A log at 5 kg (the UR5's rated payload, the payload effect's top) was refused "payload.mass_kg = 5.5 is out
    of range [0, 5] kg" by the screening's probe 0.5 kg heavier, a value the user never gave: within 0.5 kg of the
    top the probe is 0.5 kg lighter."""
    from ur5fault.discrepancy.library import candidates

    probes = {kg: [c.probe for c in candidates(kg) if c.effect == "payload"] for kg in (4.5, 4.6, 5.0)}
    assert probes == {4.5: [5.0], 4.6: [pytest.approx(4.1)], 5.0: [4.5]}


def test_a_value_below_its_limit_reads_below_it():
    """A drop reason read "z 4.0 < 4" (3.96 to one decimal)."""
    from ur5fault.discrepancy.statistics import below

    assert below(3.96, 4.0) == "3.96" and below(3.2, 4.0) == "3.2" and below(3.9996, 4.0) == "3.9996"
    assert float(below(3.99999999, 4.0)) < 4.0
    assert below(-1.0, 4.0) == "-1.0"

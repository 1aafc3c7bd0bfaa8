"""``identify(log)``: every measured parameter of the drive model, re-derived from a log.

Order matters: the torque constant and friction come first (the breakaway needs both and
the position noise), the bandwidth sweep last (it replays the log with everything else
already identified).  Where the log cannot carry a value (a joint that barely moves, a
torque constant without a gravity lever) the estimate falls back to a stated assumption
and says so (``identifiable=False``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import LogFormatError, ParameterError
from ..logs import MeasuredLog
from ..sim.axes import N_JOINTS
from ..sim.params import FrictionParams, RobotParams, load_params
from ..sim.validated import declared_range
from . import friction, loadfriction, loop, motor, payload, ripple, sensors, stickslip, urmodel
from .report import PRESLIDING_FIELD, PRESLIDING_KEY, Identification, overlay_params
from .signals import derive_all
from .stats import BLOCK_S, N_BOOT, Estimate, block_indices, bootstrap, fallback, interval


def identify(log: MeasuredLog | Sequence[MeasuredLog], params: RobotParams | None = None, *,
             model_path: str | Path | None = None,
             sweep: bool = True, bandwidths_Hz=loop.BANDWIDTHS_HZ, sweep_window_s: float = loop.SWEEP_WINDOW_S,
             n_boot: int = N_BOOT, seed: int = 0, progress: Callable[[str], None] | None = None,
             ripple_max_hz: float = ripple.MAX_RIPPLE_HZ) -> Identification:
    """Identify the ``[nist]`` parameters of ``ur5_drive.yaml`` from ``log``.

    Args:
        log: a measured log (:func:`ur5fault.logs.read_log`) with its payload and tool offset, or several
            logs of one robot identified jointly (every regression over all their samples; a rest or a
            start from rest never spans two logs; the bandwidth sweep replays the first whose first
            ``sweep_window_s`` moves a joint, and where none does the bandwidth is not identifiable). A log whose
            payload is unknown (``payload_kg`` ``None``) has it fitted as its own nuisance (:mod:`.payload`),
            reported in ``Identification.payloads``, never in the overlay.
        params: the model whose assumptions are kept (rotor inertia, gear ratio, viscous temperature
            law, the fallbacks); default the packaged ``ur5_drive.yaml``.
        model_path: MJCF for the inverse dynamics (default: the simulator's).
        sweep: run the position-loop bandwidth sweep (replays the log once per candidate; slow).
        bandwidths_Hz: candidate position-loop bandwidths.
        sweep_window_s: the part of the log the sweep replays (from its start).
        n_boot: resamples of every interval.
        seed: seed of the resampling (results are reproducible).
        progress: called with a one-line message before each slow step.
        ripple_max_hz: fastest motor-angle ripple used to identify it (:mod:`.ripple`).
    """
    from ..sim.engine import DEFAULT_MODEL_PATH

    logs = [log] if isinstance(log, MeasuredLog) else list(log)
    if not logs:
        raise ParameterError("identify needs at least one log")
    p = params if params is not None else load_params()
    say = progress or (lambda _msg: None)
    say("inverse dynamics of the log's motion" if len(logs) == 1 else f"inverse dynamics of {len(logs)} logs")
    sig = derive_all(logs, p, model_path or DEFAULT_MODEL_PATH)
    source = " + ".join(lg.source for lg in logs)
    duration_s = float(sum(lg.t_s[-1] - lg.t_s[0] for lg in logs))
    est: list[Estimate] = []

    say("torque constant and friction (moving samples)" + ("" if sig.payload_columns_Nm is None else
                                                           ", with each unknown payload"))
    fit = friction.FrictionFit(sig, p)
    blocks = block_indices(sig.n, int(round(BLOCK_S / sig.period_s)))
    payloads: tuple = ()
    if fit.payload is None:
        full = fit(np.arange(sig.n))
        refuse_current_sign(fit, full, source)
        lo, hi = interval(bootstrap(fit, blocks, n_boot, seed))
    else:
        full, theta = fit.solve(np.arange(sig.n))
        refuse_current_sign(fit, full, source)
        size = full.size
        boot = bootstrap(lambda idx: np.concatenate([a.ravel() for a in fit.solve(idx)]), blocks, n_boot, seed)
        lo, hi = interval(boot[:, :size].reshape(-1, *full.shape))
        payloads = tuple(payload.records(logs, fit.payload, theta, boot[:, size:]))
        # every later step sees the logs with the payload fitted: the torque it adds, and the replays hold it
        sig = dataclasses.replace(sig, model_torque_Nm=sig.model_torque_Nm + np.tensordot(
            theta, fit.payload.columns_Nm, axes=1), payload_columns_Nm=None, payload_owner=())
        logs = [dataclasses.replace(lg, payload_kg=r.replayed_kg, tcp_offset_m=r.replayed_com_m)
                for lg, r in zip(logs, payloads)]
    est += _torque_constant(fit, full, lo, hi, p)
    fit_k = fit  # the joint fit decides which torque constants were identified
    fit = friction.FrictionFit(sig, p) if payloads else fit_k  # the later steps: at the fitted payloads
    est += _k_check(friction.FrictionFit(sig, p, k_offset_term=True), None, blocks, n_boot, seed,
                    "check.torque_constant_with_offset_Nm_per_A", "with a constant current offset fitted too")
    if sig.target_torque_Nm is not None:
        est += _k_check(fit, sig.target_torque_Nm, blocks, n_boot, seed, "check.torque_constant_vs_UR_torque_Nm_per_A",
                        "with UR's target torque column in place of MuJoCo's inverse dynamics")
    fric = _friction(fit_k, full, lo, hi, p)
    est += fric
    est += urmodel.ur_model(fit)
    coulomb_A = np.array([e.value for e in fric if e.key == "friction.coulomb_A"])
    say("torque ripple periodic in the motor angle (moving samples)")
    est += ripple.identify_ripple(fit, full, blocks, n_boot, seed, ripple_max_hz)
    say("load-dependent friction (check, samples above the Stribeck range)")
    est += loadfriction.identify_load_friction(fit, full, blocks, n_boot, seed, p.friction.stribeck_rate_s_per_rad)

    say("sensor noise at rest and resolver resolution")
    noise = sensors.noise_at_rest(sig, n_boot, seed, {"sensors.current_noise_A": p.sensors.current_noise_A,
                                                      "sensors.resolver_noise_rad": p.sensors.resolver_noise_rad})
    est += noise
    est += sensors.resolver_resolution(sig, n_boot, seed, p.sensors.resolver_counts_per_rev)

    say("breakaway and presliding stiffness (starts from rest)")
    q_noise = np.array([e.value for e in noise if e.key == "sensors.resolver_noise_rad"])
    est += _breakaway(sig, fit, full, coulomb_A, q_noise, n_boot, seed, _presliding_prior(p))

    say("tracking lag")
    lags, lag_ok = loop.tracking_lag(sig, n_boot, seed)
    est += lags
    lag = np.array([e.value for e in lags])
    ff_prior = np.asarray(p.controller.velocity_feedforward, float)

    result = Identification(source, duration_s, tuple(est), None)
    bw_prior = float(np.mean(p.controller.position_bw_Hz))
    # the sweep replays the first log whose first sweep_window_s moves a joint (none: it cannot tell)
    sweep_log = next((lg for lg in logs if loop.sweep_joints(lg, sweep_window_s)[1]), None) if sweep else None
    if sweep and sweep_log is None:
        sw = None
        est.append(fallback("controller.position_bw_Hz", None, bw_prior, "kept the model's value",
                            f"no joint's target reaches {loop.MIN_TOP_SPEED_RAD_S:g} rad/s within the first "
                            f"{sweep_window_s:g} s of any log: nothing for the sweep to score"))
        bw = bw_prior
    elif sweep:
        sw = loop.bandwidth_sweep(sweep_log, overlay_params(result, p), lag, lag_ok, ff_prior, bandwidths_Hz,
                                  sweep_window_s, n_boot, seed, progress=say)
        est.append(loop.sweep_estimate(sw, sweep_log.source))
        bw = sw.best_Hz
    else:
        sw = None
        est.append(fallback("controller.position_bw_Hz", None, bw_prior, "not swept (sweep=False)",
                            "kept the model's value"))
        bw = bw_prior
    est += _feedforward(lags, lag_ok, bw, ff_prior)
    notes = () if payloads else tuple(stated_payload_notes(est))  # a fitted payload is the log's by construction
    return Identification(source, result.duration_s, tuple(est), sw, payloads, notes)


#: a torque constant fitted on MuJoCo's inverse dynamics that departs from the one UR's own target torques give by more
#: than this share is noted: on every real log of data/ they agree within 3 % (NIST J2 0.133 / 0.131, the nine
#: Kufieta runs 0.103-0.108 / 0.103-0.108 N*m/A), and a payload stated 3 kg too heavy put them 51 % apart
K_VS_UR_NOTE_SHARE = 0.15


def stated_payload_notes(est: Sequence[Estimate]) -> list[str]:
    """A note per joint whose torque constant (fitted under the stated payload and tool) and its check on UR's target
    torques (which carry the controller's own payload setting) differ by more than :data:`K_VS_UR_NOTE_SHARE` with
    disjoint intervals: the likeliest cause is a payload or tool stated wrongly (a probe's 3 kg for a run without
    one went into the torque constant, 0.163 for 0.108 N*m/A, without a word)."""
    ours = {e.joint: e for e in est if e.key == "motor.torque_constant_Nm_per_A" and e.identifiable}
    notes = []
    for c in (e for e in est if e.key == "check.torque_constant_vs_UR_torque_Nm_per_A"):
        k = ours.get(c.joint)
        if k is None or not c.value > 0 or abs(k.value / c.value - 1) <= K_VS_UR_NOTE_SHARE:
            continue
        if not np.isfinite([k.lo, k.hi, c.lo, c.hi]).all() or (k.lo <= c.hi and c.lo <= k.hi):
            continue  # an interval it has not, or overlapping ones: not told apart
        notes.append(f"J{c.joint + 1}'s torque constant fitted on the model's torques under the stated payload "
                     f"({k.value:.4g} N*m/A) is {100 * (k.value / c.value - 1):+.0f} % from the one UR's own target "
                     f"torques give ({c.value:.4g}): check the payload and tool stated (--payload-kg, --tcp-offset-m; "
                     "on the real logs of ur5fault's data/ the two agree within 3 %), or omit --payload-kg to fit it")
    return notes


#: a Coulomb level counts as of the other sign below minus this [A]: half the smallest of the real logs (0.10 A), so
#: a joint with next to no Coulomb friction (a simulated log at scale 0 fits a few mA either way) is not refused as a
#: log of the other sign; a log whose currents have the other sign gives -0.2..-0.8 A
SIGN_COULOMB_A = 0.05


def refuse_current_sign(fit: friction.FrictionFit, full: NDArray, source: str) -> None:
    """A torque constant or a Coulomb level fitted below zero, refused in one line (before the resampling): the
    current then runs against the torque and the motion it drives, as in a log whose currents have the other sign
    (the reader tells that from UR's target currents where a log has them, ``logs/plausible.py``; a log without
    them, or with both columns of the other sign, is told here). Every real log of data/ gives 0.10..0.13 N*m/A and
    0.10..0.81 A on every joint the fit identifies."""
    k_joints = sorted(j for g in fit.k_groups.values() for j in g)
    neg_k = [j for j in k_joints if full[0, j] < 0]
    neg_c = [int(j) for j in np.flatnonzero(fit.ok) if full[1, j] < -SIGN_COULOMB_A]
    if not neg_k and not neg_c:
        return
    parts = []
    if neg_k:
        parts.append(f"the torque constant of {', '.join(f'J{j + 1}' for j in neg_k)} "
                     f"({', '.join(f'{full[0, j] / fit.ratio[j]:.3g}' for j in neg_k)} N*m/A)")
    if neg_c:
        parts.append(f"the Coulomb friction of {', '.join(f'J{j + 1}' for j in neg_c)} "
                     f"({', '.join(f'{full[1, j]:.3g}' for j in neg_c)} A)")
    raise LogFormatError(f"{source}: {' and '.join(parts)} come out negative: the current runs against the torque "
                         "and the motion it drives, as in a log with currents of the other sign (its sign convention "
                         "is opposite to the torque's; ur5fault takes a current positive when it drives the joint "
                         "positive); negate the current columns of the other sign (nothing written)")


def _torque_constant(fit: friction.FrictionFit, full: NDArray, lo: NDArray, hi: NDArray,
                     p: RobotParams) -> list[Estimate]:
    out = []
    ratio = fit.ratio
    for j in range(N_JOINTS):
        size = motor.MOTOR_SIZE[j]
        group = fit.k_groups[size]
        key = "motor.torque_constant_Nm_per_A"
        if group:
            src = ", ".join(f"J{g + 1}" for g in group)
            out.append(Estimate(key, j, full[0, j] / ratio[j], lo[0, j] / ratio[j], hi[0, j] / ratio[j],
                                f"slope of current on MuJoCo inverse-dynamics torque, moving samples of {src} "
                                f"(shared by the size-{size} joints), fitted with their friction"))
        elif fit.payload is not None and not fit.payload.k_identifiable:
            out.append(fallback(key, j, p.motor.torque_constant_Nm_per_A[j], "kept the model's value",
                                "every log's payload is unknown and none separates it from the torque constants "
                                "(identify/payload.py): state the payload of one log"))
        else:
            same = np.flatnonzero(np.asarray(motor.MOTOR_SIZE) == size)
            out.append(fallback(key, j, p.motor.torque_constant_Nm_per_A[j], "kept the model's value",
                                f"no size-{size} joint carries it: " + "; ".join(_why_no_lever(fit, g) for g in same)))
    return out


def _why_no_lever(fit: friction.FrictionFit, j: int) -> str:
    """Why joint ``j`` (0-based) does not carry its size's torque constant: it moves too little for the friction
    fit, or the model's torque on it spreads too little (it said "spread 9.18 N*m < 2" of a joint that had the lever
    but too few moving samples)."""
    if not fit.ok[j]:
        moving = fit.moving[:, j]
        top = float(np.abs(fit.sig.qd_target_rad_s[moving, j]).max(initial=0.0))
        return (f"J{j + 1} moves too little for the friction fit ({int(moving.sum())} moving samples up to "
                f"{top:.2g} rad/s; {friction.MIN_MOVING_SAMPLES} samples and {friction.MIN_TOP_SPEED_RAD_S:g} rad/s "
                "needed)")
    return f"J{j + 1}'s model torque spreads {fit.lever_Nm[j]:.2f} N*m (< {motor.MIN_TORQUE_SPREAD_NM:g})"


def _k_check(fit: friction.FrictionFit, torque: NDArray | None, blocks, n_boot: int, seed: int, key: str,
             how: str) -> list[Estimate]:
    """A variant of the torque-constant fit, reported as a check (not written to the overlay)."""

    def stat(idx: NDArray) -> NDArray:
        return fit(idx, torque=torque)[0]

    full = stat(np.arange(fit.sig.n))
    lo, hi = interval(bootstrap(stat, blocks, n_boot, seed))
    out = []
    for size, group in fit.k_groups.items():
        if group:
            j = group[0]
            r = fit.ratio[j]
            out.append(Estimate(key, j, full[j] / r, lo[j] / r, hi[j] / r,
                                f"as motor.torque_constant_Nm_per_A (size {size}) {how}"))
    return out


def _friction(fit: friction.FrictionFit, full: NDArray, lo: NDArray, hi: NDArray, p: RobotParams) -> list[Estimate]:
    """Coulomb, viscous (and the offset, as a check) per joint; joints that barely move take the mean of
    the identified joints of their size ([A]), or the model's value when there is none."""
    out = []
    sizes = np.asarray(motor.MOTOR_SIZE)
    t_ref = p.friction.reference_temp_C
    names = (("friction.coulomb_A", 1, "Coulomb term", p.friction.coulomb_Nm),
             ("friction.viscous_A_s_per_rad", 2, f"viscous term at {t_ref:g} degC (via the model's viscous "
                                                 "temperature law)", p.friction.viscous_Nms_per_rad),
             ("check.current_offset_A", 3, "constant current (nuisance term: a torque or offset the model "
                                               "lacks)", None))
    for key, row, what, prior_Nm in names:
        for j in range(N_JOINTS):
            if fit.ok[j]:
                n = int(fit.moving[:, j].sum())
                out.append(Estimate(key, j, full[row, j], lo[row, j], hi[row, j],
                                    f"{what}, regression on {n} moving samples with the model torque removed"))
            elif prior_Nm is not None:
                donors = np.flatnonzero((sizes == sizes[j]) & fit.ok)
                if donors.size:
                    src = ", ".join(f"J{d + 1}" for d in donors)
                    out.append(fallback(key, j, float(np.mean(full[row, donors])), f"[A] equal to {src} (same joint "
                                        "size)", _why_not(fit, j)))
                else:
                    out.append(fallback(key, j, prior_Nm[j] / fit.k_prior[j], "kept the model's value",
                                        _why_not(fit, j)))
    return out


def _why_not(fit: friction.FrictionFit, j: int) -> str:
    """The criterion of :func:`friction.identifiable` that failed on joint ``j``, named."""
    n = int(fit.moving[:, j].sum())
    top = float(np.abs(fit.sig.qd_target_rad_s[fit.moving[:, j], j]).max(initial=0.0))
    failed = []
    if n < friction.MIN_MOVING_SAMPLES:
        failed.append(f"{n} moving samples, fewer than the {friction.MIN_MOVING_SAMPLES} needed "
                      f"({friction.MIN_MOVING_SAMPLES * fit.sig.period_s:.1f} s at this log's rate)")
    if top < friction.MIN_TOP_SPEED_RAD_S:
        failed.append(f"top speed {top:.2f} rad/s while moving, below the {friction.MIN_TOP_SPEED_RAD_S:g} rad/s "
                      "needed to separate Coulomb from viscous friction")
    return f"J{j + 1}: " + "; ".join(failed)


def _presliding_prior(p: RobotParams) -> NDArray:
    """The model's presliding stiffness per joint [N*m/rad] (what a joint keeps where a log cannot give it)."""
    return np.broadcast_to(np.asarray(p.friction.presliding_stiffness_Nm_per_rad, float), (N_JOINTS,))


def _breakaway(sig, fit: friction.FrictionFit, full: NDArray, coulomb_A: NDArray, q_noise: NDArray, n_boot: int,
               seed: int, stiffness_prior: NDArray) -> list[Estimate]:
    """Breakaway current and presliding stiffness per joint.  Where the starts do not show a breakaway
    (its interval reaches zero), the breakaway is the joint's Coulomb level times the breakaway-to-Coulomb
    ratio measured on the joints where they do, and the stiffness is not reported.  A stiffness the starts do
    not give within the parameter's range (no positive number: the torque rose while the joint moved back, a push
    by hand; or beyond its upper bound: almost no displacement) is not identifiable there and keeps the model's value
    (``stiffness_prior``)."""
    found = stickslip.identify_stickslip(sig, full[0], full[3], q_noise, np.flatnonzero(fit.ok), n_boot, seed)
    lo, hi = declared_range(FrictionParams, PRESLIDING_FIELD)  # open below
    brk = {e.joint: e for e in found if e.key == "friction.breakaway_A"}
    good = {j for j, e in brk.items() if e.lo > 0}
    out = []
    for e in found:
        if e.joint not in good:
            continue
        if e.key == PRESLIDING_KEY and not (np.isfinite(e.value) and lo < e.value <= hi):
            positive = bool(np.isfinite(e.value) and e.value > 0.0)
            why = (f"give {e.value:.3g} N*m/rad, beyond the model's {hi:g} (almost no displacement)" if positive
                   else "give no positive torque change over joint displacement")
            e = fallback(PRESLIDING_KEY, e.joint, stiffness_prior[e.joint], "kept the model's value",
                         f"the starts of J{e.joint + 1} {why}")
        out.append(e)
    ratio = float(np.median([brk[j].value / coulomb_A[j] for j in good])) if good else 1.0
    src = ", ".join(f"J{j + 1}" for j in sorted(good)) or "no joint (ratio 1 assumed)"
    for j in range(N_JOINTS):
        if j in good:
            continue
        if j in brk:
            why = f"the starts of J{j + 1} show no breakaway above zero (interval {brk[j].lo:.3f}..{brk[j].hi:.3f} A)"
        elif fit.ok[j]:  # its friction was identified, but the log holds too few starts from rest to read one
            why = f"J{j + 1}: fewer than {stickslip.MIN_STARTS} starts from rest in the log"
        else:
            why = _why_not(fit, j)
        out.append(fallback("friction.breakaway_A", j, ratio * coulomb_A[j],
                            f"[A] Coulomb level times the breakaway/Coulomb ratio {ratio:.2f} measured on {src}", why))
    return out


def _feedforward(lags: list[Estimate], lag_ok: NDArray, bw_Hz: float, ff_prior: NDArray) -> list[Estimate]:
    """``ff = 1 - lag * 2 pi f_p`` where the lag is identified; the model's value elsewhere."""
    out = []
    gain = 2.0 * np.pi * bw_Hz
    for e in lags:
        j = e.joint
        if lag_ok[j]:
            out.append(Estimate("controller.velocity_feedforward", j, 1.0 - e.value * gain, 1.0 - e.hi * gain,
                                1.0 - e.lo * gain, f"1 - lag * 2 pi * {bw_Hz:g} Hz (interval of the lag only)"))
        else:
            out.append(fallback("controller.velocity_feedforward", j, ff_prior[j], "kept the model's value", e.note))
    return out

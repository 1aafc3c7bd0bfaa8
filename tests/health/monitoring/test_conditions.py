"""The events' motion conditions on synthetic residuals: the arm at rest judged against its own level and the
spread of the baseline's rests (a step found there that the spread of the motions hides; a slow drift not an
event), and a healthy creeping reversal judged against the baseline's reversals, not against the standing arm."""

import zlib

import numpy as np

from tests.health.monitoring.test_monitoring import PERIOD, STRIBECK_RAD_S, part
from ur5fault.health.monitoring import assess, fit_baseline
from ur5fault.health.monitoring.conditions import MOVING, REST, REVERSAL, SLOW, STANDING, condition

N_JOINTS = 6


def bumps(rng, n: int, every_s: float, width_s: float, lo: float, hi: float) -> np.ndarray:
    """``(n, 6)``: a half-sine bump of ``width_s`` every ``every_s`` on every joint, amplitude drawn from
    ``[lo, hi]`` with a random sign (the twin's error where a move starts or stops)."""
    out = np.zeros((n, N_JOINTS))
    w = int(round(width_s / PERIOD))
    shape = np.sin(np.pi * np.arange(w) / w)
    for a in range(0, n - w, int(round(every_s / PERIOD))):
        out[a : a + w] += shape[:, None] * rng.uniform(lo, hi, N_JOINTS) * rng.choice([-1, 1], N_JOINTS)
    return out


def moving_then_standing(seed: int, move_s: float = 20.0, stand_s: float = 20.0):
    """A run whose joints take turns (2 s each: shoulder_pan to elbow move at 0.5 rad/s while the wrists stand,
    then the other way round) with the model's error on every joint (0.02 A noise and 0.2-0.6 A bumps every 2 s:
    on a standing joint, the coupling with the moving ones), and then the arm stands (the current sensor's
    0.01 A noise): residual ``(n, 6)``, target speed ``(n, 6)``."""
    rng = np.random.default_rng(seed)
    nm, ns = int(round(move_s / PERIOD)), int(round(stand_s / PERIOD))
    residual = np.concatenate([rng.normal(0, 0.02, (nm, 6)) + bumps(rng, nm, 2.0, 0.3, 0.2, 0.6),
                               rng.normal(0, 0.01, (ns, 6))])
    turn = (np.arange(nm) * PERIOD // 2.0).astype(int) % 2 == 0
    speed = np.zeros((nm + ns, 6))
    speed[:nm, :3] = np.where(turn, 0.5, 0.0)[:, None]
    speed[:nm, 3:] = np.where(turn, 0.0, 0.5)[:, None]
    return residual, speed


def standing_part(name, residual, speed):
    """The part, its targets constant where the speed is 0, at a pose of its own (no run repeats another's
    task: judged by the motion conditions, not against a paired baseline run)."""
    offset = np.random.default_rng(zlib.crc32(name.encode())).uniform(-1.0, 1.0, 6)
    return part(name, residual, speed=speed, target=offset + np.cumsum(speed, axis=0) * PERIOD)


def test_a_step_at_rest_is_found_against_the_rests_own_spread():
    """Baseline: three runs whose joints take turns moving with the model's error (bumps up to 0.6 A, on the
    standing joints too) and then the arm stands for 20 s on 0.01 A of noise. A 0.15 A step of 0.5 s on the
    standing arm (15 times the noise) is an event on its joint: judged against the spread of the baseline's
    rests of the arm, not against that of a joint standing while others move (whose coupling error the spread of
    all standing samples took in, and which hides it)."""
    base = fit_baseline([standing_part(f"r{k}", *moving_then_standing(k)) for k in range(3)], "sha")
    residual, speed = moving_then_standing(10)
    quiet = assess(base, standing_part("quiet", residual, speed))
    assert quiet["events"] == [], quiet
    t = np.arange(residual.shape[0]) * PERIOD
    residual[(t >= 30.0) & (t < 30.5), 2] += 0.15
    out = assess(base, standing_part("stepped", residual, speed))
    assert [e["joints"] for e in out["events"]] == [["elbow_joint"]], out
    ev = out["events"][0]
    assert abs(ev["t_start_s"] - 30.0) < 0.1 and abs(ev["t_end_s"] - 30.5) < 0.1


def test_a_slow_drift_at_rest_is_not_an_event():
    """The same baseline; the standing arm's wrist_2 current drifts by 0.3 A over 3 s (TEST's wrist_2 at rest,
    30 times the noise): followed by the rest's own running level, no event."""
    base = fit_baseline([standing_part(f"r{k}", *moving_then_standing(k)) for k in range(3)], "sha")
    residual, speed = moving_then_standing(11)
    t = np.arange(residual.shape[0]) * PERIOD
    residual[:, 4] += 0.3 * np.clip((t - 28.0) / 3.0, 0.0, 1.0)
    out = assess(base, standing_part("drift", residual, speed))
    assert out["events"] == [], out


def with_creep(seed: int, creep: bool, n_moves: int = 8):
    """A run of ``n_moves`` moves (every joint at 0.3 rad/s for 1.5 s, the model's error 0.02 A noise and 0.1-0.3 A
    bumps), each followed by 1.2 s where wrist_2 stops (0.01 A of noise: a wrist is hardly loaded by the others'
    motion) while the others move on, and by 1 s of the arm standing (0.01 A of noise). ``creep``: in the third
    stop wrist_2 creeps back at 0.6-0.9 mrad/s instead (under the twin's rest speed, as Movement_No1's wrist_2 at
    33.5-33.9 s) and its residual swings by 0.25 A over it (the friction's sign change, which the twin's smooth
    sign does not follow). Residual, speed, target ``(n, 6)``."""
    rng = np.random.default_rng(seed)
    fast, stop, stand = (int(round(x / PERIOD)) for x in (1.5, 1.2, 1.0))
    v, res = [], []
    for k in range(n_moves):
        vv = np.zeros((fast + stop + stand, 6))
        vv[:fast] = 0.3
        vv[fast : fast + stop, [0, 1, 2, 3, 5]] = 0.3
        r = np.concatenate([rng.normal(0, 0.02, (fast + stop, 6)) + bumps(rng, fast + stop, 1.35, 0.3, 0.1, 0.3),
                            rng.normal(0, 0.01, (stand, 6))])
        r[fast : fast + stop, 4] = rng.normal(0, 0.01, stop)  # a wrist standing: the others' motion hardly loads it
        if creep and k == 2:
            vv[fast : fast + stop, 4] = -(7.5e-4 + 1.5e-4 * np.sin(np.arange(stop) * PERIOD * 2 * np.pi * 3))
            r[fast : fast + stop, 4] += 0.25 * np.sin(np.pi * np.arange(stop) / stop)
        v.append(vv)
        res.append(r)
    signed = np.concatenate(v)
    return np.concatenate(res), np.abs(signed), np.cumsum(signed, axis=0) * PERIOD


def test_a_creeping_reversal_the_baseline_does_not_show_is_judged_no_tighter_than_its_motions():
    """Baseline: three runs without a creeping reversal. A healthy run whose wrist_2 creeps back once under the
    rest speed (its residual swinging by 0.25 A) raises no event: the creep is a reversal, a condition the
    baseline holds too little of to have its own spread, judged by the widest limit the joint has there (not by
    the standing arm's noise, which the rest speed alone would take it for); a 1 A push on wrist_2 in the same
    creep is still found."""
    base = fit_baseline([part(f"r{k}", *with_creep(k, False)) for k in range(3)], "sha")
    r, s, q = with_creep(20, True)
    t = np.arange(r.shape[0]) * PERIOD
    creeping = (t >= 2 * 3.7 + 1.8) & (t < 2 * 3.7 + 2.6)
    assert (condition(s > 1e-3, s, q, PERIOD, STRIBECK_RAD_S)[creeping, 4] == REVERSAL).all()
    out = assess(base, part("healthy", r, speed=s, target=q))
    assert out["events"] == [], out
    r[(t >= 9.3) & (t < 9.8), 4] += 1.0
    out = assess(base, part("pushed", r, speed=s, target=q))
    assert any("wrist_2_joint" in e["joints"] and abs(e["t_start_s"] - 9.3) < 0.2 for e in out["events"]), out


def test_conditions_of_a_stop_a_creep_and_a_standing_arm():
    """The codes on a hand-made target: a fast move, a stop (settling), a creep back (the other joints standing
    while it creeps), the arm standing."""
    n = 1000
    v = np.zeros((n, 6))
    v[:200] = 0.5  # 1.6 s at 0.5 rad/s
    v[300:500, 0] = -0.005  # a creep back on shoulder_pan at 5 mrad/s, 1.6 s
    q = np.cumsum(v, axis=0) * PERIOD
    cond = condition(np.abs(v) > 1e-3, np.abs(v), q, PERIOD, STRIBECK_RAD_S)
    assert (cond[:200] == MOVING).all()
    assert (cond[300:480, 0] == REVERSAL).all()  # moved back against its last fast motion
    assert (cond[200:220] == MOVING).all()  # settling after the move
    assert (cond[300:480, 1:] == STANDING).all()  # standing while shoulder_pan creeps: not the arm at rest
    assert (cond[600:] == REST).all()  # 0.8 s after the creep ended
    assert SLOW not in cond[600:]


def test_a_standing_joint_is_judged_no_tighter_than_a_moving_joint_at_its_features():
    """The limit of a standing joint is the wider of its own condition's and a moving joint's there (the
    all-motions fit and the moving condition's): a standing spread fitted on a quiet baseline run alone
    (0.01 A) does not narrow it below the moving statistics' constant (0.05 A); where the standing spread is the
    wider (0.2 A), it holds."""
    from ur5fault.health.monitoring.conditions import CONDITIONS, motion_limit

    n = 500
    feats = np.zeros((n, 6, 4))
    feats[..., 0] = 1.0  # the constant feature; a standing joint's speed and acceleration are 0
    cond = np.full((n, 6), STANDING)
    judged = np.ones(n, bool)
    tail = np.tile([3.0, 0.5, 0.1], (6, 1))  # (u0, beta, p0): one tail for every statistics
    coef = np.zeros((6, 4))
    coef[:, 0] = 0.05**2
    cond_coef = np.full((len(CONDITIONS), 6, 4), np.nan)
    cond_tail = np.full((len(CONDITIONS), 6, 3), np.nan)
    cond_coef[MOVING], cond_tail[MOVING] = coef, tail
    cond_coef[STANDING] = 0.0
    cond_coef[STANDING, :, 0] = [0.01**2] * 3 + [0.2**2] * 3
    cond_tail[STANDING] = tail
    lim = motion_limit(feats, cond, judged, coef, tail, cond_coef, cond_tail, PERIOD, 0.01)
    moving = motion_limit(feats, np.full((n, 6), MOVING), judged, coef, tail, cond_coef, cond_tail, PERIOD, 0.01)
    np.testing.assert_allclose(lim[:, :3], moving[:, :3])  # the quiet standing spread does not narrow it
    np.testing.assert_allclose(lim[:, 3:], moving[:, 3:] * 0.2 / 0.05)  # the wider standing spread holds

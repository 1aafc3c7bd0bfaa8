"""The result of an identification: estimates, the parameter overlay they imply, and its text forms.

The overlay (``params:`` mapping, :class:`ur5fault.config.Overlay`) holds what
``simulate --model``, ``campaign run --model`` and ``discrepancy --model`` accept.  Friction is
identified in current units (what the log measures) and written in the model's torque units
with the identified torque constant, so ``current = torque / K`` in a simulation gives back
the identified current.  Interval, method and caveat of every value go into the file's header.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..sim.axes import N_JOINTS
from ..sim.params import FrictionParams, RobotParams
from ..twin.payload import PayloadRecord
from ..util.io import finite_json
from ..util.yamlsafe import dump
from .stats import Estimate

#: stick-slip parameters of issue 10 part A: written as soon as the friction parameters have the field
PRESLIDING_FIELD = "presliding_stiffness_Nm_per_rad"
PRESLIDING_KEY = f"friction.{PRESLIDING_FIELD}"
#: what this log cannot give for the stick-slip law and the friction share, and why
NOT_IDENTIFIABLE = (
    "friction.model (smooth sign vs stick-slip law): a model choice, made by comparing replays "
    "(identify/friction_choice.py), not a value this regression can give",
    "bristle damping (LuGre sigma_1): acts within the milliseconds of presliding, unseen at this log's 8 ms "
    "sampling",
    "friction share motor side / link side of the gear: not identifiable from a healthy log - in steady "
    "sliding the motor current carries the whole friction wherever it acts, and before breakaway the link "
    "moves only by the friction contact's own deflection on either side (stickslip.py); only the gear's "
    "elastic mode (>100 Hz, above this log's 62.5 Hz Nyquist) or a backlash would tell",
)
SIGNIFICANT = 4
#: a measured count per revolution this close to a power of two is written as that power of two
POWER_OF_TWO_REL = 0.01


def _round(x: float) -> float:
    return float(f"{x:.{SIGNIFICANT}g}")


@dataclasses.dataclass(frozen=True)
class Identification:
    """Everything ``identify`` found.

    Attributes:
        source: the log's file name.
        duration_s: the log's length.
        estimates: one :class:`Estimate` per quantity and joint.
        sweep: the bandwidth sweep (``None`` when skipped).
        payloads: per log, its payload as stated or fitted (:class:`ur5fault.twin.payload.PayloadRecord`; empty
            when every log stated it). The log's, not the robot's: never in the overlay.
        notes: what the fit's own checks say the user should look at, one line each (e.g. a stated payload that
            UR's own torques contradict).
    """

    source: str
    duration_s: float
    estimates: tuple[Estimate, ...]
    sweep: Any = None
    payloads: tuple[PayloadRecord, ...] = ()
    notes: tuple[str, ...] = ()

    def get(self, key: str, joint: int | None = None) -> Estimate:
        for e in self.estimates:
            if e.key == key and e.joint == joint:
                return e
        raise KeyError(f"no estimate {key!r} for joint {joint}")

    def has(self, key: str) -> bool:
        return any(e.key == key for e in self.estimates)

    def values(self, key: str) -> NDArray:
        """Per-joint values ``(6,)`` of ``key``."""
        return np.array([self.get(key, j).value for j in range(N_JOINTS)])

    def overlay(self, params: RobotParams) -> dict[str, Any]:
        """The model overlay ``{"params": ...}``, with ``"effects"`` when the log shows a motor-angle ripple
        (``motor_harmonic``, :mod:`.ripple`)."""
        from .ripple import ripple_effects

        effects = ripple_effects(self.estimates)
        return {"params": overlay_params(self, params), **({"effects": effects} if effects else {})}

    def table(self) -> str:
        """One line per estimate: key, joint, value, interval, method / caveat."""
        lines = []
        for e in self.estimates:
            j = "all" if e.joint is None else f"J{e.joint + 1}"
            iv = f"[{e.lo:.4g}, {e.hi:.4g}]" if e.identifiable else "not identifiable"
            if e.identifiable and np.isnan(e.lo):
                iv = "-"
            tail = e.method + (f"; {e.note}" if e.note else "")
            lines.append(f"{e.key:46s} {j:3s} {e.value:11.4g}  {iv:22s} {tail}")
        return "\n".join(lines)

    def to_yaml(self, params: RobotParams) -> str:
        """The overlay as YAML, with every estimate, interval and caveat in the header."""
        head = [f"# ur5fault identify: parameters re-derived from {self.source} ({self.duration_s:.1f} s).",
                "# Intervals: 95 % bootstrap (time blocks, rest segments or starts).  Friction is identified in A",
                "# and written in N*m with the identified torque constant.  Estimates:"]
        head += ["#   " + line for line in self.table().splitlines()]
        fitted = [r for r in self.payloads if not r.known]
        if fitted:
            head += ["#", "# Payloads fitted as each log's own unknown (the logs', not the robot's: not in the "
                     "overlay):"]
            head += [f"#   {r.line()}" for r in fitted]
        head += ["#", "# Stick-slip and friction share:"]
        written = PRESLIDING_FIELD in {f.name for f in dataclasses.fields(FrictionParams)}
        head.append("#   presliding stiffness: " + (f"written as friction.{PRESLIDING_FIELD}" if written else
                                                 "reported above, not written (the model has no such parameter yet)"))
        head += [f"#   {t}" for t in NOT_IDENTIFIABLE]
        missing = not_written(self)
        if missing:
            head += ["#", "# Not identifiable on this log, so the model's own (packaged) value is written, not a "
                     "measurement:"]
            head += [f"#   {m}" for m in missing]
        body = dump(self.overlay(params), "the identified overlay", sort_keys=False, default_flow_style=None, width=120)
        text = "\n".join(head) + "\n" + body
        check_overlay_text(text, f"the overlay identified from {self.source}")
        return text

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"log": self.source, "duration_s": self.duration_s,
                               "estimates": [e.to_json() for e in self.estimates]}
        if self.payloads:
            out["payload"] = {r.log: r.to_json() for r in self.payloads}
        out["notes"] = list(self.notes)
        if self.sweep is not None:
            s = self.sweep
            out["sweep"] = {"bandwidths_Hz": s.bandwidths_Hz, "scores": s.scores, "best_Hz": s.best_Hz,
                            "window_s": s.window_s, "joints": [j + 1 for j in s.joints],
                            "rms_sim_rad": s.rms_sim_rad.tolist(), "rms_meas_rad": s.rms_meas_rad.tolist()}
        return finite_json(out)  # an interval it has not is null, never NaN (strict JSON)


def check_overlay_text(text: str, where: str) -> None:
    """The overlay text as ``--model`` reads it (:meth:`ur5fault.config.Overlay.load`): a value it would refuse
    (outside its parameter's valid range, e.g. a negative friction) is refused here in one line, naming it, and
    nothing is written (``where``: the overlay's name in the message)."""
    from ..config import Overlay
    from ..errors import ConfigFileError, ParameterError, UnknownNameError
    from ..util.yamlsafe import loads

    try:
        Overlay.from_data(loads(text, where), where)
    except (ConfigFileError, ParameterError, UnknownNameError) as exc:
        raise ParameterError(f"{exc}; --model would refuse the overlay, so nothing is written") from None


def overlay_params(ident: Identification, params: RobotParams) -> dict[str, Any]:
    """The identified values as a nested ``params`` mapping (keys present in ``ident`` only).

    A value the log cannot give (``identifiable=False``) is never written as if measured: the joint takes
    the model's own (packaged) value, and :func:`not_written` lists it for the file's header."""
    ratio = np.asarray(params.gear.ratio, float)
    kt = _measured(ident, "motor.torque_constant_Nm_per_A", params.motor.torque_constant_Nm_per_A)
    k_joint = kt * ratio
    vec = lambda x: [_round(v) for v in x]  # noqa: E731
    f = params.friction
    out: dict[str, Any] = {"motor": {"torque_constant_Nm_per_A": vec(kt)}}
    coulomb = _measured(ident, "friction.coulomb_A", f.coulomb_Nm, k_joint)
    fr: dict[str, Any] = {"coulomb_Nm": vec(coulomb)}
    if ident.has("friction.breakaway_A"):
        # a packaged breakaway below a measured Coulomb level would make a dip, not a peak: no Stribeck peak then
        fr["static_Nm"] = vec(np.maximum(_measured(ident, "friction.breakaway_A", f.static_Nm, k_joint), coulomb))
    fr["viscous_Nms_per_rad"] = vec(_measured(ident, "friction.viscous_A_s_per_rad", f.viscous_Nms_per_rad, k_joint))
    if ident.has(PRESLIDING_KEY) and PRESLIDING_FIELD in {
            f.name for f in dataclasses.fields(FrictionParams)}:
        fr[PRESLIDING_FIELD] = vec(_presliding(ident, params))
    out["friction"] = fr
    s = params.sensors
    sensors: dict[str, Any] = {}
    if ident.has("sensors.resolver_noise_rad"):
        sensors["resolver_noise_rad"] = vec(_measured(ident, "sensors.resolver_noise_rad", s.resolver_noise_rad))
    if ident.has("sensors.resolver_counts_per_rev"):
        sensors["resolver_counts_per_rev"] = [_counts(ident.get("sensors.resolver_counts_per_rev", j),
                                                      s.resolver_counts_per_rev[j]) for j in range(N_JOINTS)]
    if ident.has("sensors.current_noise_A"):
        sensors["current_noise_A"] = vec(_measured(ident, "sensors.current_noise_A", s.current_noise_A))
    out["sensors"] = sensors
    ctrl: dict[str, Any] = {}
    if ident.has("controller.position_bw_Hz") and ident.get("controller.position_bw_Hz").identifiable:
        ctrl["position_bw_Hz"] = _round(ident.get("controller.position_bw_Hz").value)
    if ident.has("controller.velocity_feedforward"):
        ctrl["velocity_feedforward"] = vec(_measured(ident, "controller.velocity_feedforward",
                                                     params.controller.velocity_feedforward))
    if ctrl:
        out["controller"] = ctrl
    return out


def _counts(e: Estimate, prior: float) -> int:
    """Counts per revolution to write: the nearest power of two where the measured count lies within
    :data:`POWER_OF_TWO_REL` of it (an encoder counting in powers of two, read through rounding), else the measured
    count itself (a quantum set by the controller's own scaling: the second UR5's 9.5 and 16.3 urad are no
    power of two); the model's value where the log cannot give it."""
    if not e.identifiable:
        return int(round(prior))
    pow2 = 2.0 ** round(np.log2(e.value))
    return int(pow2) if abs(e.value / pow2 - 1.0) <= POWER_OF_TWO_REL else int(round(e.value))


def _measured(ident: Identification, key: str, prior, scale=None) -> NDArray:
    """Per joint: the estimate (times ``scale``) where identifiable, else the model's ``prior`` value."""
    sc = np.ones(N_JOINTS) if scale is None else np.asarray(scale, float)
    pr = np.broadcast_to(np.asarray(prior, float), (N_JOINTS,))
    return np.array([ident.get(key, j).value * sc[j] if ident.get(key, j).identifiable else pr[j]
                     for j in range(N_JOINTS)])


def not_written(ident: Identification) -> list[str]:
    """Estimates the log could not give, for which the overlay holds the model's value instead."""
    by_key: dict[str, list[str]] = {}
    for e in ident.estimates:
        if not e.identifiable and not e.key.startswith("check."):
            by_key.setdefault(e.key, []).append("all" if e.joint is None else f"J{e.joint + 1}")
    return [f"{key} ({', '.join(joints)})" for key, joints in by_key.items()]


def _presliding(ident: Identification, params: RobotParams) -> NDArray:
    """Identified joints take their estimate; the others keep the model's value (its stated assumption)."""
    vals = {e.joint: e.value for e in ident.estimates
            if e.key == PRESLIDING_KEY and e.identifiable}
    prior = getattr(params.friction, PRESLIDING_FIELD)
    return np.array([vals.get(j, prior[j]) for j in range(N_JOINTS)])

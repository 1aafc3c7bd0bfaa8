"""Parameter objects of the robot and its six drive chains.

One frozen class per drive-chain component, mirroring the paper's Fig. 1.  The values
(with their sources or stated assumptions) live in ``data/ur5_drive.yaml``; see
``docs/parameters.md``.  Per-joint fields are 6-tuples in joint order
(:data:`ur5fault.sim.axes.JOINT_NAMES`).
"""

from __future__ import annotations

import dataclasses
from importlib import resources
from pathlib import Path
from typing import Any

from ..errors import ParameterError
from ..util import yamlsafe
from .validated import Validated, declared_range, param

DEFAULT_PARAMS_PATH = Path(str(resources.files("ur5fault") / "data" / "ur5_drive.yaml"))


@dataclasses.dataclass(frozen=True)
class GearParams(Validated):
    """Strain-wave gearbox with elastic backlash, the paper's eq. (1)."""

    ratio: tuple[float, ...] = param(1, 1000, unit="-", doc="reduction ratio (motor turns per joint turn)")
    stiffness_Nm_per_rad: tuple[float, ...] = param(0, 1e8, lo_open=True, unit="N*m/rad", doc="k in eq. (1)")
    damping_Nms_per_rad: tuple[float, ...] = param(0, 1e5, unit="N*m*s/rad", doc="c in eq. (1)")
    backlash_rad: tuple[float, ...] = param(0, 0.1, unit="rad", doc="alpha in eq. (1); 0 = healthy", default=0.0)


@dataclasses.dataclass(frozen=True)
class FrictionParams(Validated):
    """Joint friction, the paper's eq. (2) read as odd in speed, as a smooth-sign or LuGre law,
    split between the motor side and the link side of the gear clearance."""

    coulomb_Nm: tuple[float, ...] = param(0, 500, unit="N*m", doc="T_f,c")
    static_Nm: tuple[float, ...] = param(0, 500, unit="N*m", doc="T_f,s (breakaway)")
    viscous_Nms_per_rad: tuple[float, ...] = param(0, 500, unit="N*m*s/rad", doc="f_v at the reference temperature")
    viscous_temp_coeff_per_K: tuple[float, ...] = param(
        0, 0.2, unit="1/K", doc="f_v(T) = f_v,ref * exp(-coeff * (T - T_ref))"
    )
    reference_temp_C: float = param(-20, 120, unit="degC", per_joint=False, doc="T_ref of f_v")
    stribeck_rate_s_per_rad: float = param(0, 1e3, per_joint=False, unit="s/rad", doc="the 10 in tanh(10|w|)")
    sign_smoothing_rad_s: tuple[float, ...] = param(
        0, 1, lo_open=True, unit="rad/s", doc="width of the smooth sign tanh(w / width)"
    )
    # defaults reproduce the earlier smooth-sign, all-on-the-link model for files without these keys
    model: tuple[str, ...] = param(unit="", choices=("lugre", "smooth"), default="smooth",
                                   doc="friction law per joint: LuGre (sticks) or eq. (2) with a smooth sign")
    presliding_stiffness_Nm_per_rad: tuple[float, ...] = param(
        0, 1e9, lo_open=True, unit="N*m/rad", default=1e4, doc="LuGre sigma0 (bristle stiffness, joint side)"
    )
    bristle_damping_Nms_per_rad: tuple[float, ...] = param(
        0, 1e5, unit="N*m*s/rad", default=0.0, doc="LuGre sigma1 (bristle damping, joint side)"
    )
    motor_side_share: tuple[float, ...] = param(
        0, 1, unit="-", default=0.0, doc="share of the friction acting on the rotor, before the gear clearance"
    )


@dataclasses.dataclass(frozen=True)
class MotorParams(Validated):
    """Brushless motor: DC-equivalent or three-phase PMSM in d-q (amplitude-invariant Park)."""

    kind: tuple[str, ...] = param(unit="", choices=("dc", "pmsm"), doc="motor model per joint")
    torque_constant_Nm_per_A: tuple[float, ...] = param(0, 10, lo_open=True, unit="N*m/A", doc="K_t (per A of i_q)")
    resistance_ohm: tuple[float, ...] = param(0, 100, lo_open=True, unit="ohm", doc="winding (phase) resistance")
    inductance_H: tuple[float, ...] = param(0, 1, lo_open=True, unit="H", doc="winding (phase) inductance L_d = L_q")
    rotor_inertia_kgm2: tuple[float, ...] = param(0, 1, lo_open=True, unit="kg*m^2", doc="rotor inertia, motor side")
    pole_pairs: tuple[float, ...] = param(1, 50, unit="-", doc="pole pairs (PMSM electrical angle = p * motor angle)")


@dataclasses.dataclass(frozen=True)
class PowerParams(Validated):
    """Power electronics: the inverter limits the voltage to what the 48 V bus can give."""

    bus_voltage_V: float = param(1, 1000, per_joint=False, unit="V", doc="DC bus voltage V_net")
    current_limit_A: tuple[float, ...] = param(0, 200, lo_open=True, unit="A", doc="current reference clamp")


@dataclasses.dataclass(frozen=True)
class ControllerParams(Validated):
    """Cascaded position / motor-speed / current loops (paper Fig. 1), designed by bandwidth."""

    servo_period_s: float = param(1e-6, 1e-2, per_joint=False, unit="s", doc="sample period of sensors and loops")
    current_bw_Hz: tuple[float, ...] = param(1, 1e5, unit="Hz", doc="current-loop crossover")
    speed_bw_Hz: tuple[float, ...] = param(0.1, 1e4, unit="Hz", doc="motor-speed-loop crossover")
    speed_integral_time_s: tuple[float, ...] = param(1e-5, 10, unit="s", doc="speed-loop PI integral time")
    position_bw_Hz: tuple[float, ...] = param(0.01, 1e4, unit="Hz", doc="position-loop gain / (2 pi)")
    design_link_inertia_kgm2: tuple[float, ...] = param(
        0, 100, unit="kg*m^2", doc="nominal link inertia seen by the joint, used to set the speed-loop gain"
    )
    velocity_feedforward: tuple[float, ...] = param(0, 1.2, unit="-", doc="share of setpoint velocity fed forward")


@dataclasses.dataclass(frozen=True)
class SensorParams(Validated):
    """Resolver (joint side), motor encoder and current sensor (paper sec. 2.2)."""

    resolver_bw_Hz: tuple[float, ...] = param(1, 1e6, unit="Hz", doc="second-order natural frequency")
    resolver_damping: tuple[float, ...] = param(0.05, 5, unit="-", doc="second-order damping ratio")
    resolver_noise_rad: tuple[float, ...] = param(0, 0.01, unit="rad", doc="white-noise sigma")
    resolver_counts_per_rev: tuple[float, ...] = param(2, 2**32, unit="1/rev", doc="quantisation")
    encoder_bw_Hz: tuple[float, ...] = param(1, 1e6, unit="Hz", doc="second-order natural frequency")
    encoder_damping: tuple[float, ...] = param(0.05, 5, unit="-", doc="second-order damping ratio")
    encoder_noise_rad: tuple[float, ...] = param(0, 0.1, unit="rad", doc="white-noise sigma, motor side")
    encoder_counts_per_rev: tuple[float, ...] = param(2, 2**32, unit="1/rev", doc="quantisation, motor side")
    encoder_speed_noise_rad_s: tuple[float, ...] = param(0, 100, unit="rad/s", doc="white-noise sigma of speed")
    encoder_speed_lsb_rad_s: tuple[float, ...] = param(0, 100, unit="rad/s", doc="speed quantisation step")
    current_bw_Hz: tuple[float, ...] = param(1, 1e6, unit="Hz", doc="first-order bandwidth")
    current_noise_A: tuple[float, ...] = param(0, 1, unit="A", doc="white-noise sigma")
    current_lsb_A: tuple[float, ...] = param(0, 1, unit="A", doc="quantisation step")


#: the joint temperature the drive parameters refer to [degC] ([paper] Fig. 2 at 28 degC; ur5_drive.yaml's
#: joint_temperature_C, which a test holds equal): a campaign's and a life fleet's default temperature, and the
#: value of the temperature effect that means "no effect"
NOMINAL_JOINT_TEMPERATURE_C = 28.0


@dataclasses.dataclass(frozen=True)
class RobotParams(Validated):
    """Everything the simulator needs to know about one UR5 and its drives."""

    __nested__ = {
        "gear": GearParams,
        "friction": FrictionParams,
        "motor": MotorParams,
        "power": PowerParams,
        "controller": ControllerParams,
        "sensors": SensorParams,
    }

    gear: GearParams
    friction: FrictionParams
    motor: MotorParams
    power: PowerParams
    controller: ControllerParams
    sensors: SensorParams
    physics_dt_s: float = param(1e-6, 1e-2, per_joint=False, unit="s", doc="MuJoCo and drive integration step")
    tcp_offset_m: tuple[float, ...] = param(
        -2, 2, length=3, unit="m", doc="TCP position in the flange frame", default=(0.0, 0.0, 0.15)
    )
    joint_temperature_C: tuple[float, ...] = param(-20, 120, unit="degC", doc="joint temperature",
                                                   default=NOMINAL_JOINT_TEMPERATURE_C)

    def __post_init__(self) -> None:
        super().__post_init__()
        steps = self.controller.servo_period_s / self.physics_dt_s
        if abs(steps - round(steps)) > 1e-9 or round(steps) < 1:
            raise ParameterError(
                f"controller.servo_period_s = {self.controller.servo_period_s:g} s must be a whole multiple of "
                f"physics_dt_s = {self.physics_dt_s:g} s"
            )

    @property
    def steps_per_servo(self) -> int:
        """Physics steps per servo sample."""
        return round(self.controller.servo_period_s / self.physics_dt_s)


#: the joint temperatures the model takes [degC]: a log's, a campaign's, a life fleet's and the temperature effect's
#: (one range: a log at 100 degC was replayed where a campaign at 100 degC was refused)
JOINT_TEMPERATURE_RANGE_C = declared_range(RobotParams, "joint_temperature_C")


def load_params(path: str | Path | None = None, overrides: dict[str, Any] | None = None,
                where: str | None = None) -> RobotParams:
    """Load robot parameters from YAML (default: the packaged UR5 file) with optional overrides.

    Args:
        path: YAML file; ``None`` loads ``data/ur5_drive.yaml``.
        overrides: nested mapping merged over the file, e.g. ``{"physics_dt_s": 2.5e-5}``.
        where: file and key path of ``overrides`` for error messages (``"run.yaml: params"``): a bad key
            or value there is the user's, not the parameter file's (the file itself is checked by the tests).

    Raises:
        ConfigFileError: the file cannot be read or is not YAML.
        ParameterError, UnknownNameError: a key or value is invalid.
    """
    p = Path(path) if path is not None else DEFAULT_PARAMS_PATH
    data = read_yaml(p)
    if overrides:
        data = deep_merge(data, overrides)
    return RobotParams.from_dict(data, where=where or p.name)


def read_yaml(path: Path) -> dict[str, Any]:
    """Parse a YAML mapping strictly (:func:`ur5fault.util.yamlsafe.read_yaml`: duplicate keys, alias bombs,
    oversized and empty files refused; YAML 1.2 numbers), errors as :class:`ConfigFileError`."""
    return yamlsafe.read_yaml(path)


def deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """Return ``base`` with ``over`` merged in (nested mappings merged, other values replaced)."""
    out = dict(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = deep_merge(out[k], v)
        else:
            out[k] = v
    return out

"""The seams of the simulation core, declared once (``typing.Protocol``): what a plug-in must provide for
the engine to use it without knowing which one it is.

* :class:`Multibody`: the multibody side of a batch (``multibody.LoopMultibody``, ``multibody.BatchMultibody``);
* :class:`Drive`: one drive step of every run and joint (``drive.state.NumpyDrive``, the reference, and
  ``drive.state.NumbaDrive``, the compiled kernel);
* :class:`EffectApplier`: how an effect of the registry changes its run's row of the run arrays
  (``Effect.apply`` of every :data:`ur5fault.sim.effects.REGISTRY` entry);
* :class:`DataDrivenTerms`: the data-driven terms of a batch (``terms.TermHook``).

Shapes are batch first: ``(n_runs, 6)`` per joint quantity.  ``tests/sim/test_interfaces.py`` checks that
every implementation named above conforms (methods present, same parameters).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Protocol, runtime_checkable

import mujoco
from numpy.typing import NDArray


@runtime_checkable
class Multibody(Protocol):
    """MuJoCo models and states of every run of a batch.  ``qpos``, ``qvel``, ``qfrc_applied`` and
    ``dof_damping`` are live ``(n_runs, 6)`` arrays the engine reads and writes between steps."""

    qpos: NDArray
    qvel: NDArray
    qfrc_applied: NDArray
    dof_damping: NDArray
    model_damping: NDArray

    def set_payload(self, mass_kg: NDArray) -> None:
        """Payload mass of every run ``(n_runs,)`` [kg] (and its inertia)."""

    def start(self, q: NDArray) -> NDArray:
        """Place every run at ``q`` at rest; the bias forces (gravity) ``(n_runs, 6)`` [N*m]."""

    def mass_diagonal(self) -> NDArray:
        """Diagonal of every run's joint-space inertia ``(n_runs, 6)`` [kg*m^2]."""

    def step(self, active: NDArray) -> None:
        """One physics step of the runs where ``active`` ``(n_runs,)`` is true."""

    def warnings(self) -> NDArray:
        """MuJoCo warnings raised so far per run ``(n_runs,)``."""

    def run_models(self) -> list[mujoco.MjModel]:
        """Every run's model (after effects and terms changed it)."""

    def model_field(self, name: str) -> Any:
        """Per run, a writable view of a model field (call :meth:`model_changed` after writing)."""

    def link_bodies(self) -> list[int]:
        """The body each joint moves."""

    def model_changed(self) -> None:
        """Recompute what depends on model fields written through :meth:`model_field`."""

    def gravity_torque(self) -> NDArray:
        """Static gravity torque of every run and joint ``(n_runs, 6)`` [N*m]."""


@runtime_checkable
class Drive(Protocol):
    """One drive step of every run and joint; its state is readable by name (``th_m``, ``q_fb``, ``i_q``,
    ...: ``drive/layout.py`` ``STATE_NAMES``, each ``(n_runs, 6)``)."""

    def servo(self, q_set: NDArray, qd_set: NDArray, nz: NDArray) -> None:
        """At a servo instant: sample the sensors with the unit noise ``nz`` and run the loops."""

    def physics(self, q: NDArray, qd: NDArray) -> NDArray:
        """Before the multibody step: the link torque ``(n_runs, 6)`` [N*m] from the link state."""

    def sensors(self, q: NDArray, qd: NDArray) -> None:
        """After the multibody step: bristle states and analog sensor filters at the reached state."""


@runtime_checkable
class EffectApplier(Protocol):
    """How an effect changes its run's row of the run arrays before the run starts."""

    def __call__(self, arrays: Any, row: int, joint: int | None, values: Mapping[str, float]) -> None:
        """``arrays``: the :class:`ur5fault.sim.run_arrays.RunArrays`; ``joint`` 0-based or None for a
        whole-robot effect; ``values`` the effect's parameters by name."""


@runtime_checkable
class DataDrivenTerms(Protocol):
    """The data-driven terms of a batch at the three places they act: the runs' models before the run,
    a link load torque every physics step, and the logged readings after the run."""

    def prepare_model(self, mb: Multibody) -> None:
        """Change every run's MuJoCo model (armature, link mass and centre of mass)."""

    def load_torque(self, q: NDArray, qd: NDArray, m_ii: NDArray, dt: float,
                    gravity_Nm: NDArray | None) -> NDArray:
        """Load torque of the terms on every joint ``(n_runs, 6)`` [N*m]."""

    def static_load(self, q: NDArray, mb: Multibody, dt: float) -> NDArray | float:
        """The load at rest at ``q``, held by the drive from the start (0 without link-torque terms)."""

    def step_load(self, q: NDArray, qd: NDArray, mb: Multibody, dt: float) -> NDArray | float:
        """The load over one physics step of the lockstep loop (0 without link-torque terms)."""

    def apply_sensor_terms(self, log: dict[str, NDArray], t_log: NDArray) -> None:
        """Change the logged readings in place."""

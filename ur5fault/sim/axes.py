"""Axis conventions and joint names, written once.

Every array in ur5fault has the batch axis first:

* per-joint state or parameter: ``(n_runs, N_JOINTS)``
* logged signal: ``(n_runs, n_steps, N_JOINTS)``
* Cartesian signal: ``(n_runs, n_steps, 3)``

A single run is a batch of one.  Joint ``j`` (0-based) is ``JOINT_NAMES[j]``;
user-facing joint numbers are 1-based (``fault_joint`` 1..6, 0 = healthy).
"""

from __future__ import annotations

from ..errors import UnknownNameError

N_JOINTS = 6

JOINT_NAMES: tuple[str, ...] = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)

#: short aliases accepted on the command line and in YAML
JOINT_ALIASES: dict[str, int] = {
    **{name: i for i, name in enumerate(JOINT_NAMES)},
    **{name.removesuffix("_joint"): i for i, name in enumerate(JOINT_NAMES)},
    "base": 0,
    "shoulder": 1,
    "elbow": 2,
    "wrist1": 3,
    "wrist2": 4,
    "wrist3": 5,
    **{f"j{i + 1}": i for i in range(N_JOINTS)},
}


#: what an unknown joint's error lists as valid: the names, UR's short names and the numbers (every alias but the
#: names without ``_joint``, which the list would only double)
VALID_JOINTS: tuple[str, ...] = JOINT_NAMES + ("base", "shoulder", "elbow", "wrist1", "wrist2", "wrist3", "1..6",
                                               "j1..j6")


def joint_index(joint: int | str, where: str = "") -> int:
    """Return the 0-based index of ``joint``.

    Args:
        joint: a 1-based joint number (1..6), a joint name (``"shoulder_lift_joint"``),
            or an alias (``"shoulder"``, ``"j2"``).
        where: context for the error message (file and key path).

    Raises:
        UnknownNameError: ``joint`` names no joint; the message lists the valid names.
    """
    if isinstance(joint, bool):
        raise UnknownNameError("joint", joint, VALID_JOINTS, where)
    if isinstance(joint, int):
        if 1 <= joint <= N_JOINTS:
            return joint - 1
        raise UnknownNameError("joint", joint, VALID_JOINTS, where)
    key = str(joint).strip().lower()
    if key.isdigit():
        return joint_index(int(key), where)
    if key in JOINT_ALIASES:
        return JOINT_ALIASES[key]
    raise UnknownNameError("joint", joint, VALID_JOINTS, where)

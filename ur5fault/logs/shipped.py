"""The real UR5 logs shipped in the package, by name: a wheel user has them as a checkout does (``data/`` of a
checkout links to the same files).

``nist``: one run of a UR5 CB3 (NIST, public domain; ``ur5fault/data/nist-ur5/README.md``); ``kufieta/RUN``:
nine runs of a second UR5, CB2 (Kufieta, Apache-2.0 with its attribution and licence file beside them;
``ur5fault/data/kufieta-ur5/README.md``), and ``kufieta`` all nine. Each with the format and options the
commands need to read it (the NIST layout names its payload and tool; the Kufieta recordings state no payload,
their tool centre point is the flange).
"""

from __future__ import annotations

import dataclasses
from importlib import resources
from pathlib import Path

from ..errors import ConfigFileError, UnknownNameError

#: the folder of the shipped logs (beside the drive parameters)
LOGS_DIR = Path(str(resources.files("ur5fault") / "data"))


@dataclasses.dataclass(frozen=True)
class ShippedLog:
    """One shipped log: its name, file, the ``--format`` that reads it and the options it needs."""

    name: str
    path: Path
    format: str
    options: tuple[str, ...]
    about: str


def _kufieta() -> list[ShippedLog]:
    folder = LOGS_DIR / "kufieta-ur5"
    return [ShippedLog(f"kufieta/{p.name.removesuffix('.csv.gz')}", p, "rtde", ("--tcp-offset-m", "0", "0", "0"),
                       "UR5 CB2 (Kufieta, Apache-2.0), payload not stated"
                       + (", pushed by hand" if "Dist" in p.name or "w_disturbance" in p.name else ""))
            for p in sorted(folder.glob("*.csv.gz"))]


def shipped_logs() -> dict[str, ShippedLog]:
    """Every shipped log by name, NIST first."""
    from .readers import NIST_PAYLOAD_KG  # the reader's own value of the layout's payload

    nist = ShippedLog("nist", LOGS_DIR / "nist-ur5" / "ur5testresult_halfspeed_payload1.6lb_1.csv.gz", "nist", (),
                      f"UR5 CB3 (NIST, public domain), payload {NIST_PAYLOAD_KG:g} kg, 63 s")
    return {lg.name: lg for lg in (nist, *_kufieta())}


def shipped_log(name: str) -> list[ShippedLog]:
    """The shipped log ``name`` (a list of one), or every run of a group (``kufieta``); an unknown name is refused
    with the names there are."""
    logs = shipped_logs()
    if name in logs:
        found = [logs[name]]
    else:
        found = [lg for key, lg in logs.items() if key.startswith(f"{name}/")]
    if not found and name == "kufieta":  # the group exists by design: its folder is empty or missing
        raise ConfigFileError(f"the shipped Kufieta logs are not installed (no *.csv.gz in {LOGS_DIR / 'kufieta-ur5'}):"
                              " reinstall ur5fault")
    if not found:
        groups = sorted({key.split("/")[0] for key in logs if "/" in key})
        raise UnknownNameError("shipped log", name, [*groups, *logs])
    missing = [lg for lg in found if not lg.path.is_file()]
    if missing:
        raise ConfigFileError(f"{missing[0].path}: the shipped log {missing[0].name} is not installed: reinstall "
                              "ur5fault")
    return found

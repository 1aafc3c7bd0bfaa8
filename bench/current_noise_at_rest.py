"""The current sensor's noise at rest in every real log the project carries (docs/discrepancy.md, the rivals'
noise hint; docs/diagnostics.md, "A current gain told from a torque-constant loss"): per log and joint, the RMS of
the logged current's second difference over the samples whose target is at rest (the numerator of
``ur5fault.twin.residuals.noise_ratio``), and how many such samples there are.

    python bench/current_noise_at_rest.py

A current-sensor gain scales this figure; a healthy sensor should read the same in every run of one robot.  Prints
one line per log: the fewest rest samples over the joints, then the RMS per joint [mA] ("nan": under 100 samples).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ur5fault.logs import read_log
from ur5fault.twin.residuals import MIN_NOISE_SAMPLES, conditions

DATA = Path(__file__).resolve().parents[1] / "data"


def main() -> None:
    logs = [(p, "rtde") for p in sorted((DATA / "kufieta-ur5").glob("*.csv.gz"))]
    logs += [(p, "nist") for p in sorted((DATA / "nist-ur5").glob("*.csv*"))]
    print("log | rest samples (fewest joint) | RMS of the current's second difference at rest, J1..J6 [mA]")
    for path, fmt in logs:
        log = read_log(path, fmt)
        n = len(log.t_s) - 2
        rest = conditions(log, n, np.zeros((n, 6)))["at rest"]
        d2 = np.diff(log.current_A[1 : n + 1], 2, axis=0)
        m = rest[2:] & rest[1:-1] & rest[:-2]
        rms = [float(np.sqrt(np.mean(d2[m[:, j], j] ** 2))) if m[:, j].sum() >= MIN_NOISE_SAMPLES else float("nan")
               for j in range(6)]
        print(f"{path.name} | {int(m.sum(axis=0).min())} | " + " ".join(f"{1e3 * r:.1f}" for r in rms))


if __name__ == "__main__":
    main()

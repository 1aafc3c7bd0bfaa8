"""The current sensor's noise at rest in every real log the project carries (docs/discrepancy.md, the rivals'
noise hint; docs/diagnostics.md, "A current gain told from a torque-constant loss"): per log and joint, the RMS of
the logged current's second difference over the samples whose target is at rest (the numerator of
``ur5fault.twin.residuals.noise_ratio``), and how many such samples there are.

    python bench/current_noise_at_rest.py [--spectrum JOINT]

A current-sensor gain scales this figure; a healthy sensor should read the same in every run of one robot.  Prints
one line per log: the fewest rest samples over the joints, then the RMS per joint [mA] ("nan": under 100 samples).
With ``--spectrum JOINT`` (1-6) also, per log, that joint's current at rest by frequency band: the RMS amplitude of
64-sample Hann-windowed, linearly detrended stretches (half overlapping, inside rest stretches of at least 64
samples), averaged per band [mA, relative units]: whether runs differ in a slow settling or in the noise floor.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ur5fault.logs import read_log
from ur5fault.twin.residuals import MIN_NOISE_SAMPLES, conditions, stencils

DATA = Path(__file__).resolve().parents[1] / "data"


#: frequency bands of ``--spectrum`` [Hz] (the logs' Nyquist frequency is 62.5 Hz)
BANDS = ((0, 5), (5, 15), (15, 30), (30, 45), (45, 63))
#: stretch length of ``--spectrum`` [samples]
SEG = 64


def band_rms(current_A: np.ndarray, rest: np.ndarray, period_s: float) -> tuple[int, list[float]]:
    """``(number of stretches, RMS amplitude per band of BANDS)`` of one joint's current over its rest stretches."""
    spectra, count, k, n = [], 0, 0, len(current_A)
    t, win = np.arange(SEG), np.hanning(SEG)
    while k < n:
        if not rest[k]:
            k += 1
            continue
        e = k
        while e < n and rest[e]:
            e += 1
        for s in range(k, e - SEG + 1, SEG // 2):
            x = current_A[s : s + SEG]
            x = x - np.polyval(np.polyfit(t, x, 1), t)
            spectra.append(np.abs(np.fft.rfft(x * win)) ** 2)
        count += e - k >= SEG
        k = e
    if not spectra:
        return 0, [float("nan")] * len(BANDS)
    p, f = np.mean(spectra, axis=0), np.fft.rfftfreq(SEG, period_s)
    return count, [float(np.sqrt(p[(f >= lo) & (f < hi)].mean())) for lo, hi in BANDS]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--spectrum", type=int, choices=range(1, 7), help="also this joint's current by frequency band")
    a = ap.parse_args()
    logs = [(p, "rtde") for p in sorted((DATA / "kufieta-ur5").glob("*.csv.gz"))]
    logs += [(p, "nist") for p in sorted((DATA / "nist-ur5").glob("*.csv*"))]
    print("log | rest samples (fewest joint) | RMS of the current's second difference at rest, J1..J6 [mA]")
    for path, fmt in logs:
        log = read_log(path, fmt)
        n = len(log.t_s) - 2
        rest = conditions(log, n, np.zeros((n, 6)))["at rest"]
        d2 = np.diff(log.current_A[1 : n + 1], 2, axis=0)
        m = stencils(rest)
        rms = [float(np.sqrt(np.mean(d2[m[:, j], j] ** 2))) if m[:, j].sum() >= MIN_NOISE_SAMPLES else float("nan")
               for j in range(6)]
        print(f"{path.name} | {int(m.sum(axis=0).min())} | " + " ".join(f"{1e3 * r:.1f}" for r in rms))
        if a.spectrum:
            j = a.spectrum - 1
            count, bands = band_rms(log.current_A[1 : n + 1, j], rest[:, j], log.period_s)
            print(f"    J{a.spectrum} at rest by band ({count} stretches): "
                  + " ".join(f"{lo}-{hi} Hz {1e3 * b:.1f}" for (lo, hi), b in zip(BANDS, bands)))


if __name__ == "__main__":
    main()

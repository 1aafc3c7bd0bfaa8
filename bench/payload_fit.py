"""The unknown payload of real UR5 logs, fitted as ``ur5fault discrepancy`` fits it (docs/discrepancy.md, "An
unknown payload"; docs/validation.md).

    nice -n 5 python bench/payload_fit.py [--out results/payload_fit.json]

Per log, the payload's fit on the log's fitting part (the first 60 %, as the workflow takes it), under the
packaged model, one replay per log (one process):

* the nine Kufieta runs (data/kufieta-ur5: payload not stated, the tool centre point the flange): mass with the
  centre of mass unknown too, and mass at the flange (``--tcp-offset-m 0 0 0``);
* the NIST log (data/nist-ur5: payload 0.726 kg stated in its file name, 1.6 lb) declared unknown: mass and centre
  of mass, and mass at the reader's tool offset. The physics says 0.726 kg.

Prints one line per case and writes every record as JSON.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from ur5fault.discrepancy.model import WORKFLOW_SEED  # noqa: E402
from ur5fault.discrepancy.payload import fit_payload  # noqa: E402
from ur5fault.logs import read_nist, read_rtde  # noqa: E402
from ur5fault.twin.residuals import FIT_FRACTION, fit_samples  # noqa: E402

KUFIETA = sorted((REPO / "data" / "kufieta-ur5").glob("*.csv.gz"))
NIST = REPO / "data" / "nist-ur5" / "ur5testresult_halfspeed_payload1.6lb_1.csv.gz"


def cases():
    for path in KUFIETA:
        log = read_rtde(path)
        yield "mass and centre of mass", log
        yield "mass at the flange", dataclasses.replace(log, tcp_offset_m=(0.0, 0.0, 0.0))
    nist = read_nist(NIST)
    stated = nist.tcp_offset_m
    yield "mass and centre of mass", dataclasses.replace(nist, payload_kg=None, tcp_offset_m=None)
    yield "mass at the stated tool offset", dataclasses.replace(nist, payload_kg=None, tcp_offset_m=stated)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(REPO / "results" / "payload_fit.json"))
    args = ap.parse_args()
    out = []
    for what, log in cases():
        t = time.perf_counter()
        n = fit_samples(log.t_s.size - 1, FIT_FRACTION)
        rec = fit_payload(log, n, f"first {100 * FIT_FRACTION:.0f} %", seed=WORKFLOW_SEED)
        wall = time.perf_counter() - t
        free = rec.gains_free_kg
        print(f"{log.source} [{what}] {rec.line()} (r^2 {rec.r2_nuisance:.4f}; with current gains and offsets free "
              f"{free[0]:.3g} kg, 95 % {free[1]:.3g}..{free[2]:.3g}; {wall:.1f} s)", flush=True)
        out.append({"log": log.source, "case": what, "wall_s": wall, **rec.to_json()})
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=2, default=float))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

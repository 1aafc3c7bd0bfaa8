"""Two ``ur5fault discrepancy`` outputs compared: equal findings, numbers and model overlays, apart from timings.

    python bench/compare_summaries.py DIR_A DIR_B [--ignore-counts]

Compares ``summary.json`` (every key and value exactly, floats bit for bit) and ``model.yaml`` (byte for byte) of
the two output folders; the keys that time the run (``wall_s``, ``wall_s_by_stage``, ``bare_mj_step_us``,
``wall_over_mj_steps``) are left out, and with ``--ignore-counts`` also what the run simulated (``simulated_runs``,
``simulated_s``: an execution figure, changed by caching a replay instead of simulating it again).  Prints every
difference (path, value in A, value in B) and exits 1 when there is one, 0 when the outputs are equal.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

TIMING_KEYS = {"wall_s", "wall_s_by_stage", "bare_mj_step_us", "wall_over_mj_steps"}
COUNT_KEYS = {"simulated_runs", "simulated_s"}


def differences(a, b, path: str = "") -> list[tuple[str, object, object]]:
    """Every leaf where ``a`` and ``b`` differ (missing keys included), as (path, a's value, b's value)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append((f"{path}/{k}", a.get(k, "<missing>"), b.get(k, "<missing>")))
            else:
                out += differences(a[k], b[k], f"{path}/{k}")
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [(f"{path}[len]", len(a), len(b))]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in differences(x, y, f"{path}[{i}]")]
    same = a == b or (isinstance(a, float) and isinstance(b, float) and a != a and b != b)  # NaN equals NaN
    return [] if same and type(a) is type(b) else [(path, a, b)]


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    ap.add_argument("--ignore-counts", action="store_true", help="leave out simulated_runs and simulated_s too")
    args = ap.parse_args(argv)
    skip = TIMING_KEYS | (COUNT_KEYS if args.ignore_counts else set())
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (args.a, args.b))
    diffs = differences({k: v for k, v in sa.items() if k not in skip}, {k: v for k, v in sb.items() if k not in skip})
    for path, x, y in diffs:
        print(f"summary.json{path}: {x!r} != {y!r}")
    if (args.a / "model.yaml").read_bytes() != (args.b / "model.yaml").read_bytes():
        print("model.yaml differs")
        diffs.append(("model.yaml", None, None))
    for k in sorted(COUNT_KEYS & set(sa) & set(sb)):
        print(f"{k}: {sa[k]} -> {sb[k]}")
    print("equal" if not diffs else f"{len(diffs)} difference(s)")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""What flushing a stored file to disk costs: a campaign's per-run file written with and without ``fsync``.

    python bench/io_fsync.py [--n 200] [--columns 300] [--dir /tmp]

Writes ``--n`` one-row Parquet files of ``--columns`` float columns (about a run file of ``OUT/runs/``) with their
SHA-256 sidecars through ``ur5fault.util.io.write_parquet_atomic``, once as shipped (the temporary file and the
folder flushed) and once with the flush replaced by a no-op, and prints one JSON line: per file the wall and CPU
milliseconds of each.  Wall time depends on the disk and the machine's load; report the load beside it.
"""

from __future__ import annotations

import argparse
import json
import resource
import tempfile
import time

import pandas as pd

from ur5fault.util import io


def _per_file(df: pd.DataFrame, n: int, folder: str) -> tuple[float, float]:
    d = tempfile.mkdtemp(dir=folder)
    t0, c0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_SELF)
    for k in range(n):
        io.write_parquet_atomic(df, f"{d}/r{k}.parquet", checksum=True)
    c1 = resource.getrusage(resource.RUSAGE_SELF)
    cpu = c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime
    return (time.perf_counter() - t0) / n * 1e3, cpu / n * 1e3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--columns", type=int, default=300)
    ap.add_argument("--dir", default=tempfile.gettempdir())
    a = ap.parse_args()
    df = pd.DataFrame([{f"c{i}": float(i) for i in range(a.columns)}])
    _per_file(df, 20, a.dir)  # warm-up: imports, pyarrow's first write
    with_fsync = _per_file(df, a.n, a.dir)
    real = io._fsync
    io._fsync = lambda *args, **kw: None
    try:
        without = _per_file(df, a.n, a.dir)
    finally:
        io._fsync = real
    print(json.dumps({"n": a.n, "columns": a.columns, "wall_ms_with_fsync": round(with_fsync[0], 2),
                      "cpu_ms_with_fsync": round(with_fsync[1], 2), "wall_ms_without": round(without[0], 2),
                      "cpu_ms_without": round(without[1], 2)}))


if __name__ == "__main__":
    main()

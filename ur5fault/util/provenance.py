"""Provenance recorded beside results: the git revision of the source (when it is a checkout), the
installed version of every package ur5fault depends on, directly or not, and the machine's numerics (CPU and
BLAS kernel)."""

from __future__ import annotations

import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

_NAME = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)(\[[^\]]*\])?")


def package_version() -> str:
    """The installed distribution's version (pyproject.toml is its one source): ``ur5fault.__version__``."""
    try:
        return metadata.version("ur5fault")
    except metadata.PackageNotFoundError:  # a source tree on sys.path that was never installed
        return "0+unknown"


def git_revision(path: str | Path | None = None) -> dict[str, Any] | None:
    """``{"commit": sha, "dirty": bool}`` of the git checkout holding ``path`` (default: this
    package), or None when it is not in a checkout (an installed wheel) or git is absent."""
    where = Path(path) if path is not None else Path(__file__).resolve().parent
    try:
        sha = subprocess.run(["git", "-C", str(where), "rev-parse", "HEAD"], capture_output=True, text=True,
                             timeout=5, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(where), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=5, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return {"commit": sha, "dirty": bool(dirty)} if sha else None


def _requirements(dist: str, extras: bool) -> list[str]:
    out = []
    for req in metadata.requires(dist) or []:
        spec, _, marker = req.partition(";")
        if "extra" in marker and not extras:
            continue
        m = _NAME.match(spec)
        if m:
            out.append(m.group(1))
            if m.group(2):  # dask[distributed]: the extra's packages are dependencies too
                out.extend(x.strip() for x in m.group(2).strip("[]").split(",") if x.strip() == "distributed")
    return out


def dependency_versions(root: str = "ur5fault") -> dict[str, str | None]:
    """Installed versions of ``root``'s dependencies (its extras included) and theirs, by name;
    None for a direct dependency that is not installed (an extra).  Also ``python``."""
    versions: dict[str, str | None] = {"python": sys.version.split()[0]}
    todo = [(root, True)]
    seen = {root.lower()}
    while todo:
        dist, extras = todo.pop()
        try:
            names = _requirements(dist, extras)
        except metadata.PackageNotFoundError:
            continue
        for name in names:
            key = name.lower().replace("_", "-")
            if key in seen:
                continue
            seen.add(key)
            try:
                versions[key] = metadata.version(name)
            except metadata.PackageNotFoundError:
                if dist == root:  # an optional extra not installed; deeper ones are platform-specific
                    versions[key] = None
                continue
            todo.append((name, False))
    return dict(sorted(versions.items()))


def numerics() -> dict[str, Any]:
    """``{"cpu", "blas"}``: the CPU's model name (None where the platform does not say) and every BLAS library
    loaded in this process with the kernel it picked for this CPU (threadpoolctl's ``internal_api``,
    ``version``, ``architecture``; OpenBLAS picks by the CPU unless ``OPENBLAS_CORETYPE`` says).

    Since simulator revision 3 a run's simulation does not depend on them (:mod:`.portable`); the twin residual
    features' least-squares fits still go through LAPACK, and their estimates of columns that a motion nearly
    mixes differ in the last bits - or more, where the fit is ill-conditioned - from one kernel to another
    (docs/diagnostics.md, "The same campaign on another machine")."""
    from threadpoolctl import threadpool_info

    blas = [{k: lib.get(k) for k in ("internal_api", "version", "architecture")}
            for lib in threadpool_info() if lib.get("user_api") == "blas"]
    return {"cpu": _cpu_model(), "blas": blas}


def _cpu_model() -> str | None:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    import platform

    return platform.processor() or None

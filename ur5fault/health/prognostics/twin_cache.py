"""A file of the twin's failure radii (twin_boundary.failure_radii), so that a second ``prognose --twin`` on
the same fleet with the same twin simulates only the rays it has not seen.

A radius is a function of the ray (task, payload, temperature, direction, speed, guess) and of everything
the search runs: the resolved robot parameters of the twin's model (its overlay applied), the overlay's
effects, the wear law, the failure criterion, log period, duration, noise seed, drive and stepper, the search
constants and the package version.  Each entry is keyed by the SHA-256 of all of them, so a changed model,
setup or search can never read another's radius; the file holds only radii, written atomically with a
SHA-256 sidecar after every :data:`RAYS_PER_WRITE` rays simulated, so that a run stopped partway (Ctrl-C,
SIGTERM, a kill) keeps every group it finished and its rerun simulates only the rest.  A cache whose bytes
changed since it was written (a changed digit would be a wrong radius, read silently; a stop between the
sidecar's rename and the file's) is set aside with a warning and its radii simulated again.  A file that is
not shaped as a cache (a JSON object of exactly a version and radii: a manifest or a schema given by mistake,
or a cache damaged past parsing) is refused, never overwritten: the one case where a human removes it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ...errors import ConfigFileError
from ...util.io import OutputError, check_writable, checksum_path, verify_checksum, write_json_atomic
from . import twin_boundary as tb

_log = logging.getLogger(__name__)

#: format of the file (a change of the key's contents bumps it)
VERSION = 1
#: rays of one task whose radii are simulated together and then written to the file (assumption: a run stopped
#: partway loses at most this many rays' searches, ~10 simulated duty cycles each; the coarse stage of 8 rays,
#: len(COARSE) points each, still fills more than one lockstep batch of twin_boundary.BATCH runs)
RAYS_PER_WRITE = 8


def setup_key(setup: tb.TwinSetup) -> str:
    """SHA-256 of everything a radius depends on besides its ray."""
    from ... import __version__
    from ...campaign.identity import DRIVE, STEPPER
    from ...sim.params import load_params

    model = setup.model
    params = load_params(overrides=dict(model.params) if model else None)
    text = repr((VERSION, __version__, DRIVE, STEPPER, repr(params), repr(model.effects if model else ()),
                 repr(dataclasses.asdict(setup.wear)), repr(setup.failure), setup.log_period_s, setup.duration_s,
                 setup.seed, tb.COARSE, tb.BELOW, tb.ABOVE, tb.REFINE))
    return hashlib.sha256(text.encode()).hexdigest()


def ray_key(setup_sha: str, ray: tb.Ray) -> str:
    """Key of a plain ray (no friction rise of its own: that is in the setup's law, :meth:`RadiusCache.radii`)."""
    text = repr((setup_sha, ray.trajectory, ray.payload_kg, ray.temperature_C, ray.direction, ray.speed, ray.guess))
    return hashlib.sha256(text.encode()).hexdigest()


def _cache_shaped(raw: bytes) -> bool:
    """Whether ``raw`` is a JSON object of exactly a ``version`` and a mapping of ``radii`` (what :class:`RadiusCache`
    writes; its values are checked on reading)."""
    try:
        data = json.loads(raw)
    except ValueError:
        return False
    return isinstance(data, dict) and set(data) == {"version", "radii"} and isinstance(data["radii"], dict)


_AGAIN = "give --twin-cache a file this user may read and write"


class RadiusCache:
    """Radii by key in one JSON file (``path``); :meth:`radii` looks up, simulates the rest and saves."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.entries: dict[str, float] = {}
        if self.path.is_dir():  # never a cache: said now, before any ray is simulated
            raise OutputError(f"{self.path}: is a folder; {_AGAIN}")
        self._writable = False  # checked before the first ray is simulated (:meth:`radii`), not at its write
        try:
            raw = self.path.read_bytes() if self.path.is_file() else None
        except OSError as exc:
            raise ConfigFileError(f"{self.path}: cannot read ({exc.strerror or exc}); give --twin-cache a file "
                                  "this user may read and write") from None
        if raw is not None and not _cache_shaped(raw):  # another file (a manifest, a schema): never overwritten
            raise ConfigFileError(f"{self.path}: not a twin radius cache (a JSON object of a version and radii "
                                  "only) and would be overwritten; give --twin-cache a new file or a cache prognose "
                                  "wrote (an unreadable cache: remove it)")
        why = verify_checksum(self.path) if raw is not None and checksum_path(self.path).exists() else None
        if why:
            _log.warning("%s: %s; its radii are simulated again and the file rewritten", self.path, why)
        elif self.path.is_file():
            try:
                data = json.loads(raw)
            except (OSError, ValueError):
                raise ConfigFileError(f"{self.path}: not a twin radius cache (unreadable JSON); remove it") from None
            ours = checksum_path(self.path).exists()  # written by a RadiusCache (its sidecar verified above)
            if isinstance(data, dict) and data.get("version") != VERSION and ours:
                _log.warning("%s: a radius cache of version %s, this is %s; its radii are simulated again and the "
                             "file rewritten", self.path, data.get("version"), VERSION)
            elif not (isinstance(data, dict) and data.get("version") == VERSION
                      and isinstance(data.get("radii"), dict)):
                raise ConfigFileError(f"{self.path}: not a twin radius cache of version {VERSION}; remove it")
            else:
                try:
                    self.entries = {str(k): float(v) for k, v in data["radii"].items()}
                except (TypeError, ValueError):
                    raise ConfigFileError(f"{self.path}: a radius that is not a number; remove the cache") from None
        self.hits = self.misses = 0

    def missing(self, setup: tb.TwinSetup, rays: Sequence[tb.Ray]) -> int:
        """How many of ``rays`` :meth:`radii` would simulate (not in the cache)."""
        return sum(k not in self.entries for k in self._keys(setup, rays))

    def radii(self, setup: tb.TwinSetup, rays: Sequence[tb.Ray], progress=None) -> NDArray:
        """The failure radius of each ray: from the cache, else simulated (``progress``: as
        :func:`.twin_boundary.failure_radii`'s, over the simulated rays alone) and written to it."""
        keys = self._keys(setup, rays)
        todo = [i for i, k in enumerate(keys) if k not in self.entries]
        self.hits += len(rays) - len(todo)
        if todo and not self._writable:  # a complete cache in a read-only place is read, never written
            try:
                check_writable(self.path)
            except OutputError as exc:
                raise OutputError(f"{exc}; {_AGAIN}") from None
            self._writable = True
        for group in _groups(rays, todo):
            new = tb.failure_radii(setup, [rays[i] for i in group], progress)
            self.entries.update({keys[i]: float(v) for i, v in zip(group, new, strict=True)})
            self.misses += len(group)
            self._write()
        return np.array([self.entries[k] for k in keys])

    def _keys(self, setup: tb.TwinSetup, rays: Sequence[tb.Ray]) -> list[str]:
        # a ray with its own friction rise is keyed as a plain ray under the law it runs (so the radius depends
        # on the law simulated, not on the constants the twin was told and did not use)
        shas: dict[tuple, str] = {}
        keys = []
        for r in rays:
            law = r.law(setup.wear)
            ident = dataclasses.astuple(law)
            if ident not in shas:
                shas[ident] = setup_key(dataclasses.replace(setup, wear=law))
            keys.append(ray_key(shas[ident], dataclasses.replace(r, friction_per_deg=None, friction_per_Mcycle=None)))
        return keys

    def _write(self) -> None:
        # Python's JSON: an infinite radius (the ray's run stopped: failed) is not "no value", and only this class
        # reads the file
        write_json_atomic(self.path, {"version": VERSION, "radii": self.entries}, checksum=True, strict=False)


def _groups(rays: Sequence[tb.Ray], todo: Sequence[int]) -> list[list[int]]:
    """``todo`` (indices into ``rays``) in groups of at most :data:`RAYS_PER_WRITE` rays of one task, in order."""
    by_task: dict[str, list[int]] = {}
    for i in todo:
        by_task.setdefault(rays[i].trajectory, []).append(i)
    return [g[k : k + RAYS_PER_WRITE] for g in by_task.values() for k in range(0, len(g), RAYS_PER_WRITE)]

"""One recording counts once: logs given to one command (fitted, held out, a baseline and the logs judged against
it) that hold the same samples, whole or as a part cut out of one recording, are refused with one line
(:func:`refuse_same_samples`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..errors import ParameterError
from .measured import MeasuredLog

#: two recorded logs sharing at least this many rows taken in motion (and this share of the shorter one's) are parts
#: of one recording: a row holds every joint's measured position and current, which two recordings of a moving arm
#: never repeat (at rest, a coarse log may)
SHARED_ROWS_MIN, SHARED_ROWS_SHARE = 25, 0.01


def _moving_rows(log: MeasuredLog) -> NDArray:
    """The log's distinct logged rows where some joint's target moves, each as one opaque value: its measured
    positions and currents, bit for bit (not its time, which a cut may restart)."""
    moving = np.zeros(log.t_s.size, dtype=bool)
    moving[1:] = (np.diff(log.q_target_rad, axis=0) != 0.0).any(axis=1)
    rows = np.ascontiguousarray(np.hstack([log.q_actual_rad, log.current_A])[log.logged_rows() & moving],
                                dtype=np.float64)
    return np.unique(rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel())


def refuse_same_samples(groups: Sequence[tuple[str, Sequence[MeasuredLog]]]) -> None:
    """Logs holding the same samples (one recording under two names or paths, or a part of it cut out: fitted
    twice, or scored as held out on the samples it was fitted on) refused with one line; ``groups``: ``(role,
    logs)``, e.g. ``("fitted", logs)``, ``("held out", held)``."""
    seen: dict[str, tuple[str, str]] = {}
    for role, logs in groups:
        for log in logs:
            sha = log.content_sha256()
            if sha in seen:
                name, other = seen[sha]
                both = f"{role} twice" if other == role else f"both {other} and {role}"
                what = f"{log.source} is {both}" if name == log.source else \
                    f"{log.source} and {name} hold the same samples ({both})"
                raise ParameterError(f"{what}: one recording counts once; give it once")
            seen[sha] = (log.source, role)
    # parts of one recording: recorded logs only (simulated ones of one noise seed repeat each other's samples
    # wherever their effects have not acted yet: the seed's, not a cut)
    tagged = [(role, log) for role, logs in groups for log in logs if not log.simulated]
    rows = [_moving_rows(log) for _, log in tagged] if len(tagged) > 1 else []
    for i, (role_a, a) in enumerate(tagged):
        for k, (role_b, b) in enumerate(tagged[i + 1:], start=i + 1):
            shared = np.intersect1d(rows[i], rows[k], assume_unique=True).size
            if shared >= max(SHARED_ROWS_MIN, SHARED_ROWS_SHARE * min(rows[i].size, rows[k].size)):
                both = f"both {role_a}" if role_a == role_b else f"{role_a} and {role_b}"
                raise ParameterError(f"{b.source} and {a.source} ({both}) share {shared} rows in motion (of "
                                     f"{rows[k].size} and {rows[i].size}): parts of one recording; give each sample "
                                     "once")

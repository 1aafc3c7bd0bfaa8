"""One progress implementation for every long task (simulate, campaigns, the discrepancy search, the twin):
tqdm's ``auto`` flavour, which draws a widget in a notebook and a bar on a terminal; when the output is not
interactive (``nohup ... > log 2>&1``, a CI job, a notebook's ``!ur5fault`` cell, a cluster job) sparse plain
lines instead (:class:`LineBar`: no carriage returns, no ANSI codes, so a log file stays readable); nothing when
the caller asks for quiet (``--quiet``, ``enabled=False``).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import Any, TextIO

#: tqdm's format for a bar whose count is a share or counted in parts (simulate's fraction of a run, the
#: discrepancy's stages, the twin's rays in thirds): the share alone, not a float count such as 3.3333333/16
PERCENT_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}"
#: seconds between two plain progress lines off a terminal: a job of minutes shows it is moving, one of hours
#: writes a few hundred lines, not one per update
LINE_INTERVAL_S = 30.0


def bar(total: float, desc: str, unit: str = "it", enabled: bool = True, *, file: TextIO | None = None,
        clock: Callable[[], float] | None = None, **kwargs: Any):
    """A progress bar: tqdm on a terminal or in a notebook, a :class:`LineBar` on any other stream (``file``,
    default stderr); ``enabled=False`` (``--quiet``) gives a silent tqdm.  ``clock``: the line bar's clock (default
    ``time.monotonic``; tests);
    ``kwargs``: tqdm's (``bar_format``, ...), which a line bar does not need."""
    from tqdm.auto import tqdm

    if enabled and not _interactive(file):
        return LineBar(total, desc, unit, file=file, clock=clock)
    if file is not None:
        kwargs["file"] = file
    # disable=None: interactive here, but tqdm still checks its stream (a terminal) itself, as before
    return tqdm(total=total, desc=desc, unit=unit, disable=None if enabled else True, dynamic_ncols=True,
                **kwargs)


def _interactive(file: TextIO | None) -> bool:
    """Whether tqdm draws here: a notebook kernel (its widget), or a stream that is a terminal."""
    from tqdm.autonotebook import tqdm as auto
    from tqdm.std import tqdm as std

    if auto is not std and file is None:  # tqdm.auto chose the notebook widget
        return True
    stream = sys.stderr if file is None else file
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


def _number(x: float) -> str:
    """A count: ``12``, or ``1.6`` of a count in parts (the twin's rays, the discrepancy's stages), rounded down
    (15.96 of 16 reads 15.9, not a finished 16)."""
    r = math.floor(10 * float(x) + 1e-9) / 10
    return f"{r:.0f}" if r.is_integer() else f"{r:.1f}"


def _percent(n: float, total: float) -> int:
    """``n`` of ``total`` in whole per cent, 99 at most until it is done (99.6 % is not a finished 100)."""
    pct = round(100 * n / total)
    return min(pct, 99) if n < total else pct


def clock_text(seconds: float) -> str:
    """``0:41``, ``12:05``, ``1:02:03``."""
    s = max(0, round(seconds))
    h, rest = divmod(s, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class LineBar:
    """The part of tqdm's interface the commands use (``n``, ``total``, ``update``, ``refresh``, ``reset``,
    ``set_description``, ``close``, ``with``), written as a plain line such as
    ``campaign: 12/31 runs (39 %), 0:41 elapsed, about 1:03 left`` at most every :data:`LINE_INTERVAL_S`
    seconds and once more when closed."""

    def __init__(self, total: float, desc: str, unit: str = "it", *, file: TextIO | None = None,
                 clock: Callable[[], float] | None = None) -> None:
        self.total, self.desc, self.unit = total, desc, unit
        self.file, self.clock = file, clock or time.monotonic
        self.n: float = 0
        #: the count already done when counting started (a resumed campaign's runs on disk): not in the rate
        self.initial: float = 0
        self.start = self.last = self.clock()
        self.closed = False
        self.written = ""
        #: the count is a share of one (:func:`fraction_callback`: simulate's run), written as a percentage alone
        self.fraction = False
        #: a time left from the rate so far (False where the count's rate says nothing of the rest: a life campaign's
        #: units finish when they fail, all in the last rounds)
        self.eta = True

    def line(self, final: bool = False) -> str:
        n, total = self.n, self.total
        if total and math.isclose(n, total, rel_tol=1e-9):  # a count in parts adds up to the total in float
            n = total
        if self.fraction:  # a share of one run (simulate): the share alone
            count = f"{_percent(n, 1.0)} %"
        else:
            unit = self.unit if self.unit == "it" or self.unit.endswith("s") else self.unit + "s"
            count = f"{_number(n)}/{_number(total)} {unit}" + (f" ({_percent(n, total)} %)" if total else "")
        elapsed = self.clock() - self.start
        text = f"{self.desc}: {count}, {clock_text(elapsed)} elapsed"
        done = n - self.initial
        if self.eta and not final and total and 0 < done and n < total:
            text += f", about {clock_text((total - n) * elapsed / done)} left"
        return text

    def _write(self, final: bool = False) -> None:
        text = self.line(final)
        if final and text == self.written:  # the line just written already said it all
            return
        stream = sys.stderr if self.file is None else self.file
        stream.write(text + "\n")
        stream.flush()
        self.last, self.written = self.clock(), text

    def refresh(self) -> None:
        """A line if :data:`LINE_INTERVAL_S` has passed since the last (or the start)."""
        if not self.closed and self.clock() - self.last >= LINE_INTERVAL_S:
            self._write()

    def update(self, k: float = 1) -> None:
        self.n += k
        self.refresh()

    def reset(self, total: float | None = None) -> None:
        self.n, self.initial = 0, 0
        if total is not None:
            self.total = total
        self.start = self.last = self.clock()

    def set_description(self, desc: str, refresh: bool = True) -> None:
        self.desc = desc
        if refresh:
            self.refresh()

    def close(self) -> None:
        """The final line (once; not again if the last line written was it)."""
        if not self.closed:
            self._write(final=True)
            self.closed = True

    def __enter__(self) -> LineBar:
        return self

    def __exit__(self, exc_type, *exc) -> None:
        if exc_type is None:
            self.close()
        else:  # the error's own line says why it stopped, not a count before it
            self.closed = True


def fraction_callback(pbar) -> Callable[[float], None]:
    """Adapter for :meth:`ur5fault.sim.engine.Simulator.run`'s ``progress(fraction)`` on a bar of total 1 (a line
    bar then writes the share alone)."""
    if isinstance(pbar, LineBar):
        pbar.fraction = True

    def update(frac: float) -> None:
        pbar.n = round(min(max(frac, 0.0), 1.0), 4)
        pbar.refresh()

    return update


class CampaignProgress:
    """Reports finished runs of a campaign (``unit``: what it counts, a life campaign's units): to a bar
    (:func:`bar`), to a callback ``(done, total, eta_s)``, or nowhere. ``eta=False``: no time left from the rate of
    the count (the callback gets NaN; :meth:`describe` may say a bound instead)."""

    def __init__(self, progress: bool | Callable[[int, int, float], None], total: int, unit: str = "run",
                 eta: bool = True) -> None:
        self.total, self.eta = total, eta
        self.callback = progress if callable(progress) else None
        plural = unit if unit.endswith("s") else unit + "s"
        self.bar = None if self.callback else bar(
            total, "campaign", unit, enabled=bool(progress),
            **({} if eta else {"bar_format": "{desc}: {n_fmt}/{total_fmt} " + plural + " |{bar}| {elapsed}"}))
        if isinstance(self.bar, LineBar):
            self.bar.eta = eta
        self.start_done: int | None = None

    def describe(self, text: str) -> None:
        """The bar's description: ``campaign (TEXT)``."""
        if self.bar is not None:
            self.bar.set_description(f"campaign ({text})")

    def __call__(self, done: int, elapsed_s: float) -> None:
        if self.start_done is None:
            self.start_done = done
        if self.callback is not None:
            new = done - self.start_done
            eta = (self.total - done) * elapsed_s / new if new > 0 and self.eta else float("nan")
            self.callback(done, self.total, eta)
        elif self.bar is not None:
            if self.bar.n == 0 and done and self.start_done == done:
                self.bar.reset(total=self.total)
                if isinstance(self.bar, LineBar):
                    self.bar.initial = done  # its "left" from this invocation's rate, not the stored runs'
                self.bar.update(done)  # runs already on disk from an earlier invocation
            else:
                self.bar.update(done - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def campaign_progress(progress: bool | Callable[[int, int, float], None], total: int,
                      unit: str = "run", eta: bool = True) -> CampaignProgress:
    return CampaignProgress(progress, total, unit, eta)

"""Progress off a terminal (``nohup ... > log 2>&1``, CI, a notebook's ``!`` cell): sparse plain lines on the
stream, rate-limited to one per LINE_INTERVAL_S, a final line on close; nothing with ``enabled=False``."""

from __future__ import annotations

import io

import pytest

from ur5fault.util import progress


class Clock:
    """A fake clock the test moves by hand."""

    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


class TTY(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_non_terminal_stream_gets_plain_lines_with_the_counts():
    out, clock = io.StringIO(), Clock()
    with progress.bar(31, "campaign", "run", file=out, clock=clock) as b:
        assert isinstance(b, progress.LineBar)
        clock.t += 41
        b.update(12)
    lines = out.getvalue().splitlines()
    assert lines[0] == "campaign: 12/31 runs (39 %), 0:41 elapsed, about 1:05 left"  # 19 runs at 41/12 s
    assert lines[-1] == "campaign: 12/31 runs (39 %), 0:41 elapsed"  # the final line on close, no guess
    assert "\r" not in out.getvalue() and "\x1b" not in out.getvalue()


def test_lines_are_rate_limited_and_the_final_line_comes_on_close():
    out, clock = io.StringIO(), Clock()
    b = progress.bar(100, "monitor: logs replayed", "log", file=out, clock=clock)
    for _ in range(100):  # one update a second: 100 s, so 3 lines in the interval and the final one
        clock.t += 1
        b.update(1)
    assert out.getvalue().count("\n") == int(100 // progress.LINE_INTERVAL_S)
    b.close()
    b.close()  # once
    lines = out.getvalue().splitlines()
    assert len(lines) == int(100 // progress.LINE_INTERVAL_S) + 1
    assert lines[0].startswith(f"monitor: logs replayed: {int(progress.LINE_INTERVAL_S)}/100 logs (")
    assert lines[-1] == "monitor: logs replayed: 100/100 logs (100 %), 1:40 elapsed"


def test_no_line_before_the_interval_only_the_final_one():
    out, clock = io.StringIO(), Clock()
    b = progress.bar(4, "benchmark: features", "stage", file=out, clock=clock)
    clock.t += progress.LINE_INTERVAL_S - 1
    b.update(1)
    b.set_description("benchmark: training")
    b.update(1)
    assert out.getvalue() == ""
    b.close()
    assert out.getvalue() == "benchmark: training: 2/4 stages (50 %), 0:29 elapsed\n"


def test_a_fraction_bar_reads_as_a_share():
    out, clock = io.StringIO(), Clock()
    b = progress.bar(1.0, "simulate", "run", file=out, clock=clock, bar_format="{desc}")  # tqdm's kwargs: ignored
    update = progress.fraction_callback(b)
    clock.t += 40
    update(0.25)
    clock.t += 80
    update(1.0)
    b.close()
    assert out.getvalue().splitlines() == ["simulate: 25 %, 0:40 elapsed, about 2:00 left",
                                           "simulate: 100 %, 2:00 elapsed"]  # the final line not twice


def test_enabled_false_writes_nothing():
    out, clock = io.StringIO(), Clock()
    b = progress.bar(10, "campaign", "run", enabled=False, file=out, clock=clock)
    assert not isinstance(b, progress.LineBar)
    clock.t += 10 * progress.LINE_INTERVAL_S
    b.update(5)
    b.close()
    assert out.getvalue() == ""


def test_default_stream_is_stderr_and_a_terminal_keeps_tqdm(monkeypatch, capsys):
    monkeypatch.setattr(progress, "LINE_INTERVAL_S", 0.0)
    b = progress.bar(3, "campaign", "run")  # pytest's captured stderr is not a terminal
    b.update(3)
    b.close()
    err = capsys.readouterr().err
    assert err.splitlines()[0].startswith("campaign: 3/3 runs (100 %), 0:00 elapsed")
    assert "\r" not in err and "\x1b" not in err
    tty = TTY()
    t = progress.bar(3, "campaign", "run", file=tty)
    assert not isinstance(t, progress.LineBar)  # tqdm on a terminal, as before
    t.update(3)
    t.close()
    assert "\r" in tty.getvalue() and "3/3" in tty.getvalue()


@pytest.mark.parametrize("stored", [0, 10])
def test_campaign_progress_counts_this_invocation_for_what_is_left(monkeypatch, capsys, stored):
    clock = Clock()
    monkeypatch.setattr(progress.time, "monotonic", clock)
    report = progress.campaign_progress(True, 30)
    report(stored, 0.0)  # runs already on disk (a resumed campaign)
    clock.t += 60
    report(stored + 5, 60.0)  # five runs in this invocation's minute
    report.close()
    lines = capsys.readouterr().err.splitlines()
    left = (30 - stored - 5) * 60 / 5
    assert lines[0] == (f"campaign: {stored + 5}/30 runs ({100 * (stored + 5) / 30:.0f} %), 1:00 elapsed, "
                        f"about {int(left // 60)}:{int(left % 60):02d} left")
    assert lines[-1] == f"campaign: {stored + 5}/30 runs ({100 * (stored + 5) / 30:.0f} %), 1:00 elapsed"


def test_quiet_campaign_progress_writes_nothing(capsys):
    report = progress.campaign_progress(False, 30)
    report(3, 1.0)
    report.close()
    assert capsys.readouterr().err == ""


def test_an_error_inside_the_bar_leaves_its_own_line_alone():
    out = io.StringIO()
    with pytest.raises(ValueError), progress.bar(3, "diagnose: logs replayed", "log", file=out) as b:
        b.update(1)
        raise ValueError("the one line the command prints")
    assert out.getvalue() == ""


def test_a_count_in_parts_reads_with_one_decimal():
    out, clock = io.StringIO(), Clock()
    b = progress.bar(16, "prognose: twin boundary, calibration", "ray", file=out, clock=clock)
    clock.t += 37
    b.update(1.6111)
    assert out.getvalue() == ("prognose: twin boundary, calibration: 1.6/16 rays (10 %), 0:37 elapsed, "
                              "about 5:30 left\n")  # 14.39 rays at 37 s / 1.61


def test_parts_that_add_up_to_the_total_end_without_a_time_left():
    """The twin's 16 rays as 3 stages of 8 batches, 2/3 of a ray each: in float a hair short of 16 (the real
    log read '16/16 rays (100 %), 1:54 elapsed, about 0:00 left' and then the final line again)."""
    out, clock = io.StringIO(), Clock()
    b = progress.bar(16, "prognose: twin boundary, calibration", "ray", file=out, clock=clock)
    for _ in range(24):
        clock.t += 10
        b.update(16 / 3 / 8)
    b.close()
    lines = out.getvalue().splitlines()
    assert lines[-1] == "prognose: twin boundary, calibration: 16/16 rays (100 %), 4:00 elapsed"
    assert lines.count(lines[-1]) == 1 and all("left" not in ln for ln in lines if "16/16" in ln)


def test_nothing_reads_as_done_before_it_is():
    """15.96 of 16 rays read '16/16 rays (100 %) ... about 0:01 left' (a review's catch): the count is rounded down
    and the share held at 99 % until the total is reached."""
    out, clock = io.StringIO(), Clock()
    b = progress.bar(16, "prognose: twin boundary, test units", "ray", file=out, clock=clock)
    clock.t += 60
    b.update(15.96)
    assert out.getvalue() == "prognose: twin boundary, test units: 15.9/16 rays (99 %), 1:00 elapsed, about 0:00 left\n"


def test_a_count_of_one_reads_as_a_count_not_a_share():
    """Only simulate's fraction of a run (fraction_callback) reads as a share: a count whose total is 1 (diagnose
    replaying one log) read '100 %' where '1/1 logs' was meant."""
    out, clock = io.StringIO(), Clock()
    b = progress.bar(1, "diagnose: logs replayed", "log", file=out, clock=clock)
    b.update(1)
    b.close()
    assert out.getvalue() == "diagnose: logs replayed: 1/1 logs (100 %), 0:00 elapsed\n"


def test_the_benchmark_stages_write_no_count_before_an_error(capsys):
    """`benchmark` failing inside its stages printed 'benchmark: a: 0/2 stages (0 %), ...' before its one error
    line (a review's catch): the stages close their bar as the bar's own `with` does."""
    from ur5fault.health.diagnostics.run import _Stages

    with pytest.raises(ValueError), _Stages(True, "features", "training"):
        raise ValueError("the one line the command prints")
    assert capsys.readouterr().err == ""
    with _Stages(True, "features", "training") as stages:
        stages.next()
    assert capsys.readouterr().err == "benchmark: training: 1/2 stages (50 %), 0:00 elapsed\n"

"""A command's result files written as one set (ur5fault/util/results.py): a run stopped between its files leaves
a folder marked incomplete, which the next run replaces without a person; two writers never share a folder; a
complete result written meanwhile by another run is not overwritten silently."""

from __future__ import annotations

import logging
import subprocess
import sys

import pytest

from ur5fault.util.io import OutputError
from ur5fault.util.lock import LOCK_NAME, FolderLockedError, Lock
from ur5fault.util.results import INCOMPLETE_MARK, check_new_output, present, result_folder, said_written

RESULTS = ("report.md", "summary.json")


def test_a_finished_set_leaves_no_mark_and_no_lock_and_is_an_earlier_result(tmp_path):
    out = tmp_path / "out"
    with result_folder(out, RESULTS) as folder:
        assert (folder / INCOMPLETE_MARK).exists() and (folder / LOCK_NAME).exists()
        for name in RESULTS:
            (folder / name).write_text("x")
    assert sorted(p.name for p in out.iterdir()) == sorted(RESULTS)
    with pytest.raises(OutputError, match="an earlier result is there; give --replace"):
        check_new_output(out, folder=True, results=RESULTS)


def test_a_set_cut_short_is_marked_and_replaced_by_the_next_run_with_a_warning(tmp_path, caplog):
    """As a SIGTERM (an exception through the block) or a kill between two files: summary.json was written, the report
    not. The next run's check at its start refused it as "an earlier result" until a person deleted it."""
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt), result_folder(out, RESULTS) as folder:
        (folder / "summary.json").write_text("x")
        raise KeyboardInterrupt
    assert (out / INCOMPLETE_MARK).exists() and not (out / LOCK_NAME).exists()
    with caplog.at_level(logging.WARNING, logger="ur5fault"):
        assert check_new_output(out, folder=True, results=RESULTS) == out
    assert any("stopped while writing it" in r.getMessage() and "replacing it" in r.getMessage()
               for r in caplog.records), caplog.records
    with result_folder(out, RESULTS, replace=False) as folder:  # the check again, under the lock, passes too
        for name in RESULTS:
            (folder / name).write_text("y")
    assert not (out / INCOMPLETE_MARK).exists()


def test_a_set_killed_mid_write_is_replaced_by_the_next_run(tmp_path):
    """SIGKILL of the writer between two files, in another process: the mark and the lock file stay, the lock is not
    held (the kernel released it), and the next run takes the folder."""
    out = tmp_path / "out"
    code = (f"import os, signal\nfrom ur5fault.util.results import result_folder\n"
            f"with result_folder({str(out)!r}, {RESULTS!r}) as f:\n"
            f"    (f / 'summary.json').write_text('x')\n"
            f"    os.kill(os.getpid(), signal.SIGKILL)\n")
    r = subprocess.run([sys.executable, "-c", code], timeout=120)
    assert r.returncode == -9
    assert (out / INCOMPLETE_MARK).exists() and (out / "summary.json").exists() and (out / LOCK_NAME).exists()
    check_new_output(out, folder=True, results=RESULTS)  # not refused
    with result_folder(out, RESULTS, replace=False) as folder:
        (folder / "report.md").write_text("y")
    assert not (out / INCOMPLETE_MARK).exists() and not (out / LOCK_NAME).exists()


def test_a_folder_being_written_is_refused_not_taken_for_one_cut_short(tmp_path):
    out = tmp_path / "out"
    with result_folder(out, RESULTS):
        with pytest.raises(FolderLockedError, match="another ur5fault process is writing its result there"):
            check_new_output(out, folder=True, results=RESULTS)
        with pytest.raises(FolderLockedError, match="another ur5fault process is writing this folder"):
            with result_folder(out, RESULTS):
                pass


def test_a_result_written_by_another_run_meanwhile_is_not_overwritten(tmp_path):
    """Two runs into one --out started together: each checked an empty folder at its start, and the second to finish
    overwrote the first's result, both saying "wrote". Checked again under the lock, the second is refused."""
    out = tmp_path / "out"
    check_new_output(out, folder=True, results=RESULTS)  # run A's check at its start: nothing there
    with result_folder(out, RESULTS, replace=False) as folder:  # run B writes its result in the meantime
        (folder / "report.md").write_text("B")
    with pytest.raises(OutputError, match="an earlier result is there"):
        with result_folder(out, RESULTS, replace=False):  # run A, at its end
            pytest.fail("A wrote over B's result")
    assert (out / "report.md").read_text() == "B"
    with result_folder(out, RESULTS, replace=True) as folder:  # --replace: A's result replaces it, as asked
        (folder / "report.md").write_text("A")
    assert (out / "report.md").read_text() == "A"


def test_the_lock_names_its_writer(tmp_path):
    with Lock(tmp_path), pytest.raises(FolderLockedError, match="another campaign is writing this folder"):
        with Lock(tmp_path):
            pass


def test_one_output_file_is_written_by_one_process_at_a_time(tmp_path):
    """Two `identify --out same.yaml` started together both checked an empty place, both wrote, both said so (5 of 12
    trials). The file's own lock, held while the second checks, refuses it, and the lock file goes with the holder."""
    from ur5fault.util.results import file_lock

    out = tmp_path / "fit" / "p.yaml"
    with file_lock(out):
        with pytest.raises(FolderLockedError, match=r"p.yaml: another ur5fault process is writing it \(host"):
            with file_lock(out):
                pass
        with file_lock(tmp_path / "fit" / "other.yaml"):  # another file beside it: its own lock
            pass
    assert not (out.parent / ".p.yaml.lock").exists()


def test_a_set_cut_short_is_removed_before_another_commands_set(tmp_path):
    """monitor into a folder a killed discrepancy left: it said "replacing it", wrote its files beside the killed
    run's model.yaml and summary.json and removed the mark, so those passed for a result. The files the cut-short
    writer named in its mark are removed first; a user's own file in the folder stays."""
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt), result_folder(out, ("report.md", "model.yaml", "summary.json")) as f:
        (f / "model.yaml").write_text("partial")
        (f / "summary.json").write_text("partial")
        raise KeyboardInterrupt
    (out / "notes.txt").write_text("mine")
    with result_folder(out, ("monitor.json", "baseline.json", "report.md")) as f:
        (f / "monitor.json").write_text("{}")
    assert sorted(p.name for p in out.iterdir()) == ["monitor.json", "notes.txt"]


def test_taking_over_a_cut_short_set_spares_what_it_did_not_name(tmp_path):
    """The review of the change: the takeover removed every temporary file (another command writing into the folder
    without its lock, identify --out OUT/x.yaml, lost its write), a whole `models/` folder the cut-short benchmark
    named (a user's files in it too), and skipped the earlier-result check for files the mark did not name."""
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt), result_folder(out, ("report.md", "models")) as f:
        (f / "models").mkdir()
        (f / "models" / "mine.txt").write_text("a user's")
        raise KeyboardInterrupt
    (out / ".x.yaml.abc.tmp").write_text("identify writing")  # another command's file being written, seconds old
    (out / "monitor.json").write_text("{}")  # a complete result of another command, not in the mark
    with pytest.raises(OutputError, match="monitor.json: an earlier result is there"):
        check_new_output(out, folder=True, results=("monitor.json", "report.md"))
    with result_folder(out, ("summary.json",), replace=False) as f:  # a command that writes none of them
        (f / "summary.json").write_text("{}")
    assert (out / ".x.yaml.abc.tmp").exists() and (out / "models" / "mine.txt").exists()


def test_a_file_of_a_set_cut_short_is_not_read_as_a_result(tmp_path):
    """`--model DIR/model.yaml` of a discrepancy run stopped between its files (the file may be the earlier run's,
    the new summary beside it) and `--baseline-stats` of a monitor run stopped so: refused in one line, until the
    command that writes them has run again; a file the mark does not name is read as it is."""
    from ur5fault.config import Overlay
    from ur5fault.errors import StoredResultError
    from ur5fault.health.monitoring.baseline import Baseline

    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt), result_folder(out, ("model.yaml", "baseline.json")) as folder:
        (folder / "model.yaml").write_text("params: {}\n")
        raise KeyboardInterrupt
    (out / "identified.yaml").write_text("params: {}\n")  # identify's overlay saved into the same folder
    assert Overlay.load(out / "identified.yaml").params == {}
    with pytest.raises(StoredResultError, match=r"model.yaml: part of a result cut short .*run the command that "
                                                r"wrote it again"):
        Overlay.load(out / "model.yaml")
    with pytest.raises(StoredResultError, match=r"baseline.json: part of a result cut short .*--baseline-logs"):
        Baseline.load(out / "baseline.json")
    with result_folder(out, ("model.yaml",)) as folder:
        with pytest.raises(StoredResultError, match="another ur5fault process is writing its result there now"):
            Overlay.load(folder / "model.yaml")
        (folder / "model.yaml").write_text("params: {}\n")
    assert Overlay.load(out / "model.yaml").params == {}


def test_the_closing_line_says_replaced_for_the_files_that_were_there(tmp_path):
    """`identify --replace` said "wrote" over a file the user had, where simulate, show and plot said "replaced":
    every command's closing line says, in the order written, which files it replaced and which it wrote."""
    a, b, c = (tmp_path / n for n in ("a.yaml", "b.json", "c.md"))
    b.write_text("mine\n")
    earlier = present([a, b, c])
    assert earlier == {b}
    assert said_written([a, b, c], earlier, " in 3 s") == f"wrote {a}; replaced {b}; wrote {c} in 3 s"
    assert said_written([b, a, c], earlier) == f"replaced {b}; wrote {a}, {c}"
    assert said_written([str(a), str(c)]) == f"wrote {a}, {c}"  # nothing there before
    assert said_written([a, b], {a, b}) == f"replaced {a}, {b}"


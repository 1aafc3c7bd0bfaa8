"""A command's result files written into their folder as one set: one writer at a time, and a result cut
short by a crash known as such.

``identify``'s overlay aside, a command's result is several files (``discrepancy``: ``report.md``,
``model.yaml``, ``summary.json`` and figures; ``monitor``: ``monitor.json``, ``baseline.json``, ...).  Each file
is written atomically (:mod:`ur5fault.util.io`), but a process stopped between two of them (SIGKILL, SIGTERM, a
full disk) left a folder of complete-looking files without the rest, which the next run refused as "an earlier
result" until a person deleted it.  :func:`result_folder` writes the set:

- under the folder's lock (:class:`ur5fault.util.lock.Lock`): two processes never write one folder at once;
- with the mark ``OUT/.incomplete`` from before the first file to after the last: a folder holding the mark and
  no lock holder holds a result cut short, which :func:`check_new_output` does not count as an
  earlier result (the next run replaces it and says so) and whose files no reader should take as a result;
- after checking again, under the lock, that no other process wrote a complete result there since the command
  started (unless ``replace``): two runs into one ``--out`` started together overwrote each other silently.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import socket
from collections.abc import Collection, Iterable, Iterator, Sequence
from pathlib import Path

from ..errors import StoredResultError
from .io import OutputError, check_writable, remove_stale_temporaries, write_text_atomic
from .lock import FolderLockedError, Lock, lock_holder

#: the option every command writing a result takes to replace an earlier result in the place it writes to
REPLACE_OPTION = "--replace"
#: the mark a result folder holds while its files are written (:func:`result_folder`): left
#: behind, the files beside it are a result cut short
INCOMPLETE_MARK = ".incomplete"


def check_new_output(path: str | Path, *, folder: bool = False, results: tuple[str, ...] = (),
                     replace: bool = False, suffixes: tuple[str, ...] = (), option: str = "--out",
                     note: bool = True, holding_lock: bool = False, default_place: bool = False) -> Path:
    """:func:`check_writable`, then refuse to lose an earlier result silently: a file ``path`` that exists, or a
    ``folder`` holding any of the file names ``results`` (its own result files; other files are left alone), is
    refused unless ``replace``.  A folder still holding :data:`INCOMPLETE_MARK` holds a result cut short (its
    writer stopped between its files): not an earlier result, replaced (said in a warning when ``note``), unless a
    process holds the folder's lock now (it is being written: refused); ``holding_lock``: the caller holds it.
    ``suffixes``: the file name must end with one of them (case-insensitive).  Missing parent folders are fine: the
    writers create them.  ``default_place``: the user gave no ``option``, ``path`` is where the command writes without
    it (the refusal says so, and does not name ``option`` as given)."""
    path = check_writable(path, folder=folder)
    if suffixes and path.suffix.lower() not in suffixes:
        raise OutputError(f"{option} {path}: unknown file type {path.suffix or '(no suffix)'!r}; give a "
                          f"{' or '.join(suffixes)} file")
    if replace:
        return path
    cut_short: set[str] = set()
    if folder and (path / INCOMPLETE_MARK).exists():
        holder = None if holding_lock else lock_holder(path)
        if holder is not None:  # not cut short: being written now
            raise FolderLockedError(f"{path}: another ur5fault process is writing its result there"
                                    + (f" (host {holder[0]}, pid {holder[1]})" if isinstance(holder, tuple) else "")
                                    + f"; wait for it or choose another {option}")
        cut_short = set(_marked_results(path / INCOMPLETE_MARK) or results)  # a mark of before it named them: all
        if note:
            logging.getLogger(__name__).warning(
                "%s holds the result of a run stopped while writing it (%s is still there): replacing it", path,
                INCOMPLETE_MARK)
    earlier = [path] if not folder and path.exists() else [path / n for n in results
                                                           if (path / n).exists() and n not in cut_short]
    if earlier:
        if default_place:
            raise OutputError(f"{earlier[0]}: an earlier result is there (the default place, as no {option} was "
                              f"given); give {REPLACE_OPTION} to replace it, or choose another place with {option}")
        raise OutputError(f"{option} {earlier[0]}: an earlier result is there; give {REPLACE_OPTION} to replace it, "
                          f"or another {option}")
    return path


def present(paths: Iterable[str | Path]) -> set[Path]:
    """Those of ``paths`` that exist now: taken before a command writes them, the files its closing line says it
    replaced (:func:`said_written`)."""
    return {Path(p) for p in paths if Path(p).exists()}


def written(replaced: bool) -> str:
    """The verb of a command's closing line for what it wrote: ``replaced`` for a file that was there before (an
    earlier result :data:`REPLACE_OPTION` replaced), else ``wrote``."""
    return "replaced" if replaced else "wrote"


def said_written(paths: Sequence[str | Path], earlier: Collection[str | Path] = (), tail: str = "") -> str:
    """A command's closing line: ``wrote A, B`` + ``tail``, those of ``paths`` in ``earlier`` (:func:`present`
    before they were written) said as replaced, in the order of ``paths``: ``replaced A; wrote B``.  Every command
    writing a file the user names says it so (``simulate``, ``show``, ``plot``, ``identify``, ``discrepancy``,
    ``monitor``, ``diagnose``)."""
    had = {Path(p) for p in earlier}
    runs: list[tuple[bool, list[str]]] = []
    for p in paths:
        old = Path(p) in had
        if runs and runs[-1][0] == old:
            runs[-1][1].append(str(p))
        else:
            runs.append((old, [str(p)]))
    return "; ".join(f"{written(old)} {', '.join(names)}" for old, names in runs) + tail


def check_whole(path: str | Path, remake: str) -> None:
    """Refuse to read ``path`` as a result while its folder's :data:`INCOMPLETE_MARK` names it: its set was being
    written when its writer stopped (or is being written now), so the file may be the earlier result's or the new
    one's, and the rest of its set may be missing.  ``remake``: what makes the file again (for the message).  A file
    the mark does not name (``identify``'s overlay saved beside a result folder's files) is read as it is."""
    path = Path(path)
    mark = path.parent / INCOMPLETE_MARK
    if not mark.exists() or path.name not in (_marked_results(mark) or [path.name]):
        return
    holder = lock_holder(path.parent)
    if holder is not None:
        raise StoredResultError(f"{path}: another ur5fault process is writing its result there now; wait for it")
    raise StoredResultError(f"{path}: part of a result cut short (its writer stopped before finishing; "
                            f"{mark} is still there): {remake} again")


def file_lock(path: str | Path) -> Lock:
    """The lock of one output file (``identify``'s overlay): ``.NAME.lock`` beside it, held while the command checks
    and writes it, so that two runs started together into one file do not both write it (each had checked an empty
    place at its start)."""
    path = Path(path)
    return Lock(path.parent, what="ur5fault process", name=f".{path.name}.lock", subject=path)


@contextlib.contextmanager
def result_folder(out: str | Path, results: tuple[str, ...] = (), replace: bool = True,
                  option: str = "--out") -> Iterator[Path]:
    """Hold ``out``'s lock and its :data:`INCOMPLETE_MARK` while the ``with`` block writes the
    result files (``results``: their names, for the check again of ``replace=False``); the mark is removed only
    when the block ends without an exception."""
    out = Path(out)
    with Lock(out, what="ur5fault process"):
        if not replace:  # a complete result written by another run since this one checked at its start
            check_new_output(out, folder=True, results=results, replace=False, option=option, note=False,
                             holding_lock=True)
        remove_stale_temporaries(out)  # an hour old: identify or simulate may write a file here without this lock
        mark = out / INCOMPLETE_MARK
        _remove_cut_short(out, mark)
        write_text_atomic(mark, json.dumps({"host": socket.gethostname(), "pid": os.getpid(),
                                            "results": list(results)}) + "\n")
        yield out
        mark.unlink(missing_ok=True)


def _marked_results(mark: Path) -> list[str]:
    """The result names a mark records: plain file names inside its folder (empty for an absent or unreadable mark,
    or one of before it recorded them)."""
    try:
        names = json.loads(mark.read_text()).get("results", [])
    except (OSError, ValueError, AttributeError):
        return []
    return [n for n in (names if isinstance(names, list) else [])
            if isinstance(n, str) and n and Path(n).name == n and n not in (".", "..")]


def _remove_cut_short(out: Path, mark: Path) -> None:
    """The result files a writer stopped mid-set had named in its mark, removed before another set is written: a
    command of another kind (monitor into a folder a killed discrepancy left) wrote its own files beside them and
    removed the mark, so they passed for a result. Files only: a folder it named (benchmark's ``models/``) may hold
    a user's files too, and its own are checked against each other when read."""
    for name in _marked_results(mark):
        path = out / name
        if path.is_file() or path.is_symlink():
            path.unlink(missing_ok=True)
            (out / f"{name}.sha256").unlink(missing_ok=True)

"""The real logs shipped in the package: every file by name, readable with its format, the same files a
checkout's data/ links to, each set with its README (and the Kufieta runs with their licence)."""

from __future__ import annotations

import re

import pytest

from ur5fault.errors import UnknownNameError
from ur5fault.logs.readers import read_log
from ur5fault.logs.shipped import LOGS_DIR, shipped_log, shipped_logs

from conftest import KUFIETA_RUNS, NIST_LOG, REPO


def test_every_shipped_log_file_has_a_name_and_every_name_a_file():
    logs = shipped_logs()
    files = sorted(p.name for p in LOGS_DIR.rglob("*.csv.gz"))
    assert sorted(lg.path.name for lg in logs.values()) == files and len(files) == 10
    assert list(logs)[0] == "nist" and len(shipped_log("kufieta")) == 9
    for folder in ("nist-ur5", "kufieta-ur5"):
        assert (LOGS_DIR / folder / "README.md").is_file()
    assert (LOGS_DIR / "kufieta-ur5" / "LICENSE-Apache-2.0.txt").is_file()  # Apache-2.0, section 4


def test_the_shipped_readmes_say_where_the_files_they_point_at_are():
    """The Kufieta README (installed with the logs) said "see docs/validation.md", which an installed package does not
    hold: a pointer into the checkout's docs/ or bench/ says it is in the source repository."""
    readmes = sorted(LOGS_DIR.glob("*/README.md"))
    assert len(readmes) == 2
    for readme in readmes:
        text = " ".join(readme.read_text().split())
        for m in re.finditer(r"\b(?:docs|bench)/[\w./-]*\w", text):
            assert text[m.end():].startswith(" in the ur5fault source repository"), (readme.parent.name, m.group())


def test_a_checkouts_data_folder_is_the_shipped_files():
    assert NIST_LOG.resolve() == shipped_log("nist")[0].path.resolve()
    assert sorted(p.resolve() for p in KUFIETA_RUNS) == sorted(lg.path.resolve() for lg in shipped_log("kufieta"))
    assert (REPO / "data" / "nist-ur5").resolve() == (LOGS_DIR / "nist-ur5").resolve()


@pytest.mark.parametrize("name", ["nist", "kufieta/TEST", "kufieta/Movement_No4_Acc"])
def test_a_shipped_log_reads_with_its_format(name):
    (lg,) = shipped_log(name)
    log = read_log(lg.path, lg.format)
    assert log.t_s.size > 1000 and abs(log.period_s - 0.008) < 1e-4


def test_an_unknown_name_lists_the_logs():
    with pytest.raises(UnknownNameError, match=r"unknown shipped log 'kufieta/No1' \(did you mean 'kufieta' or "
                                               r"'kufieta/Movement_No1'.*valid: kufieta, kufieta/Movement_No1, "):
        shipped_log("kufieta/No1")


def test_a_shipped_log_missing_from_the_install_is_said_so(tmp_path, monkeypatch):
    """A broken install (a package-data glob that missed the logs) printed a path that did not exist, exit 0."""
    from ur5fault.errors import ConfigFileError
    from ur5fault.logs import shipped

    monkeypatch.setattr(shipped, "LOGS_DIR", tmp_path)
    with pytest.raises(ConfigFileError, match=r"ur5testresult_halfspeed_payload1.6lb_1.csv.gz: the shipped log nist "
                                              r"is not installed: reinstall ur5fault"):
        shipped_log("nist")
    with pytest.raises(ConfigFileError, match=r"the shipped Kufieta logs are not installed"):
        shipped_log("kufieta")

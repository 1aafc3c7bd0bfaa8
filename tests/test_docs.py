"""The tests README.md and docs/*.md cite exist: docs/prognostics.md cited tests/health/prognostics/test_fleet.py
after the file became test_life_fleet.py, and docs/diagnostics.md tests/health/test_noise_ratio.py, which is
tests/twin/test_noise_ratio.py. A test cited by name (``FILE.py::NAME``, a line break allowed after ``::``) is
defined in its file."""

from __future__ import annotations

import re

from conftest import REPO

#: a cited test file, and the test named after it, if any
CITED = re.compile(r"(tests/[\w./-]+?\.py)(?:::\s*(\w+))?")


def _citations() -> list[tuple[str, str, str | None]]:
    """``(page:line, file, test name or None)`` of every test file cited in README.md and docs/*.md."""
    found = []
    for page in [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]:
        text = page.read_text(encoding="utf-8")
        for m in CITED.finditer(text):
            where = f"{page.relative_to(REPO)}:{text.count(chr(10), 0, m.start()) + 1}"
            found.append((where, m.group(1), m.group(2)))
    return found


def test_every_test_file_and_test_the_docs_cite_exists():
    cited = _citations()
    assert len(cited) > 20, cited  # the pattern finds the citations (92 when this test was written)
    dead = [f"{where}: {path}" for where, path, _ in cited if not (REPO / path).is_file()]
    assert not dead, dead
    undefined = [f"{where}: {path}::{name}" for where, path, name in cited if name and not re.search(
        rf"^\s*(?:async\s+)?(?:def|class)\s+{name}\b", (REPO / path).read_text(encoding="utf-8"), re.MULTILINE)]
    assert not undefined, undefined

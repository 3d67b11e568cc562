"""docs/reliability.md names a test on every row, and each named test exists: a renamed or removed
test fails here, so that no row claims a guarantee nothing checks."""
from __future__ import annotations

import re

from tests.docs.markdown import ROOT

PAGE = ROOT / "docs" / "reliability.md"
# `tests/path/test_x.py::test_name` or `...::test_name[case]`
NAMED = re.compile(r"`(tests/[\w/]+\.py)::(\w+)(?:\[[^\]]*\])?`")


def rows() -> list[str]:
    """The page's table rows (not the header or its rule)."""
    lines = PAGE.read_text().splitlines()
    return [line for line in lines
            if line.startswith("| ") and not line.startswith(("| When ", "|---"))]


def test_every_row_names_a_test():
    unnamed = [row[:80] for row in rows() if not NAMED.search(row)]
    assert rows() and unnamed == []


def test_every_named_test_exists():
    missing = []
    for row in rows():
        for path, name in NAMED.findall(row):
            source = ROOT / path
            if not source.is_file() or not re.search(rf"^\s*(async )?def {name}\(",
                                                     source.read_text(), re.M):
                missing.append(f"{path}::{name}")
    assert missing == []

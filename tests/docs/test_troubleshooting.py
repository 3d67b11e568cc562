"""docs/troubleshooting.md quotes messages that the code still says: each literal piece of a quoted
message start is found in a string of mirrorcore/ or app/ (run after changing a message)."""
from __future__ import annotations

import ast
import re
from functools import cache

from tests.docs.markdown import ROOT, blocks

PAGE = ROOT / "docs" / "troubleshooting.md"
# What the page writes for the parts a message fills in: PATH, MIRROR, N, WxH, (U, V), ...
PLACEHOLDER = re.compile(
    r"\.\.\.|\([A-Z], [A-Z]\)|\b[A-Z][A-Za-z0-9_]*[A-Z0-9]\b|\b[A-Z]\b|\bWxH\b")
SHORTEST = 6  # characters of a piece worth looking for


@cache
def strings() -> tuple[str, ...]:
    """Every string literal of mirrorcore/ and app/, f-strings' fixed parts joined by a NUL."""
    out = []
    for folder in ("mirrorcore", "app"):
        for path in (ROOT / folder).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Constant) and isinstance(node.value, str):
                    out.append(node.value)
                elif isinstance(node, ast.JoinedStr):
                    out.append("\0".join(v.value if isinstance(v, ast.Constant) else ""
                                         for v in node.values))
    return tuple(out)


def quoted() -> list[str]:
    """The message starts the page quotes: the code spans of each table row's first cell."""
    rows = [text for kind, text in blocks(PAGE.read_text()) if kind == "row"]
    first_cells = [row.strip("|").split(" | ")[0] for row in rows]
    return [span for cell in first_cells for span in re.findall(r"`([^`]+)`", cell)]


def missing(quote: str) -> list[str]:
    pieces = [p.strip(" :;,.'") for p in PLACEHOLDER.split(quote)]
    return [p for p in pieces if len(p) >= SHORTEST and not any(p in s for s in strings())]


def test_troubleshooting_quotes_messages_the_code_says():
    stale = {q: missing(q) for q in quoted() if missing(q)}
    assert stale == {}, ("docs/troubleshooting.md quotes messages the code no longer says "
                         "(update the page): " + "; ".join(f"{q!r}: {m}" for q, m in stale.items()))


def test_the_check_finds_a_changed_message():
    assert missing("PATH: no such depth image") == []
    assert missing("PATH: no such depth picture") == ["no such depth picture"]
    assert len(quoted()) > 100

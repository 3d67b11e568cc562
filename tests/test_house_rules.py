"""The house rules of docs/architecture.md that a machine can check: product text speaks of the
product, lines and modules stay short, tests wait on conditions."""
from __future__ import annotations

import io
import re
import subprocess
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CODE = ("mirrorcore", "app", "bench", "scripts", "tests")
MAX_LINE = 100
MAX_MODULE = 400       # lines of a module of mirrorcore/, app/ or bench/
MAX_TEST_MODULE = 500

# Who tried the tool, and what an earlier version did, belong to commit messages and CHANGELOG.md.
# The word is spelt in two parts so that this file does not match its own pattern.
WHO = "help" + "er"
PERSON = re.compile(rf"\ba {WHO}\b|\b{WHO}'s\b|\({WHO}s?\b|\b{WHO}s? "
                    r"(found|took|met|tried|saw|said|could)\b", re.I)
HISTORY = re.compile(
    # the pluperfect of a change's story
    r"(?<!has )\bhad\b(?! to\b)"
    r"|\d\s*(%|ms|mm|s|px|fps|MB)?\s*->\s*\d"                           # before -> after figures
    r"|\bbefore: |\bused to\b|\bno longer\b|\bwalk-?through\b|\b(this|last|earlier) "
    r"(stop|session|version)\b"
    r"|\btried and\b|\bnot kept\b|\bwent from\b",
    re.I)


def tracked(*patterns: str) -> list[Path]:
    out = subprocess.run(
        ["git", "ls-files", *patterns], cwd=ROOT, capture_output=True, text=True, check=True
    )
    return [ROOT / p for p in out.stdout.split() if (ROOT / p).is_file()]


def python_files() -> list[Path]:
    return [p for p in tracked("*.py") if p.relative_to(ROOT).parts[0] in CODE]


def comment_lines(path: Path) -> list[tuple[int, str]]:
    """(line number, text) of every comment and docstring line of a Python file."""
    source = path.read_text()
    out: list[tuple[int, str]] = []
    previous = tokenize.INDENT
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            out.append((tok.start[0], tok.string))
        elif tok.type == tokenize.STRING and previous in (
            tokenize.INDENT,
            tokenize.NEWLINE,
            tokenize.DEDENT,
            tokenize.NL,
        ):
            out += [(tok.start[0] + i, line) for i, line in enumerate(tok.string.splitlines())]
        if tok.type not in (tokenize.COMMENT, tokenize.NL):
            previous = tok.type
    return out


def text_lines() -> list[tuple[str, int, str]]:
    """Every line a reader meets as prose: Markdown files and the comments and docstrings of the
    code."""
    lines = [
        (str(p.relative_to(ROOT)), n, line)
        for p in tracked("*.md")
        if not p.name == "CHANGELOG.md" and "decisions" not in p.parts
        for n, line in enumerate(p.read_text().splitlines(), 1)
    ]
    lines += [
        (str(p.relative_to(ROOT)), n, line) for p in python_files() for n, line in comment_lines(p)
    ]
    return lines


def test_no_text_speaks_of_who_tested_the_tool():
    found = [f"{f}:{n}: {line.strip()[:80]}" for f, n, line in text_lines() if PERSON.search(line)]
    assert found == [], f"{len(found)} lines speak of who tested the tool:\n" + "\n".join(
        found[:40]
    )


def test_comments_describe_the_code_as_it_is():
    """History (what an earlier version did, who found what) stays under 2 % of comment and
    docstring lines: a line counts when it matches HISTORY or PERSON (the pluperfect, before ->
    after figures, words of a change's story)."""
    lines = [
        (f, n, line)
        for p in python_files()
        for f, (n, line) in ((str(p.relative_to(ROOT)), c) for c in comment_lines(p))
    ]
    history = [
        f"{f}:{n}: {line.strip()[:90]}"
        for f, n, line in lines
        if HISTORY.search(line) or PERSON.search(line)
    ]
    assert len(history) < 0.02 * len(lines), (
        f"{len(history)} of {len(lines)} comment lines tell history:\n" + "\n".join(history[:60])
    )


def test_documents_describe_the_product_as_it_is():
    lines = [(f, n, line) for f, n, line in text_lines() if f.endswith(".md")]
    history = [f"{f}:{n}: {line.strip()[:90]}" for f, n, line in lines if HISTORY.search(line)]
    assert history == [], f"{len(history)} lines of the documents tell history:\n" + "\n".join(
        history[:60]
    )


def test_lines_fit_in_100_columns():
    long = [
        f"{p.relative_to(ROOT)}:{n}"
        for p in python_files()
        for n, line in enumerate(p.read_text().splitlines(), 1)
        if len(line) > MAX_LINE
    ]
    assert long == [], f"{len(long)} lines over {MAX_LINE} characters: " + ", ".join(long[:40])


@pytest.mark.parametrize(
    "folder,most",
    [
        ("mirrorcore", MAX_MODULE),
        ("app", MAX_MODULE),
        ("bench", MAX_MODULE),
        ("tests", MAX_TEST_MODULE),
    ],
)
def test_modules_stay_short(folder, most):
    long = [
        f"{p.relative_to(ROOT)} ({n})"
        for p in python_files()
        if p.relative_to(ROOT).parts[0] == folder and (n := len(p.read_text().splitlines())) > most
    ]
    assert long == [], f"modules over {most} lines: " + ", ".join(long)


def test_tests_wait_on_conditions():
    """A fixed sleep in a test is deliberate and says why on its line or the line above."""
    bare = []
    for p in python_files():
        if p.relative_to(ROOT).parts[0] != "tests":
            continue
        lines = p.read_text().splitlines()
        bare += [
            f"{p.relative_to(ROOT)}:{n}"
            for n, line in enumerate(lines, 1)
            if re.search(r"\btime\.sleep\(", line)
            and "#" not in line
            and not lines[n - 2].strip().startswith("#")
        ]
    assert bare == [], "fixed sleeps without a reason: " + ", ".join(bare)

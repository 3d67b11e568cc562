"""What the tests of the command line read in its output: headlines and the figures under them."""

from __future__ import annotations

from mirrorscan.commands.wording import HEADLINE_WORDS, INDENT


def headlines(out: str) -> list[str]:
    """The lines of `out` that are not indented, each of at most HEADLINE_WORDS words (asserted)."""
    lines = [line for line in out.splitlines() if line and not line.startswith(INDENT)]
    for line in lines:
        assert len(line.split()) <= HEADLINE_WORDS, f"{len(line.split())} words: {line}"
    return lines


def details(out: str) -> list[str]:
    """The indented lines of `out` (the figures -v/--verbose prints), without their indent."""
    return [line[len(INDENT) :] for line in out.splitlines() if line.startswith(INDENT)]

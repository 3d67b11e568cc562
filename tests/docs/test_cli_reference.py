"""docs/reference/cli.md is what scripts/cli_reference.py writes from the parsers now."""
from __future__ import annotations

from tests.docs.scripts import load


def test_cli_reference_is_current():
    script = load("cli_reference")
    assert script.PAGE.read_text() == script.generate(), (
        "docs/reference/cli.md is stale: run `.venv/bin/python scripts/cli_reference.py`")


def test_cli_reference_names_every_command_and_option():
    from mirrorscan.cli import COMMANDS, build_parser

    page = load("cli_reference").generate()
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for name in COMMANDS:
        assert f"## mirrorscan {name}\n" in page
        for action in sub.choices[name]._actions:
            for option in action.option_strings:
                if option not in ("-h", "--help"):
                    assert f"`{option}" in page or f", {option}" in page, option

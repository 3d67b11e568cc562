"""Every relative link, anchor and module path that README.md and docs/ name exists."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from tests.docs.markdown import ROOT, anchor, anchors, blocks, documents, links

FOLDERS = {"mirrorcore": "mirrorcore", "mirrorscan": "app"}
FILE_PATH = re.compile(r"(?<![\w/.-])((?:mirrorcore|app|bench|tests|scripts)/[\w/.-]*[\w/])")
DOTTED = re.compile(r"(?<![\w/.-])((?:mirrorcore|mirrorscan)(?:\.[A-Za-z_]\w*)+)(?![\w-])")


def module_file(dotted: str) -> tuple[Path | None, list[str]]:
    """The source file of the longest module prefix of a dotted name, and the names after it."""
    parts = dotted.split(".")
    for n in range(len(parts), 0, -1):
        head = parts[:n]
        if head[:2] == ["mirrorscan", "bench"]:
            base = ROOT / "bench" / Path(*head[2:]) if n > 2 else ROOT / "bench"
        else:
            base = ROOT / FOLDERS[head[0]] / Path(*head[1:]) if n > 1 else ROOT / FOLDERS[head[0]]
        for candidate in (base.with_suffix(".py"), base / "__init__.py"):
            if candidate.is_file():
                return candidate, parts[n:]
    return None, parts


def defines(path: Path, name: str) -> bool:
    """Whether a module defines or imports a name at its top level (or as a class member)."""
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        named = (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)
        if isinstance(node, named) and node.name == name:
            return True
        if isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id == name for t in targets):
                return True
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            if any((a.asname or a.name.split(".")[0]) == name for a in node.names):
                return True
    return False


def stale_paths(text: str) -> list[str]:
    """The module and file paths a text names that do not exist."""
    out = []
    for path in FILE_PATH.findall(text):
        if not (ROOT / path.rstrip("/")).exists():
            out.append(path)
    for dotted in DOTTED.findall(text):
        source, rest = module_file(dotted)
        if source is None or len(rest) > 2 or (rest and not defines(source, rest[0])):
            out.append(dotted)
    return out


@pytest.mark.parametrize("path", documents(), ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_and_anchors_exist(path):
    broken = []
    for target in links(path):
        if re.match(r"[a-z]+:", target):
            continue
        file, _, fragment = target.partition("#")
        dest = (path.parent / file).resolve() if file else path
        if not dest.exists():
            broken.append(f"{target}: no such file")
        elif fragment and dest.suffix == ".md" and fragment not in anchors(dest):
            broken.append(f"{target}: no heading #{fragment} in {dest.relative_to(ROOT)}")
    assert broken == [], f"{path.relative_to(ROOT)}: " + "; ".join(broken)


@pytest.mark.parametrize("path", [p for p in documents() if p.name != "CHANGELOG.md"],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_module_paths_exist(path):
    """The README and the guide name modules and files that exist (the changelog names old ones)."""
    text = "\n".join(t for _, t in blocks(path.read_text()))
    assert stale_paths(text) == [], f"{path.relative_to(ROOT)} names what does not exist"


def test_checks_find_what_is_stale():
    assert stale_paths("see `mirrorcore/carve.py` and mirrorcore.views") == [
        "mirrorcore/carve.py", "mirrorcore.views"]
    assert stale_paths("`mirrorcore/rig/raypaths.py`, mirrorcore.calibration.refine, "
                       "mirrorscan.bench.soak, tests/waiting.py") == []
    names = "mirrorcore.base.palette.source_sequence and mirrorcore.base.palette.nothing"
    assert stale_paths(names) == ["mirrorcore.base.palette.nothing"]
    assert anchor("## Sharing the browser tool safely") == "sharing-the-browser-tool-safely"
    assert anchor("### `mirrorscan serve` (the tool)") == "mirrorscan-serve-the-tool"

"""Reading the project's Markdown as the forge shows it: blocks, sentences, links and anchors."""
from __future__ import annotations

import re
import statistics
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
LINK = re.compile(r"!?\[(?P<text>[^\]]*)\]\((?P<target>[^)\s]+)(?:\s+\"[^\"]*\")?\)")
CODE_SPAN = re.compile(r"`[^`]*`")
SENTENCE_END = re.compile(r"(?<=[.!?])[)*_]*\s+(?=[A-Z0-9*_`(\[\"])")


def documents() -> list[Path]:
    """README.md and every Markdown file under docs/ (git's view, plus files not yet added)."""
    listing = ["git", "ls-files", "--cached", "--others", "--exclude-standard",
               "README.md", "CHANGELOG.md", "docs"]
    out = subprocess.run(listing, cwd=ROOT, capture_output=True, text=True, check=True)
    return sorted({ROOT / p for p in out.stdout.split()
                   if p.endswith(".md") and (ROOT / p).is_file()})


def guide(path: Path) -> bool:
    """Whether a document is the product's guide, as against its history (CHANGELOG, decisions)."""
    rel = path.relative_to(ROOT)
    return rel.name != "CHANGELOG.md" and "decisions" not in rel.parts


def blocks(text: str) -> list[tuple[str, str]]:
    """The document's units as (kind, text): 'heading', 'paragraph', 'item' (of a list), 'row' (of a
    table), 'code' (one line of a fenced block), 'html' (a comment or tag line)."""
    out: list[tuple[str, str]] = []
    paragraph: list[str] = []
    kind = "paragraph"
    fence = None

    def flush() -> None:
        nonlocal paragraph, kind
        if paragraph:
            out.append((kind, " ".join(line.strip() for line in paragraph)))
        paragraph, kind = [], "paragraph"

    for line in text.splitlines():
        stripped = line.strip()
        if fence:
            if stripped.startswith(fence):
                fence = None
            else:
                out.append(("code", line))
            continue
        if stripped.startswith(("```", "~~~")):
            flush()
            fence = stripped[:3]
        elif not stripped:
            flush()
        elif stripped.startswith("#"):
            flush()
            out.append(("heading", stripped))
        elif stripped.startswith("|"):
            flush()
            out.append(("row", stripped))
        elif stripped.startswith("<"):
            flush()
            out.append(("html", stripped))
        elif re.match(r"([-*+]|\d+\.)\s", stripped):
            flush()
            paragraph, kind = [stripped], "item"
        else:
            paragraph.append(line)
    flush()
    return out


def words(text: str) -> int:
    """Words a reader reads: link targets left out."""
    return len(LINK.sub(lambda m: m["text"], text).split())


def sentences(text: str) -> list[str]:
    """The sentences of a paragraph or list item."""
    plain = LINK.sub(lambda m: m["text"], text)
    plain = re.sub(r"^([-*+]|\d+\.)\s+", "", plain)
    return [s for s in SENTENCE_END.split(plain) if s.strip()]


def prose_sentences(path: Path) -> list[str]:
    return [s for kind, text in blocks(path.read_text()) if kind in ("paragraph", "item")
            for s in sentences(text)]


def median_sentence(paths: list[Path]) -> float:
    return statistics.median(words(s) for p in paths for s in prose_sentences(p))


def anchor(heading: str) -> str:
    """GitHub's anchor of a heading's text: lower case, punctuation dropped, spaces to hyphens."""
    text = LINK.sub(lambda m: m["text"], heading.lstrip("#").strip()).lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """Every anchor of a document: its headings (repeats numbered -1, -2 ...) and explicit ids."""
    seen: dict[str, int] = {}
    out = set()
    for kind, text in blocks(path.read_text()):
        if kind == "heading":
            name = anchor(text)
            out.add(f"{name}-{seen[name]}" if name in seen else name)
            seen[name] = seen.get(name, 0) + 1
        out.update(re.findall(r"<a\s+(?:id|name)=\"([^\"]+)\"", text))
    return out


def links(path: Path) -> list[str]:
    """The link and image targets of a document, code left out."""
    return [m["target"] for kind, text in blocks(path.read_text()) if kind != "code"
            for m in LINK.finditer(CODE_SPAN.sub("", text))]

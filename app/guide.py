"""The guide served beside the page: mirrorscan's README, CHANGELOG and docs/ over the tool's own
port, Markdown rendered as HTML.

GET /guide/PATH answers with a file of mirrorscan's source tree, found beside the installed package
(an editable install or a checkout; a wheel has no docs and then no route): README.md, CHANGELOG.md
or a file under docs/, of a suffix in CONTENT_TYPES. Markdown is rendered with markdown-it-py
(CommonMark and tables, raw HTML shown as text), headings given GitHub's anchors, so that the docs'
relative links and `file.md#heading` land as on the forge. Any other path under /guide/ is 404.
The guard's checks (security.protect) run before this route.
"""
from __future__ import annotations

import functools
import html
import http
import re
from pathlib import Path
from urllib.parse import unquote, urlsplit

from markdown_it import MarkdownIt
from websockets.datastructures import Headers
from websockets.http11 import Response

PREFIX = "/guide/"
GUIDE = "docs/browser-tool.md"  # the guide to the browser tool
DOCS_INDEX = "docs/README.md"
TOP_FILES = ("README.md", "CHANGELOG.md")
CONTENT_TYPES = {
    ".md": "text/html; charset=utf-8",
    ".png": "image/png",
    ".svg": "image/svg+xml",
    ".jpg": "image/jpeg",
    ".jpeg": "image/jpeg",
    ".csv": "text/csv; charset=utf-8",
}
# the pages run no script and load nothing but the guide's own images
POLICY = "default-src 'none'; img-src 'self'; style-src 'unsafe-inline'"
STYLE = """
body { margin: 0; font: 16px/1.55 system-ui, -apple-system, "Segoe UI", Roboto, sans-serif;
       color: #1f2328; background: #fff; }
nav { padding: 0.6em 1.5em; border-bottom: 1px solid #d0d7de; background: #f6f8fa; }
nav a { margin-right: 1.2em; }
main { max-width: 52em; margin: 0 auto; padding: 1em 1.5em 4em; }
h1, h2 { border-bottom: 1px solid #d0d7de; padding-bottom: 0.2em; }
h1, h2, h3, h4 { line-height: 1.25; margin: 1.4em 0 0.6em; }
a { color: #0969da; }
code, pre { font: 0.9em/1.45 ui-monospace, "SFMono-Regular", Menlo, Consolas, monospace;
            background: #f6f8fa; border-radius: 4px; }
code { padding: 0.1em 0.3em; }
pre { padding: 0.8em 1em; overflow-x: auto; }
pre code { padding: 0; background: none; }
table { border-collapse: collapse; margin: 1em 0; display: block; overflow-x: auto; }
th, td { border: 1px solid #d0d7de; padding: 0.35em 0.7em; text-align: left; vertical-align: top; }
th { background: #f6f8fa; }
img { max-width: 100%; height: auto; }
blockquote { margin: 1em 0; padding: 0 1em; color: #59636e; border-left: 4px solid #d0d7de; }
"""
PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title} · mirrorscan</title><style>{style}</style></head>
<body><nav><a href="{prefix}{guide}">The browser tool</a><a href="{prefix}{index}">The docs</a\
><a href="{prefix}README.md">README</a></nav>
<main>
{body}</main></body></html>
"""


def source_root() -> Path | None:
    """mirrorscan's source tree: the folder above the package, when it holds the guide.

    Returns
    -------
    Path or None
        None for an install without the docs (a wheel).
    """
    root = Path(__file__).resolve().parents[1]
    return root if (root / GUIDE).is_file() else None


def anchor(text: str) -> str:
    """GitHub's anchor of a heading's text: lower case, punctuation dropped, spaces to hyphens.

    Parameters
    ----------
    text : str
        The heading as shown (no Markdown).

    Returns
    -------
    str
    """
    return re.sub(r"[^\w\- ]", "", text.strip().lower()).replace(" ", "-")


@functools.cache
def _markdown() -> MarkdownIt:
    return MarkdownIt("commonmark", {"html": False}).enable("table")


def render(text: str) -> tuple[str, str]:
    """A Markdown document as HTML, its headings given GitHub's anchors as ids.

    Parameters
    ----------
    text : str
        The Markdown.

    Returns
    -------
    title : str
        The first heading's text ('' without one).
    body : str
        The HTML of the document.
    """
    md = _markdown()
    tokens = md.parse(text)
    seen: dict[str, int] = {}
    title = ""
    for opening, inline in zip(tokens, tokens[1:]):
        if opening.type != "heading_open":
            continue
        shown = "".join(child.content for child in inline.children or ()
                        if child.type in ("text", "code_inline"))
        title = title or shown
        name = anchor(shown)
        opening.attrSet("id", f"{name}-{seen[name]}" if name in seen else name)
        seen[name] = seen.get(name, 0) + 1
    return title, md.renderer.render(tokens, md.options, {})


@functools.lru_cache(maxsize=64)
def _page(path: Path, stamp: tuple[int, int]) -> bytes:
    """The HTML page of a Markdown file (cached while its modification time and size hold)."""
    title, body = render(path.read_text(encoding="utf-8"))
    return PAGE.format(title=html.escape(title or path.name), style=STYLE, body=body,
                       prefix=PREFIX, guide=GUIDE, index=DOCS_INDEX).encode()


def served(relative: str) -> bool:
    """Whether a path relative to the source tree is one the route serves.

    Parameters
    ----------
    relative : str
        '/'-separated.

    Returns
    -------
    bool
        True for README.md, CHANGELOG.md and files under docs/ of a suffix in CONTENT_TYPES.
    """
    parts = relative.split("/")
    if any(part in ("", ".", "..") or "\\" in part or "\0" in part for part in parts):
        return False
    if Path(parts[-1]).suffix.lower() not in CONTENT_TYPES:
        return False
    return relative in TOP_FILES or (parts[0] == "docs" and len(parts) > 1)


def resolve(root: Path, request_path: str) -> Path | None:
    """The file a request's path names, or None when the route does not serve it.

    Parameters
    ----------
    root : Path
        The source tree.
    request_path : str
        The request's path, query included, percent-encoded.

    Returns
    -------
    Path or None
        None for a path outside the served files (traversal, an absolute path, a symlink out of
        them, another suffix, a folder, a missing file).
    """
    relative = unquote(urlsplit(request_path).path)[len(PREFIX):]
    if not served(relative):
        return None
    base = root.resolve()
    target = (base / relative).resolve()
    if not target.is_relative_to(base) or not served(target.relative_to(base).as_posix()):
        return None
    return target if target.is_file() else None


def respond(root: Path | None, request_path: str) -> Response | None:
    """The route's answer to a GET, or None for a path not under /guide/ (viser's page).

    Parameters
    ----------
    root : Path or None
        The source tree (None: no route).
    request_path : str
        The request's path, query included.

    Returns
    -------
    Response or None
        200 with the file (Markdown as an HTML page), or 404.
    """
    if root is None or not request_path.startswith(PREFIX):
        return None
    target = resolve(root, request_path)
    if target is None:
        return _response(http.HTTPStatus.NOT_FOUND, "text/plain; charset=utf-8",
                         b"404 Not Found: the guide serves README.md, CHANGELOG.md and docs/\n")
    kind = CONTENT_TYPES[target.suffix.lower()]
    if target.suffix.lower() == ".md":
        status = target.stat()
        body = _page(target, (status.st_mtime_ns, status.st_size))
    else:
        body = target.read_bytes()
    return _response(http.HTTPStatus.OK, kind, body)


def _response(status: http.HTTPStatus, kind: str, body: bytes) -> Response:
    headers = Headers({"Content-Type": kind, "Content-Length": str(len(body)),
                       "X-Content-Type-Options": "nosniff", "Cache-Control": "no-cache",
                       "Content-Security-Policy": POLICY})
    return Response(status, status.phrase, headers, body)

"""The guide served beside the page (mirrorscan.guide), over plain HTTP from a protected viser
server: README, CHANGELOG and docs/ as rendered HTML with GitHub's anchors, their images and
tables with their content types, every relative link of the guide served; anything else 404; the
token still required; and the header's link to it (or its path, on an install without docs)."""
from __future__ import annotations

import http.client
import re
import time
from pathlib import Path
from urllib.parse import urljoin, urlsplit

import pytest
import viser
from mirrorscan import guide, page
from mirrorscan.guide import render, resolve, respond, source_root
from mirrorscan.security import TOKEN_COOKIE, new_token, protect

from tests.docs.markdown import anchors

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.skipif(source_root() is None, reason="an install without the docs")


@pytest.fixture(scope="module")
def served():
    """A viser server protected as on loopback (no token); its port."""
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    protect(server, "127.0.0.1")
    yield server.get_port()
    server.stop()


@pytest.fixture(scope="module")
def remote():
    """A viser server protected with a token, as one listening beyond loopback; (port, token)."""
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    guard = protect(server, "0.0.0.0")
    yield server.get_port(), guard.token
    server.stop()


def get(port: int, path: str, **headers: str) -> tuple[int, http.client.HTTPMessage, bytes]:
    """(status, headers, body) of a GET of `path` sent as it is (no normalisation)."""
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        connection.request("GET", path, headers={"Host": f"127.0.0.1:{port}", **headers})
        response = connection.getresponse()
        return response.status, response.headers, response.read()
    finally:
        connection.close()


def ids(body: bytes) -> set[str]:
    return set(re.findall(r'id="([^"]+)"', body.decode()))


def test_the_guide_is_rendered_with_its_tables_images_and_anchors(served):
    start = time.perf_counter()
    status, headers, body = get(served, "/guide/docs/browser-tool.md")
    print(f"browser-tool.md served in {1000 * (time.perf_counter() - start):.1f} ms")
    assert status == 200 and headers["Content-Type"] == "text/html; charset=utf-8"
    text = body.decode()
    assert "<h1 id=\"the-browser-tool\">The browser tool</h1>" in text
    assert "<title>The browser tool · mirrorscan</title>" in text
    assert "<table>" in text and "<th>Keys</th>" in text and "<td>Ctrl+Z</td>" in text
    assert re.search(r'<img src="images/[\w-]+\.png" alt="[^"]+"', text)
    assert 'id="keyboard-shortcuts"' in text
    # the anchors are the forge's, as the docs' own links expect them
    assert ids(body) >= anchors(ROOT / "docs" / "browser-tool.md")
    assert headers["Content-Length"] == str(len(body))


@pytest.mark.parametrize("path, kind", [
    ("/guide/README.md", "text/html; charset=utf-8"),
    ("/guide/CHANGELOG.md", "text/html; charset=utf-8"),
    ("/guide/docs/images/mirrors-1400x900.png", "image/png"),
    ("/guide/docs/images/plan-drawing.svg", "image/svg+xml"),
    ("/guide/docs/experiment-angle.csv", "text/csv; charset=utf-8"),
    ("/guide/docs/browser-tool.md?token=x#colour", "text/html; charset=utf-8"),
])
def test_each_kind_of_file_has_its_content_type(served, path, kind):
    status, headers, body = get(served, path)
    assert status == 200 and headers["Content-Type"] == kind
    file = urlsplit(path).path[len("/guide/"):]
    if not file.endswith(".md"):
        assert body == (ROOT / file).read_bytes()


def test_every_relative_link_of_the_guide_lands(served):
    """Links and images of the guide, the docs' index and the README, resolved as a browser does
    from the served page, are served, and their anchors are ids of the page they name."""
    for page_path in ("/guide/docs/browser-tool.md", "/guide/docs/README.md", "/guide/README.md"):
        body = get(served, page_path)[2].decode()
        targets = re.findall(r'(?:href|src)="([^"]+)"', body)
        relative = [t for t in targets if not re.match(r"[a-z]+:", t)]
        assert len(relative) > 3, page_path
        for target in relative:
            url = urlsplit(urljoin(f"http://x{page_path}", target))
            status, _, linked = get(served, url.path)
            assert status == 200, f"{page_path}: {target}"
            if url.fragment:
                assert url.fragment in ids(linked), f"{page_path}: {target}"


@pytest.mark.parametrize("path", [
    "/guide/../pyproject.toml",
    "/guide/docs/../pyproject.toml",
    "/guide/docs/%2e%2e/pyproject.toml",
    "/guide/docs/%2E%2E%2Fpyproject.toml",
    "/guide/docs/..%5cpyproject.toml",
    "/guide//etc/passwd",
    "/guide/%2Fetc%2Fpasswd",
    "/guide/pyproject.toml",
    "/guide/app/page.py",
    "/guide/app/guide.py",
    "/guide/docs",
    "/guide/docs/",
    "/guide/docs/images",
    "/guide/docs/./README.md",
    "/guide/docs/no-such-file.md",
    "/guide/",
    "/guide/docs/README.md%00.png",
])
def test_anything_else_is_not_found(served, path):
    status, headers, body = get(served, path)
    assert status == 404, path
    assert b"README" in body and b"root:" not in body


def test_symlinks_out_of_the_served_files_and_folders_are_not_found(tmp_path):
    (tmp_path / "docs" / "images").mkdir(parents=True)
    (tmp_path / "docs" / "folder.md").mkdir()
    (tmp_path / "README.md").write_text("# Top\n")
    (tmp_path / "secret.md").write_text("# Secret\n")
    (tmp_path / "docs" / "page.md").write_text("# A page\n")
    (tmp_path / "docs" / "out.md").symlink_to(tmp_path / "secret.md")
    (tmp_path / "docs" / "far.md").symlink_to("/etc/hostname")
    (tmp_path / "docs" / "up.md").symlink_to("../README.md")
    (tmp_path / "docs" / "linked").symlink_to(tmp_path)
    assert resolve(tmp_path, "/guide/docs/page.md") == tmp_path / "docs" / "page.md"
    # a link inside the served files is followed
    assert resolve(tmp_path, "/guide/docs/up.md") == tmp_path / "README.md"
    for path in ("/guide/docs/out.md", "/guide/docs/far.md", "/guide/docs/folder.md",
                 "/guide/docs/linked/secret.md", "/guide/secret.md"):
        assert resolve(tmp_path, path) is None, path
        assert respond(tmp_path, path).status_code == 404, path
    # not the route's
    assert respond(tmp_path, "/") is None and respond(tmp_path, "/guidebook") is None
    assert respond(None, "/guide/docs/page.md") is None


def test_with_a_token_the_guide_needs_it_like_the_page(remote):
    port, token = remote
    path = "/guide/docs/browser-tool.md"
    status, _, body = get(port, path)
    assert status == 403 and b"needs its token" in body
    assert get(port, path, Cookie=f"{TOKEN_COOKIE.format(port=port)}={new_token()}")[0] == 403
    assert get(port, "/guide/docs/../README.md")[0] == 403
    assert get(port, path, Cookie=f"{TOKEN_COOKIE.format(port=port)}={token}")[0] == 200
    assert get(port, path, Authorization=f"Bearer {token}")[0] == 200
    status, headers, _ = get(port, f"{path}?token={token}")
    assert status == 200 and headers["Set-Cookie"].startswith(TOKEN_COOKIE.format(port=port))


def test_markdown_is_commonmark_with_tables_and_raw_html_as_text():
    title, body = render("# A `code` title\n\n## A title\n\n## A title\n\n<script>x()</script>\n\n"
                         "| a | b |\n|---|---|\n| 1 | 2 |\n\n[there](other.md#a-title-1)\n")
    assert title == "A code title"
    assert '<h1 id="a-code-title">' in body
    assert '<h2 id="a-title">' in body and '<h2 id="a-title-1">' in body
    assert "<script>" not in body and "&lt;script&gt;" in body
    assert "<td>1</td>" in body and '<a href="other.md#a-title-1">' in body


def test_a_server_of_an_install_without_docs_has_no_route(monkeypatch):
    monkeypatch.setattr("mirrorscan.security.source_root", lambda: None)
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        protect(server, "127.0.0.1")
        status, _, body = get(server.get_port(), "/guide/docs/browser-tool.md")
        assert status == 404 and b"the guide serves" not in body
        assert get(server.get_port(), "/")[0] == 200
    finally:
        server.stop()


def test_the_header_links_the_guide_or_names_its_path(monkeypatch):
    linked = page.keys_help()
    assert f"[Open the guide](/guide/{guide.GUIDE})" in linked
    assert f"(/guide/{guide.DOCS_INDEX})" in linked
    monkeypatch.setattr(page, "source_root", lambda: None)
    plain = page.keys_help()
    assert "/guide/" not in plain and f"`{guide.GUIDE}` in mirrorscan's source" in plain

"""Who may drive the browser tool, against a real MirrorscanApp on
127.0.0.1 with real websocket clients and plain HTTP requests: websockets from other sites and
unknown Host headers (DNS rebinding) are refused, a token is needed beyond loopback, uploads are
refused by size as they start, a probe is not logged and a malformed message is one line."""
from __future__ import annotations

import asyncio
import logging
import os
import socket
import time
import urllib.error
import urllib.request
from pathlib import Path
from types import SimpleNamespace

import msgspec
import pytest
import viser
import websockets.asyncio.client
import websockets.exceptions
from mirrorscan.bench.tabs import HeadlessTab
from mirrorscan.panels.mirrors import MirrorsPanel
from mirrorscan.panels.object import ObjectPanel
from mirrorscan.panels.session import SessionPanel
from mirrorscan.security import (MAX_MESSAGE_BYTES, TOKEN_COOKIE, install_log_filter, new_token,
                                 protect)
from mirrorscan.server import MirrorscanApp
from viser import _messages

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.io.session import Session, SessionMirror
from mirrorcore.io.sessionfile import load_session, save_session
from mirrorcore.sim.layouts import paper_scene
from mirrorcore.sim.simulator import Simulator
from mirrorcore.sources import SimulatedSource
from tests.waiting import wait_for

PROTOCOL = f"viser-v{viser.__version__}"


def _app(root, token: str | None = None) -> MirrorscanApp:
    """The browser tool on 127.0.0.1 (it protects itself as it starts), a token required when one is
    given."""
    rig = Simulator(paper_scene(object="sphere"), seed=1, fps=5.0)
    mirrors = (SessionMirror("mirror 1"), SessionMirror("mirror 2"))
    session = Session(root, rig.intrinsics, mirrors)
    save_session(session)
    return MirrorscanApp(session, SimulatedSource(rig), port=0, sessions_dir=root.parent,
                         token=token)


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    app = _app(tmp_path_factory.mktemp("guarded") / "scan")
    yield app
    app.stop()


@pytest.fixture(scope="module")
def remote():
    """A viser server protected with the policy of one listening beyond loopback (it listens on
    127.0.0.1 whatever the policy): a token is made and required."""
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield SimpleNamespace(guard=protect(server, "0.0.0.0"), port=server.get_port())
    server.stop()


def http_get(port: int, path: str = "/", host: str | None = None, cookie: str | None = None):
    """(status, headers, body) of a plain GET with the given Host and Cookie headers."""
    headers = {"Host": host or f"127.0.0.1:{port}", **({"Cookie": cookie} if cookie else {})}
    request = urllib.request.Request(f"http://127.0.0.1:{port}{path}", headers=headers)
    try:
        with urllib.request.urlopen(request, timeout=10) as response:
            return response.status, response.headers, response.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.headers, exc.read()


async def _open(port: int, **kwargs) -> str:
    """Open a websocket as a viser client and read one message: 'accepted', or the HTTP status that
    refused it."""
    try:
        async with websockets.asyncio.client.connect(f"ws://127.0.0.1:{port}/",
                                                     subprotocols=[PROTOCOL], max_size=None,
                                                     open_timeout=10, **kwargs) as ws:
            await asyncio.wait_for(ws.recv(), 10)
            return "accepted"
    except websockets.exceptions.InvalidStatus as exc:
        return str(exc.response.status_code)


def ws_open(port: int, **kwargs) -> str:
    return asyncio.run(_open(port, **kwargs))


def send(message: _messages.Message) -> bytes:
    return msgspec.msgpack.encode(message.as_serializable_dict())


# --------------------------------------------------------------------- Origin and Host
def test_a_websocket_from_another_site_is_refused(app):
    port = app.port
    assert ws_open(port, origin="https://evil.example") == "403"
    assert ws_open(port, origin="null") == "403"
    # another port is another site
    assert ws_open(port, origin=f"http://127.0.0.1:{port + 1}") == "403"
    # the page itself
    assert ws_open(port, origin=f"http://127.0.0.1:{port}") == "accepted"
    # not a browser: no Origin
    assert ws_open(port) == "accepted"


def test_another_sites_websocket_cannot_rename_a_mirror(app):
    """A page of https://evil.example that renames a mirror through the Rename button of an open
    tab is refused at the handshake; the session keeps its names."""
    # a tab of the page itself, whose Rename the attack aims at
    with HeadlessTab(app) as tab:
        mirrors = next(p for p in tab.tab.panels if isinstance(p, MirrorsPanel))
        name_field, rename_button = mirrors.name._impl.uuid, mirrors.rename._impl.uuid

        async def attack() -> str:
            try:
                async with websockets.asyncio.client.connect(
                        f"ws://127.0.0.1:{app.port}/", subprotocols=[PROTOCOL],
                        origin="https://evil.example", max_size=None) as ws:
                    await ws.send(send(_messages.GuiUpdateMessage(name_field, {"value": "pwned"})))
                    await ws.send(send(_messages.GuiUpdateMessage(rename_button, {"value": True})))
                    # deliberate: time for a rename to land, were the connection let in
                    await asyncio.sleep(1)
                    return "connected"
            except websockets.exceptions.InvalidStatus as exc:
                return str(exc.response.status_code)

        assert asyncio.run(attack()) == "403"
    names = [m.name for m in load_session(app.editor.session.root).mirrors]
    assert names == ["mirror 1", "mirror 2"]


# --------------------------------------------------------------------- what a message may set
def test_a_depth_range_the_reader_refuses_is_refused_from_a_websocket_message(app, caplog):
    """The depth range [-1e308, 1e308] sent as the slider's value is refused in one line (past the
    slider's limits; the editor's check, which the reader shares, is tested in test_editor_fields);
    the session on disk and in memory keeps its range and opens."""
    caplog.set_level(logging.INFO, "mirrorscan")
    root = app.editor.session.root
    before = app.editor.session.selection
    with HeadlessTab(app) as headless:
        objects = next(p for p in headless.tab.panels if isinstance(p, ObjectPanel))
        headless.ws.send(send(_messages.GuiUpdateMessage(objects.range._impl.uuid,
                                                         {"value": (-1e308, 1e308)})))
        wait_for(lambda: "refused a GUI update of 'Depth range (m)'" in caplog.text,
                 what="the refusal")
        wait_for(lambda: objects.range.value == (before.depth_min, before.depth_max),
                 what="the slider back on the session's range")
    assert app.editor.session.selection == before
    assert load_session(root).selection == before
    with HeadlessTab(app) as again:
        assert again.tab.panels


@pytest.mark.parametrize("host", ["evil.example", "evil.example:{port}",
                                  "127.0.0.1.evil.example:{port}", ""])
def test_unknown_host_headers_are_refused(app, host):
    status, _, body = http_get(app.port, host=host.format(port=app.port) or " ")
    assert status == 403 and b"unknown Host" in body
    # the same name on a websocket (its socket opened to 127.0.0.1, as a rebinding page's is)
    if host:
        name = host.format(port=app.port).split(":")[0]
        sock = socket.create_connection(("127.0.0.1", app.port))
        assert asyncio.run(_open_as(f"ws://{name}:{app.port}/", sock)) == "403"


async def _open_as(uri: str, sock: socket.socket) -> str:
    try:
        async with websockets.asyncio.client.connect(uri, sock=sock, subprotocols=[PROTOCOL],
                                                     open_timeout=10):
            return "accepted"
    except websockets.exceptions.InvalidStatus as exc:
        return str(exc.response.status_code)


def test_a_request_with_two_host_headers_is_refused(app):
    assert ws_open(app.port, additional_headers={"Host": "evil.example"}) == "403"


@pytest.mark.parametrize("host", ["127.0.0.1:{port}", "localhost:{port}", "LOCALHOST",
                                  "[::1]:{port}", "10.0.0.7"])
def test_addresses_and_localhost_are_served(app, host):
    status, _, body = http_get(app.port, host=host.format(port=app.port))
    assert status == 200 and b"<html" in body.lower()


# --------------------------------------------------------------------- the token
def test_beyond_loopback_a_token_is_made_and_required(remote):
    guard, port = remote.guard, remote.port
    assert guard.token and len(guard.token) >= 40
    assert guard.url.endswith(f"/?token={guard.token}")
    status, _, body = http_get(port)
    assert status == 403 and b"needs its token" in body
    assert http_get(port, f"/?token={guard.token[:-1]}x")[0] == 403
    assert ws_open(port) == "403"
    assert ws_open(port, origin=f"http://127.0.0.1:{port}") == "403"

    # the address printed at start
    status, headers, _ = http_get(port, f"/?token={guard.token}")
    assert status == 200
    cookie = headers["Set-Cookie"]
    assert "HttpOnly" in cookie and "SameSite=Strict" in cookie
    jar = cookie.split(";")[0]
    # the page's other requests
    assert http_get(port, "/", cookie=jar)[0] == 200
    page = f"http://127.0.0.1:{port}"
    assert ws_open(port, origin=page, additional_headers={"Cookie": jar}) == "accepted"
    bearer = {"Authorization": f"Bearer {guard.token}"}
    assert ws_open(port, additional_headers=bearer) == "accepted"
    assert ws_open(port, origin="https://evil.example", additional_headers={"Cookie": jar}) == "403"


@pytest.mark.parametrize("other", ['prefs={"a":1}', 'x=a b', 'broken', 'q="unclosed', '=v',
                                   'a=1;;b', 'caf\xe9=1'])
def test_another_applications_malformed_cookie_never_hides_the_token(remote, other):
    guard, port = remote.guard, remote.port
    token = f"{TOKEN_COOKIE.format(port=port)}={guard.token}"
    for header in (f"{other}; {token}", f"{token}; {other}"):
        assert http_get(port, "/", cookie=header)[0] == 200, header
        page = f"http://127.0.0.1:{port}"
        assert ws_open(port, origin=page, additional_headers={"Cookie": header}) == "accepted"
    assert http_get(port, "/", cookie=f"{other}; {token[:-1]}x")[0] == 403


def test_a_given_token_is_checked_and_protecting_twice_keeps_the_first(app, tmp_path):
    assert protect(app.server, "127.0.0.1") is app.guard
    with pytest.raises(MirrorscanError, match="--token: at least 16 characters"):
        _app(tmp_path / "short", token="short")
    token = new_token()
    # on loopback, when asked for
    other = _app(tmp_path / "scan", token=token)
    try:
        assert other.guard.token == token and http_get(other.port)[0] == 403
        assert http_get(other.port, f"/?token={token}")[0] == 200
    finally:
        other.stop()


def test_a_new_token_never_begins_with_a_dash(monkeypatch):
    """1 draw in 64 of token_urlsafe begins with '-', which `serve --token` would read as an
    option: such a draw is made again."""
    draws = iter(["-leading-dash-token-0123456789", "a-token-without-one-0123456789"])
    monkeypatch.setattr("mirrorscan.security.secrets.token_urlsafe", lambda n: next(draws))
    assert new_token() == "a-token-without-one-0123456789"


# --------------------------------------------------------------------- sizes
def test_an_upload_is_refused_from_its_declared_size_before_its_parts(app):
    """A tab uploads to its own Session step's button: declared too large, or sending more than it
    declared, its parts are dropped as they come (none is stored) and the tab is told."""
    with HeadlessTab(app) as headless:
        client = headless.tab.client
        panel = next(p for p in headless.tab.panels if isinstance(p, SessionPanel))
        button = panel.upload._impl.uuid
        states = client.gui._current_file_upload_states
        said = []
        client.add_notification = lambda title, message, **kwargs: said.append(message)

        def upload(transfer: str, size: int, parts: int, part_bytes: int, told: int) -> None:
            headless.ws.send(send(_messages.FileTransferStartUpload(
                button, transfer, "huge.png", "image/png", parts, size)))
            for i in range(8):
                part = _messages.FileTransferPart(button, transfer, i, bytes(part_bytes))
                headless.ws.send(send(part))
            # refused and told, its parts not buffered
            wait_for(lambda: len(said) >= told and transfer not in states, 10, "the refusal")

        # declares 1 GiB
        upload("t1", 1 << 30, 2048, 512 << 10, told=1)
        # declares 1 kB, sends 4 MB: dropped
        upload("t2", 1000, 100, 512 << 10, told=2)
        assert not states
        assert "huge.png: 1024.0 MB is more than the 20 MB an upload may have" in said[0]
        assert "huge.png: more bytes than it declared" in said[1]


def test_a_websocket_message_above_the_limit_closes_that_connection_only(app):
    async def big() -> int:
        ws = await websockets.asyncio.client.connect(f"ws://127.0.0.1:{app.port}/",
                                                     subprotocols=[PROTOCOL], max_size=None)
        try:
            await ws.send(bytes(MAX_MESSAGE_BYTES + 1))
            while True:
                await asyncio.wait_for(ws.recv(), 10)
        # closed while the client still sent
        except (websockets.exceptions.ConnectionClosed, AttributeError):
            pass
        await ws.wait_closed()
        return ws.close_code

    # "message too big"
    assert asyncio.run(big()) == 1009
    assert ws_open(app.port) == "accepted"


# --------------------------------------------------------------------- the log
def test_a_probe_is_not_logged_and_a_malformed_message_is_one_line(app, caplog):
    caplog.set_level(logging.DEBUG, logger="websockets")
    # viser's own log filter is in place after a page request
    http_get(app.port)
    quiet = install_log_filter()
    probes = quiet.probes
    # health checks, port scans
    for _ in range(5):
        socket.create_connection(("127.0.0.1", app.port), timeout=5).close()
    wait_for(lambda: quiet.probes >= probes + 5, 10, "five probes counted")
    assert quiet.probes == probes + 5
    assert not [r for r in caplog.records if r.exc_info or r.levelno >= logging.WARNING]

    async def malformed() -> None:
        async with websockets.asyncio.client.connect(f"ws://127.0.0.1:{app.port}/",
                                                     subprotocols=[PROTOCOL], max_size=None) as ws:
            await ws.send("not a viser message")
            await ws.send(b"\xc1 not msgpack")
            try:
                while True:
                    await asyncio.wait_for(ws.recv(), 10)
            except websockets.exceptions.ConnectionClosed:
                pass

    caplog.clear()
    asyncio.run(malformed())
    loud = wait_for(lambda: [r for r in caplog.records if r.levelno >= logging.WARNING], 10,
                    "the malformed message logged")
    assert len(loud) == 1 and not loud[0].exc_info and "\n" not in loud[0].getMessage()
    assert "malformed message from a client" in loud[0].getMessage()
    assert ws_open(app.port) == "accepted"


# --------------------------------------------------------------------- the command, a process
def test_serve_prints_its_token_address_refuses_strangers_and_stops_on_sigterm(tmp_path):
    import os
    import re
    import signal
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    token = new_token()
    command = [sys.executable, "-m", "mirrorscan.cli", "serve", str(tmp_path / "new"),
               "--port", "0", "--token", token]
    process = subprocess.Popen(command, cwd=root, env={**os.environ, "PYTHONPATH": str(root)},
                               stderr=subprocess.PIPE, text=True)
    try:
        lines = []
        while not any("mirrorscan is at" in line for line in lines):
            line = process.stderr.readline()
            assert line, "".join(lines)
            lines.append(line)
        address = re.search(r"http://127\.0\.0\.1:(\d+)/\?token=" + re.escape(token), lines[-1])
        port = int(address.group(1))
        assert http_get(port)[0] == 403 and http_get(port, f"/?token={token}")[0] == 200
        for _ in range(3):
            socket.create_connection(("127.0.0.1", port), timeout=5).close()
        time.sleep(0.5)  # deliberate: the server meets the probes before it stops (none logged)
        process.send_signal(signal.SIGTERM)
        _, rest = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    log = "".join(lines) + rest
    assert process.returncode == 130, log
    assert "Traceback" not in log and "handshake failed" not in log, log
    assert f"mirrorscan serve: stopped; every edit is saved in {tmp_path / 'new'}" in rest
    assert "cancelled" not in rest
    assert load_session(tmp_path / "new").mirrors == ()


# --------------------------------------------------------------------- names that are not UTF-8
def test_folder_names_that_are_not_utf8_never_close_a_tab(tmp_path, caplog):
    """A session in a folder named b'scan\\xe9', beside b'caf\\xe9' (a session) and b'vide\\xe9'
    (empty): a tab connects and stays; the Open list leaves them out and says so; the session's
    place and a refusal naming such a path are shown with replacement characters."""
    base = os.fsencode(tmp_path)
    for name in (b"caf\xe9", b"vide\xe9"):
        os.mkdir(base + b"/" + name)
    rig = Simulator(paper_scene(object="sphere"), seed=1, fps=5.0)
    save_session(Session(Path(os.fsdecode(base + b"/caf\xe9")), rig.intrinsics))
    save_session(Session(tmp_path / "plain", rig.intrinsics))
    root = Path(os.fsdecode(base + b"/scan\xe9"))
    save_session(Session(root, rig.intrinsics, (SessionMirror("mirror 1"),)))
    app = MirrorscanApp(load_session(root), SimulatedSource(rig), port=0, sessions_dir=tmp_path)
    app.start()
    try:
        with HeadlessTab(app) as headless:
            sessions = next(p for p in headless.tab.panels if isinstance(p, SessionPanel))
            assert sessions.open_choice.options == ("", "plain")
            assert "Not listed: 2 session folders whose name" in sessions.skipped.content
            assert "scan\ufffd" in sessions.where.content
            app.act(headless.tab.client,
                    lambda: load_session(Path(os.fsdecode(base + b"/caf\xe9/x\xe9"))))
            # deliberate: time for a close that must not come
            time.sleep(1)
            assert headless.tab.client.client_id in app.tabs
            assert headless._reader.is_alive()
    finally:
        app.stop()
    assert "UnicodeEncodeError" not in caplog.text

"""Who may use the browser tool, and what a stranger costs the log.

viser serves its page and its websocket on one port with no check of its own. protect() installs
these checks into a running viser.ViserServer, before any client is let in:

- **Host**: a request whose Host header is not an IP address, `localhost` or a name given in
  `allowed_hosts` (and this machine's own names) is refused (403): a DNS-rebinding page reaches
  127.0.0.1 under its own domain name.
- **Origin**: a websocket whose Origin is not the page's own (the Host it asked for) is refused
  (403): any web page may open ws://127.0.0.1:PORT from the user's browser. A client without an
  Origin is not a browser page.
- **Token**: required when listening beyond loopback (or whenever one is given): `?token=T` on the
  page's address (the server then sets a cookie, HttpOnly and SameSite=Strict, that the page's
  websocket carries), the cookie, or an `Authorization: Bearer T` header (scripts). Without it the
  page says where to find the address to open.
- **Sizes and values**: a websocket message is at most MAX_MESSAGE_BYTES; uploads are counted by
  the bytes received and GUI values kept within their inputs' ranges (inputlimits).
- **Log**: a plain TCP probe (connect, close: a health check, a port scan) is not logged at all
  (counted in QuietProbes.probes); a malformed HTTP request or websocket message is one line, not a
  traceback.

A request that passes the checks gets the guide (GET /guide/..., `guide.respond`) or viser's page.
"""
from __future__ import annotations

import asyncio
import hmac
import http
import ipaddress
import logging
import re
import secrets
import socket
import threading
from dataclasses import dataclass, field
from urllib.parse import parse_qs, urlsplit

import viser
import websockets.asyncio.server as ws_server
from websockets.datastructures import Headers
from websockets.http11 import Request, Response

from mirrorcore.base.errors import MirrorscanError

from .guide import respond, source_root
from .inputlimits import MAX_UPLOAD_BYTES, limit_inputs
from .quietlog import QuietProbes, install_log_filter

log = logging.getLogger("mirrorscan.security")

# one websocket message; uploads come in 512 KiB parts, GUI messages are small
MAX_MESSAGE_BYTES = 8 << 20
TOKEN_COOKIE = "mirrorscan-token-{port}"


@dataclass
class Guard:
    """The checks protect() installed, the counters, and the address to open.

    Attributes
    ----------
    host : str
        The address the server listens on.
    port : int
    token : str or None
        None when not required.
    allowed_hosts : frozenset of str
        Host names a browser may use besides IP addresses.
    max_upload_bytes : int
        The largest upload.
    refused : int
        Requests refused by Host, Origin or token.
    """

    host: str
    port: int
    token: str | None
    allowed_hosts: frozenset[str]
    max_upload_bytes: int = MAX_UPLOAD_BYTES
    refused: int = 0                 # requests refused by Host, Origin or token
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    @property
    def url(self) -> str:
        """The address to open in a browser (with the token when one is required)."""
        shown = "127.0.0.1" if self.host in ("0.0.0.0", "::", "") else self.host
        shown = f"[{shown}]" if ":" in shown else shown
        return f"http://{shown}:{self.port}/" + (f"?token={self.token}" if self.token else "")

    # ------------------------------------------------------------------ the checks, on one request
    def check(self, request: Request) -> Response | None:
        """Whether `request` may go on: its Host, its Origin (a websocket's) and the token.

        Parameters
        ----------
        request : Request

        Returns
        -------
        Response or None
            None when it may go on; otherwise the 403 response that refuses it (with a one-line
            reason).
        """
        headers = request.headers
        hosts, origins = headers.get_all("Host"), headers.get_all("Origin")
        host = hosts[0] if len(hosts) == 1 else ""
        if not self.host_allowed(host):
            return self._refuse(f"unknown Host {', '.join(hosts)[:80]!r}: open the address the "
                                "server printed")
        if "websocket" in (v.lower() for v in headers.get_all("Upgrade")) and origins:
            origin = urlsplit(origins[0])
            if (len(origins) > 1 or origin.scheme not in ("http", "https")
                    or origin.netloc.lower() != host.lower()):
                origin_text = ", ".join(origins)[:80]
                return self._refuse("websocket from another site refused: open the tool from the "
                                    f"address the server printed (Origin {origin_text!r})")
        if self.token is not None and not self.token_given(request):
            return self._refuse("this server needs its token: open the address with ?token= that "
                                "it printed when it started (or ask who started it)")
        return None

    def host_allowed(self, host_header: str) -> bool:
        """True for an IP address, localhost, or an allowed name, with or without a port.

        Parameters
        ----------
        host_header : str
            The Host header ('' when missing).

        Returns
        -------
        bool
        """
        name = urlsplit(f"//{host_header}").hostname if host_header else None
        if not name:
            return False
        try:
            ipaddress.ip_address(name)
            return True
        except ValueError:
            return name.lower() in self.allowed_hosts

    def token_given(self, request: Request) -> bool:
        """True when the query string, the cookie or an Authorization: Bearer header has the token.

        Parameters
        ----------
        request : Request

        Returns
        -------
        bool
        """
        given = parse_qs(urlsplit(request.path).query).get("token", [])
        given += cookie_values(request.headers.get_all("Cookie"),
                               TOKEN_COOKIE.format(port=self.port))
        given += [auth[7:].strip() for auth in request.headers.get_all("Authorization")
                  if auth.lower().startswith("bearer ")]
        return any(hmac.compare_digest(t.encode(), self.token.encode())
                   for t in given if t.isascii())

    def _refuse(self, reason: str) -> Response:
        """Count, log and return the 403 response with `reason`."""
        with self._lock:
            self.refused += 1
        log.warning("refused a connection: %s", reason)
        body = f"403 Forbidden: {reason}\n".encode()
        headers = Headers({"Content-Type": "text/plain; charset=utf-8",
                           "Content-Length": str(len(body))})
        return Response(http.HTTPStatus.FORBIDDEN, "Forbidden", headers, body)

    def cookie_header(self) -> str:
        """The Set-Cookie value that carries the token (30 days, HttpOnly, SameSite=Strict)."""
        return (f"{TOKEN_COOKIE.format(port=self.port)}={self.token}; HttpOnly; SameSite=Strict; "
                "Path=/; Max-Age=2592000")


def cookie_values(headers: list[str], name: str) -> list[str]:
    """The values of every cookie called `name` in Cookie headers, read pair by pair.

    Another application on the same host may set cookies that a strict parser refuses
    (`prefs={"a":1}`): such a pair is skipped, never the whole header.

    Parameters
    ----------
    headers : list of str
        The Cookie headers' values.
    name : str
        The cookie's name.

    Returns
    -------
    list of str
        Its values (surrounding double quotes taken off), in order.
    """
    values = []
    for pair in ";".join(headers).split(";"):
        key, equals, value = pair.partition("=")
        if equals and key.strip() == name:
            value = value.strip()
            if len(value) >= 2 and value[0] == value[-1] == '"':
                value = value[1:-1]
            values.append(value)
    return values


def new_token() -> str:
    """A secret token: 32 random bytes, URL-safe, never beginning with '-'.

    `--token` would read such a token as an option where a user pastes it.
    """
    token = secrets.token_urlsafe(32)
    while token.startswith("-"):
        token = secrets.token_urlsafe(32)
    return token


def is_loopback(host: str) -> bool:
    """True for localhost and the loopback addresses (127.0.0.0/8, ::1).

    Only this machine can connect to them.

    Parameters
    ----------
    host : str

    Returns
    -------
    bool
    """
    try:
        return host == "localhost" or ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def protect(server: viser.ViserServer, host: str, token: str | None = None,
            allowed_hosts: tuple[str, ...] = (), max_upload_bytes: int = MAX_UPLOAD_BYTES) -> Guard:
    """Install the checks of this module into a running viser server.

    Call it right after creating the server, before printing its address; connections already open
    that would not pass are closed. Protecting a server twice returns the first Guard.

    Parameters
    ----------
    server : viser.ViserServer
    host : str
        The address the server listens on; beyond loopback a token is required (a new one when
        `token` is None).
    token : str or None
        Require this token, even on loopback.
    allowed_hosts : tuple of str
        Host names besides IP addresses, localhost and this machine's names that a browser may use
        (a name behind which the machine is reached).
    max_upload_bytes : int
        The largest upload.

    Returns
    -------
    Guard
        Its `url` is the address to print.

    Raises
    ------
    MirrorscanError
        When the token is malformed, or viser's server cannot be found (a viser version whose
        internals differ): the tool refuses to run unprotected.
    """
    if isinstance(getattr(server, "_mirrorscan_guard", None), Guard):
        return server._mirrorscan_guard
    if token is None and not is_loopback(host):
        token = new_token()
    if token is not None and not re.fullmatch(r"[A-Za-z0-9._~-]{16,}", token):
        raise MirrorscanError("--token: at least 16 characters among letters, digits and . _ ~ - "
                              "(the token goes in an address and a cookie)")
    names = {"localhost", *(n.lower() for n in allowed_hosts)}
    if not is_loopback(host):
        names |= {socket.gethostname().lower(), socket.getfqdn().lower()}
    guard = Guard(host, server.get_port(), token, frozenset(names), max_upload_bytes)
    websock = server._websock_server
    loop = websock._background_event_loop
    future = asyncio.run_coroutine_threadsafe(_install(websock, guard), loop)
    try:
        future.result(timeout=10)
    except (LookupError, TimeoutError) as exc:
        raise MirrorscanError("cannot protect the browser tool's server; refusing to run "
                              f"unprotected (check the viser version): {exc}") from None
    limit_inputs(server, max_upload_bytes)
    install_log_filter()
    server._mirrorscan_guard = guard
    return guard


async def _install(websock, guard: Guard) -> None:
    """Wrap the websockets server's process_request with the guard's checks (on its event loop),
    then the guide's route (guide.respond), then viser's page."""
    server = _websockets_server(websock._background_event_loop)
    serve_page = server.process_request
    root = source_root()

    def process_request(connection: ws_server.ServerConnection,
                        request: Request) -> Response | None:
        refusal = guard.check(request)
        if refusal is not None:
            return refusal
        connection.protocol.max_message_size = MAX_MESSAGE_BYTES
        response = respond(root, request.path)
        if response is None and serve_page is not None:
            response = serve_page(connection, request)
        if response is not None and guard.token is not None and "token=" in request.path:
            response.headers["Set-Cookie"] = guard.cookie_header()
        return response

    server.process_request = process_request
    for connection in list(server.handlers):
        if connection.request is not None and guard.check(connection.request) is not None:
            await connection.close(1008, "refused")


def _websockets_server(loop: asyncio.AbstractEventLoop) -> ws_server.Server:
    """The websockets Server that viser's serving task holds.

    A local of its coroutine, waiting for the stop.
    """
    for task in asyncio.all_tasks(loop):
        frame = getattr(task.get_coro(), "cr_frame", None)
        for value in (frame.f_locals.values() if frame is not None else ()):
            if isinstance(value, ws_server.Server):
                return value
    raise LookupError("viser's websockets server was not found")


__all__ = ["Guard", "MAX_MESSAGE_BYTES", "MAX_UPLOAD_BYTES", "QuietProbes", "install_log_filter",
           "is_loopback", "new_token", "protect"]

"""An existing Dask scheduler's address, checked before Dask is handed it.

Its form ('tcp://HOST:PORT' or 'HOST:PORT'), then a probe that connects and reads the handshake a
Dask scheduler sends first, within a few seconds and stopping at once on a cancel request (Dask's
own client waits on a silent peer for its whole timeout, and reads an HTTP answer as a frame
length of exbibytes).
"""
from __future__ import annotations

import errno
import os
import select
import socket
import struct
import time

from mirrorcore.base.errors import Cancelled, MirrorscanError
from mirrorcore.base.progress import cancel_requested

# a Dask scheduler answers a connection at once; a silent peer is given up after this
PROBE_SECONDS = 5.0
# how often the probe looks at the cancel request
POLL_SECONDS = 0.1
# a handshake is a few hundred bytes ({'compression', 'python', 'pickle-protocol'} in msgpack)
MAX_HANDSHAKE_BYTES = 65536
HANDSHAKE_KEY = b"pickle-protocol"


def scheduler_address(address: str) -> tuple[str, int]:
    """Split a scheduler's address into its host and port.

    Parameters
    ----------
    address : str
        'tcp://HOST:PORT' or 'HOST:PORT' ('[::1]:8786' for IPv6).

    Returns
    -------
    host : str
    port : int

    Raises
    ------
    MirrorscanError
        Another protocol (ucx://, tls://, ...), no host or no port 1 to 65535.
    """
    scheme, _, rest = address.rpartition("://")
    if scheme not in ("", "tcp"):
        raise MirrorscanError(f"--scheduler {address}: only tcp:// schedulers are supported; "
                              "give tcp://HOST:PORT")
    host, _, port = rest.rpartition(":")
    host = host.removeprefix("[").removesuffix("]")
    if not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise MirrorscanError(f"--scheduler {address!r}: not a scheduler's address; give "
                              "tcp://HOST:PORT")
    return host, int(port)


def probe_scheduler(address: str, cancel=None, seconds: float = PROBE_SECONDS) -> None:
    """Check that a Dask scheduler answers at `address`.

    Connects, reads the handshake the scheduler sends first and sends it back (a well-formed
    handshake, so that the scheduler sees a client that left rather than garbage).

    Parameters
    ----------
    address : str
        As `scheduler_address`.
    cancel : threading.Event or callable, optional
        Looked at every POLL_SECONDS.
    seconds : float
        How long the peer has to connect and answer.

    Raises
    ------
    MirrorscanError
        One line: a bad address, nothing listening, a peer silent for `seconds`, or one that
        answers as something other than a Dask scheduler.
    Cancelled
        On a cancel request.
    """
    host, port = scheduler_address(address)
    deadline = time.monotonic() + seconds
    try:
        family, kind, proto, _, where = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0]
    except OSError as exc:
        raise MirrorscanError(f"--scheduler {address}: no such host ({exc})") from None
    with socket.socket(family, kind, proto) as sock:
        sock.setblocking(False)
        error = sock.connect_ex(where)
        if error not in (0, *_IN_PROGRESS):
            raise MirrorscanError(f"--scheduler {address}: no Dask scheduler answered "
                                  f"({_strerror(error)})")
        _wait(sock, "w", deadline, address, cancel)
        error = sock.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR)
        if error:
            raise MirrorscanError(f"--scheduler {address}: no Dask scheduler answered "
                                  f"({_strerror(error)})")
        head = _read(sock, 8, deadline, address, cancel)
        (size,) = struct.unpack("<Q", head)
        if not 0 < size <= MAX_HANDSHAKE_BYTES:
            raise _not_dask(address)
        body = _read(sock, size, deadline, address, cancel)
        if HANDSHAKE_KEY not in body:
            raise _not_dask(address)
        sock.setblocking(True)
        sock.settimeout(max(0.1, deadline - time.monotonic()))
        try:
            sock.sendall(head + body)
        except OSError:
            pass


_IN_PROGRESS = (errno.EINPROGRESS, errno.EWOULDBLOCK)


def _strerror(error: int) -> str:
    """An errno as its text ('Connection refused')."""
    return os.strerror(error)


def _not_dask(address: str) -> MirrorscanError:
    return MirrorscanError(f"--scheduler {address}: the peer there answers, but not as a Dask "
                           "scheduler (a dashboard or web port?); give the scheduler's port, "
                           "usually 8786")


def _wait(sock: socket.socket, what: str, deadline: float, address: str, cancel) -> None:
    """Wait until `sock` is readable ('r') or writable ('w'), looking at `cancel` meanwhile."""
    while True:
        if cancel_requested(cancel):
            raise Cancelled("cancelled while connecting to the Dask scheduler")
        left = deadline - time.monotonic()
        if left <= 0:
            raise MirrorscanError(f"--scheduler {address}: no answer as a Dask scheduler in "
                                  "time; give the scheduler's address, usually tcp://HOST:8786")
        readable, writable, _ = select.select([sock] if what == "r" else [],
                                              [sock] if what == "w" else [], [],
                                              min(POLL_SECONDS, left))
        if readable or writable:
            return


def _read(sock: socket.socket, count: int, deadline: float, address: str, cancel) -> bytes:
    """Read exactly `count` bytes before the deadline."""
    data = b""
    while len(data) < count:
        _wait(sock, "r", deadline, address, cancel)
        try:
            chunk = sock.recv(count - len(data))
        except OSError as exc:
            raise MirrorscanError(f"--scheduler {address}: the connection failed "
                                  f"({exc.strerror or exc})") from None
        if not chunk:
            raise _not_dask(address)
        data += chunk
    return data

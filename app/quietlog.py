"""What a stranger costs the server's log: a plain TCP probe (connect, close: a health check, a
port scan) is not logged at all (counted in QuietProbes.probes); a malformed HTTP request or
websocket message is one line, not a traceback."""
from __future__ import annotations

import logging
import threading
import traceback


class QuietProbes(logging.Filter):
    """A filter on the 'websockets.server' logger that keeps strangers out of the log.

    A connection closed before its request (a probe) is not logged; a malformed request, or a
    malformed message from a client (its connection is closed), is one line.

    Attributes
    ----------
    probes : int
        Connections closed before their request, in this process.
    """

    def __init__(self):
        super().__init__("")
        # connections closed before their request, in this process
        self.probes = 0
        self._lock = threading.Lock()

    def filter(self, record: logging.LogRecord) -> bool:
        """Drop a probe's record (counted in `probes`); make a malformed request's one line.

        Parameters
        ----------
        record : logging.LogRecord

        Returns
        -------
        bool
            Whether the record is logged.
        """
        exc = record.exc_info[1] if record.exc_info else None
        if exc is None:
            return True
        message = record.getMessage()
        if message == "opening handshake failed":
            if _is_probe(exc):
                with self._lock:
                    self.probes += 1
                return False
            return _one_line(record, f"bad request refused: {_describe(exc)}")
        if message == "connection handler failed" and _from_a_message(exc):
            return _one_line(record, "malformed message from a client, connection closed: "
                                     f"{_describe(exc)}")
        return True


def _is_probe(exc: BaseException) -> bool:
    """True when the connection ended before a whole request came in.

    EOFError or a reset, somewhere in the chain.
    """
    while exc is not None:
        if isinstance(exc, (EOFError, ConnectionError)):
            return True
        exc = exc.__cause__ or exc.__context__
    return False


def _from_a_message(exc: BaseException) -> bool:
    """True when the exception was raised while reading or decoding a client's message.

    In viser's consumer loop.
    """
    return any(frame.name == "_message_consumer"
               for frame in traceback.extract_tb(exc.__traceback__))


def _describe(exc: BaseException) -> str:
    """The exception's type and the first line of its message (160 characters at most)."""
    text = str(exc).splitlines()[0][:160] if str(exc) else ""
    return f"{type(exc).__name__}{': ' + text if text else ''}"


def _one_line(record: logging.LogRecord, text: str) -> bool:
    """Make `record` a one-line warning saying `text`, without its traceback; keep it."""
    record.msg, record.args, record.exc_info, record.exc_text = text, (), None, None
    record.levelno, record.levelname = logging.WARNING, "WARNING"
    return True


_filter = QuietProbes()


def install_log_filter() -> QuietProbes:
    """Put the QuietProbes filter first on the websockets server logger, once per process.

    First, because viser adds a filter of its own there (on its first page request) that drops every
    failed handshake silently, malformed requests included.

    Returns
    -------
    QuietProbes
        The filter.
    """
    logger = logging.getLogger("websockets.server")
    if _filter in logger.filters:
        logger.removeFilter(_filter)
    logger.filters.insert(0, _filter)
    return _filter

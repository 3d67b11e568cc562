"""Waiting on a condition instead of sleeping a fixed time."""
from __future__ import annotations

import time
from typing import Callable, TypeVar

T = TypeVar("T")


def wait_for(condition: Callable[[], T], seconds: float = 30.0, what: str = "condition") -> T:
    """Poll `condition()` every 20 ms until it returns something true, and return that.

    Raises
    ------
    AssertionError
        When `seconds` pass first; the message names `what`.
    """
    deadline = time.monotonic() + seconds
    while not (value := condition()):
        assert time.monotonic() < deadline, f"timed out after {seconds:g} s waiting for {what}"
        time.sleep(0.02)   # the polling interval
    return value

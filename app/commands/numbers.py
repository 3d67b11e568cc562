"""The command line's numbers, checked where argparse parses them.

Each function here makes an argparse `type=` that turns the text into a number or refuses it in one
line; argparse names the option (`mirrorscan.cli` prints it as '--seed: expected ...').
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def whole(low: int, high: int | None = None) -> Callable[[str], int]:
    """Return an argparse type for a whole number from `low` to `high` (inclusive).

    Parameters
    ----------
    low : int
    high : int, optional
        No upper limit when None.

    Returns
    -------
    callable
        text -> int; raises argparse.ArgumentTypeError naming the range.
    """
    wanted = _wanted("a whole number", low, high, above=False)

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {wanted}, got {text!r}") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"expected {wanted}, got {value}")
        return value

    return parse


def real(low: float | None = None, high: float | None = None, unit: str = "",
         above: bool = False) -> Callable[[str], float]:
    """Return an argparse type for a finite number from `low` to `high`.

    Parameters
    ----------
    low, high : float, optional
        The limits (inclusive); None: none on that side.
    unit : str
        Named in the message ('metres', 'mm', 'degrees').
    above : bool
        Refuse `low` itself (the value must be more than `low`).

    Returns
    -------
    callable
        text -> float; raises argparse.ArgumentTypeError naming the range and unit.
    """
    wanted = _wanted(f"a number of {unit}" if unit else "a finite number", low, high, above)

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {wanted}, got {text!r}") from None
        too_low = low is not None and (value <= low if above else value < low)
        if not math.isfinite(value) or too_low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"expected {wanted}, got {text}")
        return value

    return parse


def _wanted(kind: str, low: float | None, high: float | None, above: bool) -> str:
    """What a checker expects: 'a whole number from 1 to 3', 'a number of mm > 0'..."""
    if low is not None and high is not None and not above:
        return f"{kind} from {_shown(low)} to {_shown(high)}"
    limits = [f"{'>' if above else '>='} {_shown(low)}"] if low is not None else []
    limits += [f"<= {_shown(high)}"] if high is not None else []
    return " and ".join([kind + (f" {limits[0]}" if limits else ""), *limits[1:]])


def _shown(limit: float) -> str:
    """A limit as a person reads it: 65535, 1,000,000 rather than 1e+06, 0.0001 as it is."""
    if float(limit).is_integer() and abs(limit) < 1e15:
        return f"{int(limit):,}" if abs(limit) >= 100_000 else str(int(limit))
    return f"{limit:g}"


# a random generator's seed (numpy takes any whole number from 0)
seed = whole(0)

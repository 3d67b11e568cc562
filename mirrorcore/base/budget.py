"""The memory budget: the most that one piece of work may allocate when its size comes from a user's
or a file's numbers (a voxel grid, an image's header, an .npz's declared shapes, a frame file, an
upload, a recording's backlog). Every such path calls check_memory() with its estimate before
allocating, so that an absurd number is one line of refusal instead of a MemoryError, a swapping
machine or a killed process.

The budget is, in order: set_memory_budget() (the command line's --memory), the environment variable
MIRRORSCAN_MEMORY (e.g. '8G', '512M', '1.5GiB', or bytes), else DEFAULT_BUDGET or half the machine's
memory, whichever is smaller.
"""
from __future__ import annotations

import os
import re

from mirrorcore.base.errors import MirrorscanError

ENV = "MIRRORSCAN_MEMORY"
# bytes: 4 GiB (a 2 mm TSDF of 200^3 voxels needs 130 MB; 1 mm over 60 cm, 3.5 GB)
DEFAULT_BUDGET = 4 << 30
_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
_SIZE = re.compile(r"^\s*([0-9]*\.?[0-9]+)\s*([KMGT]?)(?:I?B)?\s*$", re.IGNORECASE)
_override: int | None = None


class MemoryBudgetError(MirrorscanError):
    """A piece of work would need more memory than the budget allows; nothing was allocated."""


def parse_size(text: str, where: str = ENV) -> int:
    """Read a size such as '4G', '512M', '1.5GiB' or '2048' (bytes) in bytes (powers of 1024).

    Parameters
    ----------
    text : str
        The size.
    where : str
        Where it comes from, for the message.

    Returns
    -------
    int
        The size in bytes.

    Raises
    ------
    MirrorscanError
        Naming `where`, when `text` is not a size or is less than 1 MiB.
    """
    match = _SIZE.match(str(text))
    if not match:
        raise MirrorscanError(
            f"{where}: {text!r} is not a size (write e.g. 8G, 512M or a number of bytes)")
    size = int(float(match.group(1)) * _UNITS[match.group(2).upper()])
    if size < 1 << 20:
        raise MirrorscanError(f"{where}: {text!r} is less than 1 MiB; nothing useful fits in it")
    return size


def default_budget() -> int:
    """DEFAULT_BUDGET, or half the machine's physical memory when that is less."""
    try:
        physical = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):   # not a POSIX system that says
        return DEFAULT_BUDGET
    return min(DEFAULT_BUDGET, physical // 2) if physical > 0 else DEFAULT_BUDGET


def memory_budget() -> int:
    """Return the budget in bytes now (see the module docstring).

    Returns
    -------
    int
        The budget in bytes.

    Raises
    ------
    MirrorscanError
        MIRRORSCAN_MEMORY is not a size.
    """
    if _override is not None:
        return _override
    text = os.environ.get(ENV, "").strip()
    return parse_size(text) if text else default_budget()


def set_memory_budget(size: int | str | None) -> None:
    """Set the memory budget for this process.

    Parameters
    ----------
    size : int, str or None
        Bytes, or a size such as '8G'; None goes back to the environment/default.

    Raises
    ------
    MirrorscanError
        `size` is a string that is not a size.
    """
    global _override
    _override = None if size is None else parse_size(size, "--memory") if isinstance(
        size, str) else int(size)


def check_memory(nbytes: float, what: str) -> None:
    """Refuse work whose estimated need exceeds the memory budget.

    Parameters
    ----------
    nbytes : float
        The bytes the work needs, estimated before allocating (NaN is refused).
    what : str
        The work and where it comes from, for the message ('volume 400x400x300',
        'scan.npz: depth').

    Raises
    ------
    MemoryBudgetError
        One line naming `what`, the need and the budget.
    """
    budget = memory_budget()
    if not nbytes <= budget:       # also refuses NaN
        raise MemoryBudgetError(
            f"{what}: needs {format_bytes(nbytes)}, more than the memory budget of "
                                f"{format_bytes(budget)} (set {ENV} or --memory to change it)")


def format_bytes(nbytes: float) -> str:
    """Write a number of bytes for a reader: 1536 -> '1.5 KiB', 5e9 -> '4.7 GiB'.

    Parameters
    ----------
    nbytes : float
        The number of bytes.

    Returns
    -------
    str
        Bytes below 1024, else KiB, MiB, GiB or TiB with one decimal.
    """
    value = float(nbytes)
    if value < 1024:
        return f"{value:.0f} bytes"
    for unit in ("KiB", "MiB", "GiB"):
        value /= 1024
        if value < 1024:
            return f"{value:.1f} {unit}"
    return f"{value / 1024:.1f} TiB"

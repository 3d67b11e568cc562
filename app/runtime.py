"""Process settings for mirrorscan's commands: keep the per-frame working buffers in the heap between frames.

Every frame allocates a few arrays of 1-5 MB. glibc serves blocks that large with mmap and returns them to the system
when they are freed, so the next frame pays a page fault per 4 KiB page again (about 1 ms per 5 MB here, several
times the arithmetic). Raising glibc's mmap and trim thresholds keeps those blocks in the heap for reuse. This only
tunes the allocator of our own process (the command line and the server); it changes no result.
"""
from __future__ import annotations

import ctypes
import ctypes.util

M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD = 256 * 1024 * 1024
TRIM_THRESHOLD = 512 * 1024 * 1024


def keep_frame_buffers() -> bool:
    """Apply the allocator settings when running on glibc; returns whether they were applied."""
    name = ctypes.util.find_library("c")
    if not name:
        return False
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError):   # not glibc (musl, macOS): nothing to tune
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))

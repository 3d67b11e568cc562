"""What a batch's frames were made from.

Each frame's depth file as a SHA-256 of its bytes, with its size and modification time so that a
rerun hashes only the files that changed (as rsync decides); the session's identity, a SHA-256 of
its calibration and other inputs and its frames' digests.
"""
from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from mirrorcore.base.errors import FileFormatError

# files hashed at once (hashlib releases the GIL on large buffers; the disk reads overlap)
HASH_THREADS = 4


@dataclass(frozen=True)
class DepthStamp:
    """A depth file's contents, and the size and modification time they were read at.

    Attributes
    ----------
    sha256 : str
        Of the file's bytes (hex).
    size : int
        Bytes.
    mtime_ns : int
        Nanoseconds since the epoch.
    """

    sha256: str
    size: int
    mtime_ns: int

    @classmethod
    def from_json(cls, data, where: str) -> DepthStamp:
        """Read {'sha256', 'size', 'mtime_ns'} (as dataclasses.asdict writes it).

        Raises
        ------
        FileFormatError
            Naming `where`, for anything else.
        """
        if (not isinstance(data, dict) or set(data) != {"sha256", "size", "mtime_ns"}
                or not isinstance(data["sha256"], str) or len(data["sha256"]) != 64
                or not all(type(data[k]) is int and data[k] >= 0 for k in ("size", "mtime_ns"))):
            raise FileFormatError(f"{where}: expected {{sha256, size, mtime_ns}}, got {data!r}")
        return cls(**data)


def depth_stamps(files: Sequence[Path], known: Mapping[int, DepthStamp] | None = None
                 ) -> list[DepthStamp | None]:
    """Return the stamp of every depth file, hashing only those whose size or time changed.

    Parameters
    ----------
    files : sequence of Path
        Each frame's depth file.
    known : mapping of int to DepthStamp, optional
        Frame index -> its stamp of an earlier run: kept as it is when the file still has that
        size and modification time.

    Returns
    -------
    list of DepthStamp or None
        One per file; None for a file that is missing or cannot be read (its frame fails when it
        is reconstructed, with the error).
    """
    known = known or {}

    def stamp(index: int) -> DepthStamp | None:
        path = files[index]
        try:
            info = path.stat()
            old = known.get(index)
            if old is not None and (old.size, old.mtime_ns) == (info.st_size, info.st_mtime_ns):
                return old
            digest = hashlib.sha256(path.read_bytes()).hexdigest()
        except OSError:
            return None
        return DepthStamp(digest, info.st_size, info.st_mtime_ns)

    threads = min(HASH_THREADS, os.cpu_count() or 1)
    with ThreadPoolExecutor(threads) as pool:
        return list(pool.map(stamp, range(len(files))))


def session_digest(inputs: dict, stamps: Sequence[DepthStamp | None]) -> str:
    """Return the identity of a session's contents.

    The SHA-256 of what the output depends on in it (job.session_inputs: the calibration, the
    selection, the background's digest, the frame list) and of its frames' digests, in order (an
    empty line for a file that cannot be read).

    Parameters
    ----------
    inputs : dict
        JSON.
    stamps : sequence of DepthStamp or None

    Returns
    -------
    str
        Hex.
    """
    frames = "\n".join("" if s is None else s.sha256 for s in stamps)
    text = json.dumps(inputs, sort_keys=True) + "\n" + frames
    return hashlib.sha256(text.encode("utf-8")).hexdigest()

"""The output folder of a batch: one PLY file per frame and manifest.json (the session and the
identity of its contents, the method and its options, what the output depends on in the session,
every frame done with its counts, time and depth file's digest, the frames that failed), written
atomically; a lock so that one run at a time writes into it; the frames of an earlier run that can
be kept.

A frame is done when the manifest lists it, its file is there with the size and the element counts
the manifest gives (a file is only ever replaced whole, so this finds files removed or replaced
since) and the depth files it was made from still have the digests the manifest gives. Frames
written by a run that was killed before it wrote them into the manifest are simply done again.
"""
from __future__ import annotations

import fcntl
import json
import os
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

from mirrorcore.base.atomic import make_durable, write_atomic
from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.base.jsonfile import read_json
from mirrorcore.batch.digests import depth_stamps, session_digest
from mirrorcore.batch.job import differences
from mirrorcore.batch.records import FrameRecord, require_count
from mirrorcore.depth.temporal import frame_window

MANIFEST_FILE = "manifest.json"
LOCK_FILE = ".mirrorscan-batch.lock"
# the manifest is rewritten at most this share of the time (it grows with the frames)
FLUSH_SHARE = 0.05
MIN_FLUSH_SECONDS = 0.1
# ...but never further apart than this, however long one write took (a busy disk)
MAX_FLUSH_SECONDS = 2.0
VERSION = 2
# the versions read: 1 has no digests of the session's contents (see OutputFolder)
READS = (1, 2)
KIND = "mirrorscan batch reconstruction"


@dataclass
class Manifest:
    """manifest.json in memory.

    Attributes
    ----------
    session : str
    settings : dict
        {'method', 'options'} of the job (BatchJob.settings).
    inputs : dict
        What the output depends on in the session (job.session_inputs).
    total : int
        The session's frame count.
    done : dict of int to FrameRecord
        Index -> record.
    failed : dict of int to str
        Index -> one-line error of the last attempt.
    session_sha256 : str or None
        The identity of the session's contents (digests.session_digest; None in a version-1
        manifest).
    """

    session: str
    settings: dict
    inputs: dict
    total: int
    done: dict[int, FrameRecord] = field(default_factory=dict)
    failed: dict[int, str] = field(default_factory=dict)
    session_sha256: str | None = None
    _lines: dict[int, tuple[FrameRecord, str]] = field(default_factory=dict, repr=False,
                                                       compare=False)

    @property
    def complete(self) -> bool:
        """True when every frame is done."""
        return len(self.done) == self.total

    def text(self) -> str:
        """Return manifest.json's text: the settings indented, then one line per frame done.

        Each line is made once and kept: 18,000 frames are rewritten in a few tens of milliseconds.
        """
        head = {"version": VERSION, "kind": KIND, "session": self.session,
                "session_sha256": self.session_sha256, **self.settings,
                "inputs": self.inputs,
                "total": self.total, "complete": self.complete,
                "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                "failed": [{"index": i, "error": self.failed[i]} for i in sorted(self.failed)]}
        for i, record in self.done.items():
            if self._lines.get(i, (None,))[0] is not record:
                self._lines[i] = (record, json.dumps(asdict(record)))
        frames = ",\n".join(self._lines[i][1] for i in sorted(self.done))
        return json.dumps(head, indent=1)[:-2] + f',\n "frames": [\n{frames}\n ]\n}}\n'

    @classmethod
    def from_json(cls, data, where: str) -> Manifest:
        """Read a parsed manifest.json.

        Parameters
        ----------
        data : object
            The parsed JSON.
        where : str
            For the messages.

        Returns
        -------
        Manifest

        Raises
        ------
        FileFormatError
            Not the manifest of a batch reconstruction, or a bad record.
        """
        if not isinstance(data, dict) or data.get("kind") != KIND:
            raise FileFormatError(f"{where}: not the manifest of a batch reconstruction")
        if data.get("version") not in READS:
            raise FileFormatError(
                f"{where}: unknown version {data.get('version')!r}; this mirrorscan writes "
                                  f"version {VERSION}")
        try:
            settings = {"method": str(data["method"]), "options": dict(data["options"])}
            records = [FrameRecord.from_json(r, f"{where}: frames[{k}]") for k,
                       r in enumerate(data["frames"])]
            failed = {require_count(f["index"], f"{where}: failed[{k}].index"): str(f["error"])
                      for k, f in enumerate(data["failed"])}
            identity = data.get("session_sha256")
            if identity is not None and not isinstance(identity, str):
                raise TypeError(f"session_sha256 is {identity!r}")
            return cls(str(data["session"]), settings, dict(data["inputs"]),
                       require_count(data["total"], f"{where}: total"),
                       {r.index: r for r in records}, failed, identity)
        except (KeyError, TypeError, ValueError) as exc:
            raise FileFormatError(
                f"{where}: missing or malformed key ({type(exc).__name__}: {exc})") from None


class OutputFolder:
    """A batch's output folder, held for one run.

    Created when missing, locked against a second run, stale temporary files of a killed run
    removed, the manifest read and checked against this run's session, settings and inputs.

    A frame of the manifest is kept when its file is intact and the depth files it was made from
    (its own, and its neighbours with temporal smoothing) have the digests the manifest gives;
    a depth file is hashed again only when its size or time changed. A manifest of another
    session folder is refused unless the session's contents are the same (a session moved or
    copied whole). A version-1 manifest (no digests) is read: for the same session folder its
    frames are kept and their depth files taken as they are now; for another folder, refused.

    Parameters
    ----------
    path : Path
    session : str
        The session folder (absolute).
    settings : dict
        The job's settings (BatchJob.settings).
    inputs : dict
        What the output depends on (job.session_inputs).
    names : tuple of str
        Each frame's output file name.
    depth_files : sequence of Path
        Each frame's depth file.
    overwrite : bool
        Accept a manifest of another session, or made with other settings or inputs: every frame
        is done again, and the files of frames that are not in the session are removed.

    Attributes
    ----------
    depths : list of DepthStamp or None
        Each frame's depth file as hashed now (None: it cannot be read).

    Raises
    ------
    MirrorscanError
        One line: a folder that holds other files and no manifest, a folder another run is writing
        into, or a manifest of another session or made with other settings or inputs unless
        `overwrite`.
    """

    def __init__(self, path: Path, session: str, settings: dict, inputs: dict,
                 names: tuple[str, ...], depth_files: Sequence[Path],
                 overwrite: bool = False):
        self.path = Path(path)
        self._flushed = self._flush_seconds = 0.0
        # frames added since the last write of the manifest
        self._unflushed: list[FrameRecord] = []
        self._lock = _lock(self.path)
        try:
            _remove_stale_temporaries(self.path)
            old = self._read_old()
            # as read back
            settings, inputs = json.loads(json.dumps(settings)), json.loads(json.dumps(inputs))
            # the sizes and times of the same folder's files spare hashing them again
            known = {} if old is None or old.session != session else {
                i: r.depth for i, r in old.done.items() if r.depth is not None}
            self.depths = depth_stamps(depth_files, known)
            self.manifest = Manifest(session, settings, inputs, len(names),
                                     session_sha256=session_digest(inputs, self.depths))
            self.kept = self._keep(old, names, overwrite)
            self.manifest.done.update(self.kept)
            self.flush()
        except BaseException:
            self.close()
            raise

    def _read_old(self) -> Manifest | None:
        """Read the folder's manifest; None for a folder with none and no other files."""
        file = self.path / MANIFEST_FILE
        if not file.exists():
            others = [p.name for p in self.path.iterdir() if p.name != LOCK_FILE]
            if others:
                raise MirrorscanError(
                    f"{self.path}: already holds files ({others[0]}...) and no {MANIFEST_FILE}; "
                                      "choose a new or empty folder")
            return None
        return Manifest.from_json(read_json(file, "manifest"), str(file))

    def _keep(self, old: Manifest | None, names: tuple[str, ...], overwrite: bool) -> dict[
        int, FrameRecord]:
        """The frames of the old manifest that this run keeps (see the class docstring)."""
        if old is None:
            return {}
        new = self.manifest
        if old.session != new.session and old.session_sha256 != new.session_sha256 and (
                not overwrite):
            raise MirrorscanError(f"{self.path / MANIFEST_FILE}: its frames are of the session "
                                  f"{old.session}, not {new.session}; use --overwrite to redo "
                                  "every frame, or another folder")
        changed = differences({**old.settings, **old.inputs},
                              {**self.manifest.settings, **self.manifest.inputs})
        if changed and not overwrite:
            said = ", ".join(change.removeprefix("options.") for change in changed)
            raise MirrorscanError(f"{self.path / MANIFEST_FILE}: its frames were made with other "
                                  f"settings ({said}); use --overwrite to redo every frame, or "
                                  "another folder")
        if overwrite:
            for record in old.done.values():
                if record.file not in names:
                    (self.path / record.file).unlink(missing_ok=True)
            return {}
        temporal = new.settings["options"].get("temporal", 0)

        def unchanged(index: int) -> bool:
            if old.done[index].depth is None:
                return True
            return all(j in old.done and None not in (old.done[j].depth, self.depths[j])
                       and old.done[j].depth.sha256 == self.depths[j].sha256
                       for j in frame_window(index, temporal, len(names)))

        return {i: replace(r, depth=self.depths[i]) for i, r in old.done.items()
                if i < len(names) and r.file == names[i] and unchanged(i)
                and r.intact(self.path)}

    def add(self, records: list[FrameRecord], failures: dict[int, str]) -> None:
        """Record frames done and frames failed.

        The manifest is written when the time since the last write is at least MIN_FLUSH_SECONDS and
        1 / FLUSH_SHARE times what that write took, and at most MAX_FLUSH_SECONDS: often for a short
        recording, every 0.6 s or so for 18,000 frames, never a large share of the run; a write
        slowed by a busy disk does not leave the next one far behind the frames.

        Parameters
        ----------
        records : list of FrameRecord
        failures : dict of int to str
            {frame: one-line error}.
        """
        records = [replace(r, depth=self.depths[r.index]) for r in records]
        for r in records:
            self.manifest.done[r.index] = r
            self.manifest.failed.pop(r.index, None)
        self._unflushed += records
        self.manifest.failed.update(failures)
        interval = min(max(MIN_FLUSH_SECONDS, self._flush_seconds / FLUSH_SHARE), MAX_FLUSH_SECONDS)
        if time.monotonic() - self._flushed >= interval:
            self.flush()

    def flush(self) -> None:
        """Flush the frames' files added since the last write to the disk, then write the manifest.

        The workers write the files without flushing them; the manifest is written atomically and
        lists a frame only once its file is on the disk.

        Raises
        ------
        OSError
            Naming the file that could not be flushed or written (the manifest on the disk is then
            the last one written).
        """
        start = time.monotonic()
        for record in self._unflushed:
            make_durable(self.path / record.file)
        self._unflushed = []
        write_atomic(self.path / MANIFEST_FILE, self.manifest.text().encode("utf-8"))
        self._flushed = time.monotonic()
        self._flush_seconds = self._flushed - start

    def close(self) -> None:
        """Release the lock (the manifest is left as last flushed)."""
        if self._lock is not None:
            os.close(self._lock)
            self._lock = None


def _lock(folder: Path) -> int:
    """Create `folder` if needed and take its lock (a file descriptor, released by os.close);
    MirrorscanError when another process holds it."""
    if folder.exists() and not folder.is_dir():
        raise MirrorscanError(f"{folder}: exists and is not a folder")
    folder.mkdir(parents=True, exist_ok=True)
    fd = os.open(folder / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise MirrorscanError(
            f"{folder}: another mirrorscan run is writing into this folder") from None
    return fd


def _remove_stale_temporaries(folder: Path) -> None:
    """Remove the temporary files that atomic writes leave when their process is killed
    ('.NAME.XXXX.tmp')."""
    for path in folder.glob(".*.tmp"):
        if path.name.startswith(f".{MANIFEST_FILE}.") or ".ply." in path.name:
            path.unlink(missing_ok=True)


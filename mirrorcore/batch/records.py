"""One frame of a batch in its manifest: its PLY file with the counts and size that tell it intact,
and the depth file it was made from."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mirrorcore.base.errors import FileFormatError
from mirrorcore.batch.digests import DepthStamp
from mirrorcore.io.ply import ply_element_counts


@dataclass(frozen=True)
class FrameRecord:
    """One frame done.

    Attributes
    ----------
    index : int
        Its index in the session (0-based).
    file : str
        Its file name in the folder.
    vertices : int
        The PLY's vertex count (points of a cloud, vertices of a mesh).
    faces : int or None
        Face count (None for clouds).
    sources : tuple of int
        Vertices per source (direct, mirror 1, ...).
    bytes : int
        The file's size.
    seconds : float
        The time it took (read, reconstruct, write).
    depth : DepthStamp or None
        The frame's depth file as it was read (None in a version-1 manifest).
    """

    index: int
    file: str
    vertices: int
    faces: int | None
    sources: tuple[int, ...]
    bytes: int
    seconds: float
    depth: DepthStamp | None = None

    @classmethod
    def from_json(cls, data, where: str) -> FrameRecord:
        """Read a record of manifest.json.

        Parameters
        ----------
        data : object
            The parsed JSON.
        where : str
            For the messages.

        Returns
        -------
        FrameRecord

        Raises
        ------
        FileFormatError
            One line naming the record and the key.
        """
        if not isinstance(data, dict):
            raise FileFormatError(f"{where}: not a frame record")
        try:
            depth = data.get("depth")
            record = cls(**{**data, "sources": tuple(data["sources"]),
                            "depth": None if depth is None else DepthStamp.from_json(
                                depth, f"{where}.depth")})
        except (TypeError, KeyError) as exc:
            raise FileFormatError(f"{where}: not a frame record ({exc})") from None
        numbers = {"index": record.index, "vertices": record.vertices, "bytes": record.bytes,
                   **({} if record.faces is None else {"faces": record.faces}),
                   **{f"sources[{k}]": n for k, n in enumerate(record.sources)}}
        for key, value in numbers.items():
            require_count(value, f"{where}.{key}")
        if (isinstance(record.seconds, bool) or not isinstance(record.seconds, (int, float))
                or not 0 <= record.seconds < float("inf")):
            raise FileFormatError(f"{where}.seconds: expected seconds >= 0, got "
                                  f"{record.seconds!r}")
        if (not isinstance(record.file, str) or Path(record.file).name != record.file
                or not record.file.endswith(".ply")):
            raise FileFormatError(
                f"{where}: file {record.file!r} is not a PLY file name of this folder")
        return record

    def intact(self, folder: Path) -> bool:
        """Tell whether the file is in `folder` with this record's size and element counts.

        Parameters
        ----------
        folder : Path

        Returns
        -------
        bool
        """
        path = folder / self.file
        try:
            if path.stat().st_size != self.bytes:
                return False
            counts = ply_element_counts(path)
        except (OSError, FileFormatError):
            return False
        return counts.get("vertex") == self.vertices and counts.get("face") == self.faces


def require_count(value, where: str) -> int:
    """Return `value` if it is a whole number >= 0 (not a bool); FileFormatError naming `where`."""
    if type(value) is not int or value < 0:
        raise FileFormatError(f"{where}: expected a whole number >= 0, got {value!r}")
    return value

"""The live cloud as it travels to a browser tab.

At most MAX_POINTS points a frame, one node per source and half, positions as float16 offsets from
the part's centre (6 bytes a point instead of 12) wherever that keeps every point within 0.3 mm,
float32 where a part is too large for it. A node takes its source's colour (one colour for all its
points), or in true colour each point's colour as 3 bytes (uint8 RGB, the cloud's `rgb`): 9 bytes
a point.

Each source's points are split into two interleaved halves (every other point); a live frame
refreshes one half (even frames the first, odd frames the second), so a tab always shows every
point while receiving half of them per frame; a paused or single frame sends both. A source keeps
its centre from frame to frame while its points stay within reach of it (Anchors), so that a tab
moves no node: viser's pose update costs about half of a node's update.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from mirrorcore.rig.cloud import Cloud
from mirrorcore.rig.colour import rgb_words

MAX_POINTS = 60_000          # points shown per frame, all sources together (evenly strided)
FLOAT16_EXTENT = 1.0         # metres: offsets below this round to float16 within 2^-12 m (0.24 mm)
HALVES = 2


@dataclass(frozen=True, eq=False)
class SourcePart:
    """One half of one source's points of a frame.

    Attributes
    ----------
    source, half : int
        The source label and which half.
    centre : (3,) float64 ndarray
        Metres, camera frame.
    offsets : (n, 3) float16 or float32 ndarray
        Metres from the centre.
    colours : (n, 3) uint8 ndarray or None
        Each point's RGB; None: its source's colour.
    """

    source: int
    half: int
    centre: np.ndarray
    offsets: np.ndarray
    colours: np.ndarray | None = None

    @property
    def key(self) -> tuple[int, int]:
        """(source, half): the part's node."""
        return self.source, self.half


class Anchors:
    """Each source's centre, kept from one frame to the next while the source's points stay near it.

    A centre, (3,) float32 metres, is kept while every point of the part at hand lies within
    FLOAT16_EXTENT of it along each axis (the walking person's box moves, but rarely out of
    reach): the halves of a source then share it too.
    """

    def __init__(self) -> None:
        self._centres: dict[int, np.ndarray] = {}

    def centre(self, source: int, low: np.ndarray, high: np.ndarray) -> np.ndarray:
        """The centre for a source's part whose points span the box [low, high].

        The kept one while it reaches the whole box, else the box's middle (kept from now on).

        Parameters
        ----------
        source : int
            The source label.
        low, high : np.ndarray, shape (3,), float32
            The box's corners (metres).

        Returns
        -------
        np.ndarray, shape (3,), float32
        """
        kept = self._centres.get(source)
        if kept is not None and float(np.maximum(high - kept, kept - low).max()) < FLOAT16_EXTENT:
            return kept
        self._centres[source] = centre = (low + high) / np.float32(2)
        return centre


def downsample(cloud: Cloud, max_points: int) -> Cloud:
    """Every k-th point so that at most `max_points` remain.

    The order is row-major, so this thins evenly.

    Parameters
    ----------
    cloud : Cloud
    max_points : int

    Returns
    -------
    Cloud
    """
    step = max(1, int(np.ceil(len(cloud) / max_points)))
    return cloud if step == 1 else cloud.select(slice(None, None, step))


def stream_parts(cloud: Cloud, labels, max_points: int = MAX_POINTS, halves=range(HALVES),
                 anchors: Anchors | None = None, true_colour: bool = False) -> list[SourcePart]:
    """The `halves` of the sources `labels`, downsampled to at most `max_points`.

    A part's centre is the middle of its points' box, or the one `anchors` kept for its source. A
    live frame asks for the one half it sends: half the gathering and conversion.

    Parameters
    ----------
    cloud : Cloud
        The frame's cloud (metres).
    labels : iterable of int
        Source labels, in order; empty ones included, so that a source that left the view is
        cleared.
    max_points : int, optional
    halves : iterable of int, optional
        All by default.
    anchors : Anchors, optional
    true_colour : bool, optional
        Each part carries its points' colours (the cloud's `rgb`, which it must have).

    Returns
    -------
    list of SourcePart
    """
    cloud = downsample(cloud, max_points)
    # (3, n): numpy gathers and reduces rows about 30 times faster than columns
    rows = cloud.points.T
    words = rgb_words(cloud.rgb) if true_colour else None
    parts = []
    for j in labels:
        mine = np.flatnonzero(cloud.sources == j)
        for half in halves:
            taken = mine[half::HALVES]
            part = _part(j, half, np.take(rows, taken, axis=1), anchors)
            if words is not None:
                part = replace(part, colours=_colours(words, taken))
            parts.append(part)
    return parts


def _colours(words: np.ndarray, taken: np.ndarray) -> np.ndarray:
    """(k, 3) uint8 C-ordered: the colours of the points `taken` (k,) from their words (n,)
    uint32 (mirrorcore.rig.colour.rgb_words: a part's colours are single-element takes, about 20
    times faster than taking (n, 3) rows of the strided view Algorithm 1 gives)."""
    if not len(taken):
        # a source with no points here: cvtColor refuses an empty image
        return np.empty((0, 3), np.uint8)
    rgba = np.take(words, taken).view(np.uint8).reshape(-1, 1, 4)
    return cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB).reshape(-1, 3)


def _part(source: int, half: int, columns: np.ndarray, anchors: Anchors | None) -> SourcePart:
    """The part of (3, k) float32 rows of points.

    Float16 offsets where they reach every point, else float32.
    """
    if not columns.shape[1]:
        return SourcePart(source, half, np.zeros(3), np.zeros((0, 3), np.float16))
    low, high = columns.min(axis=1), columns.max(axis=1)
    centre = (low + high) / np.float32(2) if anchors is None else anchors.centre(source, low, high)
    reach = float(np.maximum(high - centre, centre - low).max())
    dtype = np.float16 if reach < FLOAT16_EXTENT else np.float32
    return SourcePart(source, half, centre.astype(np.float64), _offsets(columns, centre, dtype))


def _offsets(columns: np.ndarray, centre: np.ndarray, dtype) -> np.ndarray:
    """The offsets of points from their centre, C-ordered, in `dtype`.

    `columns` are (3, k) float32 rows of points, `centre` (3,) float32; the result is (k, 3).
    Subtracted and converted along the rows, then transposed by OpenCV (float16 as its bits):
    about 3 times faster than numpy writing the transposed result, with the same bits.
    """
    rows = np.subtract(columns, centre[:, None]).astype(dtype, copy=False)
    bits = rows.view(np.uint16) if dtype == np.float16 else rows
    return cv2.transpose(bits).view(dtype)

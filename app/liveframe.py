"""A processed live frame and its processing: the object selected in a source frame and Algorithm 1
run on it with the session's rig."""
from __future__ import annotations

import time
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from mirrorcore.rig.cloud import Cloud
from mirrorcore.rig.pipeline import prepare_frame
from mirrorcore.rig.reconstruct import reconstruct_raw
from mirrorcore.sources import Frame

from .overlays import depth_layer, depth_range
from .state import Snapshot
from .stream import HALVES, Anchors, SourcePart, stream_parts


@dataclass(frozen=True, eq=False)
class LiveFrame:
    """One processed frame.

    Attributes
    ----------
    index : int
        Its running index in the loop.
    timestamp : float
        The source's, seconds.
    depth, prepared_depth : (H, W) ndarray
        Metres, as read and as Algorithm 1 used it (smoothed on the object).
    mask : (H, W) bool ndarray
        The object.
    cloud : Cloud
        The merged cloud.
    snapshot : Snapshot
        The session and rig it was processed with.
    process_ms : float
        The processing time, ms.
    anchors : Anchors
        The stream's centres kept from the frames before (mirrorscan.stream.Anchors).
    colour : (H, W, 3) uint8 ndarray or None
        The source's colour image registered to the depth (Frame.colour); None without colour.
    """

    index: int
    timestamp: float
    depth: np.ndarray
    prepared_depth: np.ndarray
    mask: np.ndarray
    cloud: Cloud
    snapshot: Snapshot
    process_ms: float
    anchors: Anchors
    colour: np.ndarray | None = None

    # What the tabs show of it, made once by the first tab that asks (a frozen dataclass keeps
    # cached properties).
    @cached_property
    def mirror_ids(self) -> tuple[int, ...]:
        """The ids of the mirrors in session order: a source's colour follows its mirror's id."""
        return tuple(m.id for m in self.snapshot.session.mirrors)

    @cached_property
    def counts(self) -> dict[int, int]:
        """Points per source label (Cloud.source_counts).

        The direct view and every mirror, then each view through several mirrors that has points.
        """
        return self.cloud.source_counts(len(self.snapshot.rig.mirrors))

    def parts(self, half: int | None = None, true_colour: bool = False) -> list[SourcePart]:
        """The cloud as it is streamed (see mirrorscan.stream).

        Each half is made once for each colouring, by the first tab that asks for it.

        Parameters
        ----------
        half : int or None, optional
            One half's parts, or both halves' (None).
        true_colour : bool, optional
            Each point's colour with it (the cloud's `rgb`, when it has one), rather than its
            source's.

        Returns
        -------
        list of SourcePart
        """
        if half is None:
            return [part for h in range(HALVES) for part in self.parts(h, true_colour)]
        key = (half, true_colour and self.cloud.rgb is not None)
        if key not in self._parts:
            self._parts[key] = stream_parts(self.cloud, list(self.counts), halves=(half,),
                                            anchors=self.anchors, true_colour=key[1])
        return self._parts[key]

    @cached_property
    def _parts(self) -> dict[tuple[int, bool], list[SourcePart]]:
        """The parts made so far, by (half, true colour)."""
        return {}

    @cached_property
    def depth_range(self) -> tuple[float, float]:
        """(near, far) metres of the depth frame's grey scale."""
        return depth_range(self.depth)

    @cached_property
    def depth_rgb(self) -> np.ndarray:
        """(H, W, 3) uint8: the depth frame with the object tinted, under every tab's overlay."""
        return depth_layer(self.depth, self.mask, *self.depth_range)

    def screen_rgb(self, colour_image: bool) -> np.ndarray:
        """(H, W, 3) uint8: what a tab's depth-frame screen shows under its overlay.

        Parameters
        ----------
        colour_image : bool
            The colour image, when the frame has one; else (or without one) depth_rgb.
        """
        return self.colour if colour_image and self.colour is not None else self.depth_rgb


def frame_number(index: int, frame_count: int | None) -> int:
    """A live frame's number as the technician sees it.

    Parameters
    ----------
    index : int
        The loop's running index.
    frame_count : int or None
        The recording's frame count; None (or 0) for a live source.

    Returns
    -------
    int
        Its place in the recording that plays (which loops; from 0, as the frame slider and the
        recording's files count), or its running index for a live source.
    """
    return index % frame_count if frame_count else index


def process_frame(snapshot: Snapshot, index: int, frame: Frame, anchors: Anchors) -> LiveFrame:
    """Select the object in a source frame and run Algorithm 1 on it with the snapshot's rig.

    Parameters
    ----------
    snapshot : Snapshot
        The state the frame is processed with.
    index : int
        The loop's running index.
    frame : Frame
        The source's frame (depth in metres; its colour, when it has one, colours the cloud).
    anchors : Anchors
        The stream's centres, kept from frame to frame.

    Returns
    -------
    LiveFrame
        With the processing time (ms).
    """
    t0 = time.perf_counter()
    prepared, mask = prepare_frame(snapshot.rig, frame.depth, snapshot.backdrop,
                                   snapshot.session.selection)
    cloud = reconstruct_raw(snapshot.rig, prepared, mask, frame.colour)
    return LiveFrame(index, frame.timestamp, frame.depth, prepared, mask, cloud, snapshot,
                     (time.perf_counter() - t0) * 1e3, anchors, frame.colour)

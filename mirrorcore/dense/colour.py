"""The colour of dense results: each view's pixels divided by the colour gains of the mirrors the
view reflects on (Rig.colour_correction by its source label), so that every view shows the
surface's own colour.

Fusion (mirrorcore.dense.tsdf): a voxel's colour is the mean of the corrected colour of the pixel
nearest each view's projection of it, weighted by the view's distance weight, over the views and
frames that see the voxel within the truncation of their surface (a view that sees it as empty sees
the colour of a surface behind it). `FusedColour` computes it for the voxels asked for (the mesh
asks for the ends of its edges), from the tables the fusion read. Carving
(mirrorcore.dense.carve): a kept voxel's colour is the mean of the corrected colours of the views
whose nearest pixel shows the object within the carving threshold of the voxel (`voxel_colours`).

Colour images are packed as one 4-byte word a pixel (red, green, blue, 1) so that a voxel's colour
and its weight's 1 are one take; the 1 sums the weights beside the colours.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import cv2
import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.rig.colour import check_colour_image
from mirrorcore.rig.model import Rig
from mirrorcore.dense.blockfusion import view_weight
from mirrorcore.dense.sampling import (BORDER, QuadTable, pixel_index, project, project_blocks,
                                       transform)
from mirrorcore.dense.views import View, padded_flat
from mirrorcore.dense.volume import CHUNK_VOXELS, Volume, run_chunks

# bytes per kept voxel while carving's colours are computed (float32 sums, takes, pixels)
CARVE_COLOUR_BYTES = 96


def colour_frames(intr: Intrinsics, colours, count: int) -> np.ndarray:
    """Check the colour images of `count` frames.

    Parameters
    ----------
    intr : Intrinsics
        The depth camera.
    colours : (H, W, 3) or (F, H, W, 3) uint8 array
        RGB registered to the depth frames.
    count : int
        F, the depth frames.

    Returns
    -------
    (F, H, W, 3) uint8 array

    Raises
    ------
    MirrorscanError
        Not one colour image per depth frame, or not 8-bit RGB of the depth image's size.
    """
    colours = np.asarray(colours)
    colours = colours[None] if colours.ndim == 3 else colours
    if len(colours) != count:
        raise MirrorscanError(f"dense: {len(colours)} colour images for {count} depth frames")
    for image in colours:
        check_colour_image(intr, image, "dense colour image")
    return colours


def packed_padded(image: np.ndarray) -> np.ndarray:
    """Pack a colour image on the padded grid of sampling.Quads.

    Parameters
    ----------
    image : (H, W, 3) uint8 array

    Returns
    -------
    ((H + 2 BORDER) * (W + 2 BORDER),) uint32 array
        Each pixel's bytes red, green, blue, 1 (zeros in the padding).
    """
    return np.pad(_words(image), BORDER).reshape(-1)


def packed_flat(image: np.ndarray) -> np.ndarray:
    """Pack a colour image in View's flat layout.

    Parameters
    ----------
    image : (H, W, 3) uint8 array

    Returns
    -------
    (H*W + 1,) uint32 array
        Each pixel's bytes red, green, blue, 1; the pad cell last, zero.
    """
    return padded_flat(_words(image), 0)


def _words(image: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 RGB -> (H, W) uint32, each pixel's bytes red, green, blue, 1."""
    out = np.empty((*image.shape[:2], 4), np.uint8)
    out[..., :3] = image
    out[..., 3] = 1
    return out.view(np.uint32)[..., 0]


@dataclass(frozen=True, eq=False)
class FusedColour:
    """What a fusion with colour read, to colour voxels with.

    Attributes
    ----------
    rig : Rig
    tables : list of QuadTable
        Each view's surface quads over the frames.
    to_views : list of (3, 4) array
        Each view's extrinsic.
    labels : list of int
        Each view's source label.
    truncation : float
        Metres.
    packed : list of (Hp*Wp,) uint32 array
        Each frame's colour image (`packed_padded`).
    """

    rig: Rig
    tables: list[QuadTable]
    to_views: list[np.ndarray]
    labels: list[int]
    truncation: float
    packed: list[np.ndarray]

    def colours(self, volume: Volume, ijk: np.ndarray) -> np.ndarray:
        """Return the fused colours of voxels (see the module docstring).

        The weights and the views' depths are the fusion's. The fusion's culling (the camera's
        empty space, the mirrors' back sides) sets every view's weight of a voxel to 0, so it does
        not concern the voxels it observed (weight > 0), the ones a mesh asks for; a voxel of
        weight 0 gets the colour its views give.

        Parameters
        ----------
        volume : Volume
        ijk : (k, 3) integer array
            The voxels' indices in the volume.

        Returns
        -------
        (k, 4) uint8 array
            Red, green, blue levels (rounded, saturated at 255), and 1 where some view gave a colour
            (0 and black elsewhere).
        """
        ijk = np.asarray(ijk).reshape(-1, 3)
        axes = [a.astype(np.float32) for a in volume.axes()]
        out = np.empty((len(ijk), 4), np.uint8)

        def work(rows: slice) -> None:
            x, y, z = (np.take(a, ijk[rows, c]) for c, a in enumerate(axes))
            out[rows] = self._colours(x, y, z)

        # one chunk per thread, each at most CHUNK_VOXELS
        step = max(1, min(CHUNK_VOXELS, -(-len(ijk) // (os.cpu_count() or 1))))
        run_chunks([slice(start, start + step) for start in range(0, len(ijk), step)], work)
        return out

    def _colours(self, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The colours (k, 4) uint8 of voxel centres x, y, z (k,) float32."""
        rig, trunc = self.rig, np.float32(self.truncation)
        intr, correction = rig.intrinsics, rig.colour_correction
        total = np.zeros((len(x), 4), np.float32)
        width = intr.width + 2 * BORDER
        for table, to_view, label in zip(self.tables, self.to_views, self.labels):
            projection = project_blocks(intr, to_view, x, y, z)
            weight = view_weight(projection, None)
            slots = table.slots(projection)
            pixel = np.add(projection.index, projection.fu >= 0.5)
            pixel += (projection.fv >= 0.5) * width
            for frame, packed in enumerate(self.packed):
                with np.errstate(invalid="ignore"):
                    sdf = table.surface_depth(frame, slots, projection)
                    sdf -= projection.z
                    band = (sdf > -trunc) & (sdf < trunc)
                # the band's pixels show the surface; the others may be padding
                rgba = np.take(packed, pixel, mode="clip").view(np.uint8).reshape(-1, 4)
                rgba = rgba.astype(np.float32)
                rgba *= (weight * band)[:, None]
                rgba *= correction[label]
                total += rgba
        return finished_colours(total)


def finished_colours(total: np.ndarray) -> np.ndarray:
    """Return the weighted mean colours of sums.

    Parameters
    ----------
    total : (n, 4) float32 array
        Sums of weight x colour (red, green, blue) and of the weights; scaled in place.

    Returns
    -------
    (n, 4) uint8 array
        Red, green, blue levels (rounded, saturated at 255), and 1 where some view gave a colour
        (0 and black elsewhere).
    """
    weight = total[:, 3]
    scale = np.divide(np.float32(1), weight, out=np.zeros_like(weight), where=weight > 0)
    total *= scale[:, None]
    # one pass that rounds and saturates (the values are not negative)
    return cv2.convertScaleAbs(total)


def voxel_colours(rig: Rig, views: tuple[View, ...], image: np.ndarray, points: np.ndarray,
                  sources: np.ndarray, th: float) -> np.ndarray:
    """Return the colours of kept voxels from the views that see them.

    The mean of the corrected colours of the views whose pixel nearest the voxel's projection shows
    the object at a depth within `th` of the voxel's; a voxel no view sees so takes its source
    view's pixel.

    Parameters
    ----------
    rig : Rig
    views : tuple of View
        The frame's views (mirrorcore.dense.views.rig_views).
    image : (H, W, 3) uint8 array
        The frame's colour, registered to its depth.
    points : (n, 3) float32 array
        The voxels' centres, metres, camera frame.
    sources : (n,) uint8 array
        Their source labels.
    th : float
        Metres.

    Returns
    -------
    (n, 3) uint8 array
        RGB levels.
    """
    intr, correction = rig.intrinsics, rig.colour_correction
    packed = packed_flat(image)
    total = np.zeros((len(points), 4), np.float32)
    fallback = np.zeros_like(total)
    coordinates = np.ascontiguousarray(np.asarray(points, np.float32).T)
    for view in views:
        p = transform(view.to_view, coordinates)
        at = pixel_index(intr, *project(intr, p))
        with np.errstate(invalid="ignore"):
            seen = view.surface[at] & (np.abs(p[2] - view.depth[at]) < th)
        rgba = np.take(packed, at).view(np.uint8).reshape(-1, 4).astype(np.float32)
        rgba *= correction[view.source]
        total += rgba * seen[:, None]
        fallback += rgba * (sources == view.source)[:, None]
    total = np.where(total[:, 3:] > 0, total, fallback)
    return np.ascontiguousarray(finished_colours(total)[:, :3])

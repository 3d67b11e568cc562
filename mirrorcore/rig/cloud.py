"""A source-labelled point cloud: points in the camera frame, the source of each point, the pixel it
came from."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.base.palette import source_colours, source_name


@dataclass(frozen=True, eq=False)
class Cloud:
    """A source-labelled point cloud of one depth image.

    Attributes
    ----------
    points : (n, 3) float32 array
        Metres, camera frame (possibly a strided view: np.ascontiguousarray before handing its
        buffer on).
    sources : (n,) uint8 array
        0 = direct, j = mirror j, from 33 through several mirrors in turn
        (mirrorcore.base.palette).
    pixel_index : (n,) int64 array
        Flat index v * width + u of the depth pixel each point came from.
    width : int
        Image width, pixels.
    rgb : (n, 3) uint8 array or None
        Each point's colour with its view's colour gain undone (mirrorcore.rig.colour); None for a
        frame without colour.
    """

    points: np.ndarray
    sources: np.ndarray
    pixel_index: np.ndarray
    width: int
    rgb: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.points)

    @property
    def pixels(self) -> np.ndarray:
        """(n, 2) int32 pixel coordinates (u, v)."""
        v, u = np.divmod(self.pixel_index, self.width)
        return np.stack([u, v], axis=-1).astype(np.int32)

    @property
    def colours(self) -> np.ndarray:
        """(n, 3) uint8 source colours (palette.py)."""
        return source_colours(self.sources)

    @property
    def true_colours(self) -> np.ndarray:
        """(n, 3) uint8: the scene's colours (`rgb`), or the source colours without them."""
        return self.colours if self.rgb is None else self.rgb

    def select(self, keep: np.ndarray) -> "Cloud":
        """Return the sub-cloud of a boolean mask or index array over the points.

        Parameters
        ----------
        keep : (n,) bool array or (k,) integer array

        Returns
        -------
        Cloud
        """
        return Cloud(self.points[keep], self.sources[keep], self.pixel_index[keep], self.width,
                     None if self.rgb is None else self.rgb[keep])

    def counts(self, n_mirrors: int) -> dict[str, int]:
        """Count the points per source name of the direct view and every mirror, even when absent.

        The views through several mirrors are in `source_counts`.

        Parameters
        ----------
        n_mirrors : int
            The rig's mirrors.

        Returns
        -------
        dict of str to int
            {'direct': n0, 'mirror 1': n1, ...}.
        """
        counts = np.bincount(self.sources, minlength=n_mirrors + 1)
        return {source_name(j): int(counts[j]) for j in range(n_mirrors + 1)}

    def source_counts(self, n_mirrors: int) -> dict[int, int]:
        """Count the points per source label.

        The direct view and every mirror are listed even when absent, then each view through several
        mirrors in turn that has points, in label order (name and colour of a label:
        mirrorcore.base.palette.source_name, source_colour).

        Parameters
        ----------
        n_mirrors : int
            The rig's mirrors.

        Returns
        -------
        dict of int to int
            {0: n0, 1: n1, ..., 33: n33, ...}.
        """
        counts = np.bincount(self.sources, minlength=n_mirrors + 1)
        listed = [*range(n_mirrors + 1), *(int(s) for s in np.flatnonzero(counts) if s > n_mirrors)]
        return {j: int(counts[j]) for j in listed}

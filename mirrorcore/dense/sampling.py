"""Where points fall in a view and what depth the view measured there (the views:
mirrorcore.dense.views).

A view's depth image is read by quads, the 2x2 pixels around a point's projection, named by their
top-left pixel. `Quads` holds the image on a grid padded with BORDER pixels of NaN (nothing known)
and, per quad, whether it shows the surface (its four pixels do, within BILINEAR_GAP of each other:
the depth is then their bilinear interpolation) and its least depth (NaN ignored; the depth read
everywhere else: the ray is empty up to there whichever of the four the point's own ray is closest
to). A point beyond one pixel outside the image reads a quad of padding: nothing known.

Voxel centres come in the block layout (mirrorcore.dense.blocks): x (B, 1, 1, m), y (1, B, 1, m), z
(1, 1, B, m), so a view's transform is two full-size operations per coordinate, and the camera's own
projection (u from x and z, v from y and z) is computed on (B, 1, B, m) and (1, B, B, m) values
only.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.rig.model import Rig

# metres: four neighbours spread wider than this are a depth edge (their least depth is read)
BILINEAR_GAP = 0.03
BORDER = 2            # pixels of padding around a view's image in Quads


@dataclass(frozen=True, eq=False)
class Quads:
    """A view's depth read by quads of pixels.

    Quads are named by the flat index of their top-left pixel on the padded grid ((H + 2 BORDER)
    rows of `width` = W + 2 BORDER pixels, the image at row and column BORDER). Made on first use,
    for carving: `padded` and `low`, each quad's least depth.

    Attributes
    ----------
    width : int
        W + 2 BORDER.
    image : (H, W) float32 array
        Metres, the view's depth as in mirrorcore.dense.views (finite, +inf empty ray, NaN nothing
        known).
    index : (k,) intp array
        Ascending, the quads that show the surface (their four pixels do, within BILINEAR_GAP of
        each other).
    corners : (k, 4) float32 array
        Their depths: top-left d0, right d1, below d2, below right d3.
    """

    width: int
    image: np.ndarray
    index: np.ndarray
    corners: np.ndarray

    @classmethod
    def of(cls, depth: np.ndarray, surface: np.ndarray) -> "Quads":
        """Read a view's depth by quads; only the box around the surface pixels is looked at.

        Parameters
        ----------
        depth : (H, W) float32 array
            Metres.
        surface : (H, W) bool array
            A view's pixels showing the object's surface.

        Returns
        -------
        Quads
        """
        width = depth.shape[1] + 2 * BORDER
        rows, cols = np.flatnonzero(surface.any(axis=1)), np.flatnonzero(surface.any(axis=0))
        if len(rows) < 2 or len(cols) < 2:
            return cls(width, depth, np.zeros(0, np.intp), np.zeros((0, 4), np.float32))
        box = np.s_[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]
        shows, d = surface[box], depth[box]
        r, c = np.nonzero(shows[:-1, :-1] & shows[:-1, 1:] & shows[1:, :-1] & shows[1:, 1:])
        corners = np.stack([d[r, c], d[r, c + 1], d[r + 1, c], d[r + 1, c + 1]], axis=1)
        spread = np.fmax(np.fmax(corners[:, 0], corners[:, 1]),
                         np.fmax(corners[:, 2], corners[:, 3])) - \
            np.fmin(np.fmin(corners[:, 0], corners[:, 1]), np.fmin(corners[:, 2], corners[:, 3]))
        # four surface pixels with no depth edge between
        ok = spread < BILINEAR_GAP
        index = (r[ok] + rows[0] + BORDER) * width + (c[ok] + cols[0] + BORDER)
        return cls(width, depth, index.astype(np.intp), corners[ok])

    @cached_property
    def padded(self) -> np.ndarray:
        """The depth on the padded grid, flat float32 (NaN padding)."""
        h, w = self.image.shape
        padded = np.full((h + 2 * BORDER, w + 2 * BORDER), np.nan, np.float32)
        padded[BORDER:-BORDER, BORDER:-BORDER] = self.image
        return padded.reshape(-1)

    @cached_property
    def low(self) -> np.ndarray:
        """Each quad's least depth, NaN ignored (NaN if all are): float32, flat like `padded`."""
        w, depth = self.width, self.padded
        low = np.full(len(depth), np.nan, np.float32)
        d0, d1, d2, d3 = (depth[i:len(depth) - w - 1 + i] for i in (0, 1, w, w + 1))
        with np.errstate(invalid="ignore"):
            low[:len(d0)] = np.fmin(np.fmin(d0, d1), np.fmin(d2, d3))
        return low


@dataclass(frozen=True, eq=False)
class QuadTable:
    """One virtual camera's surface quads in one or more frames.

    For reading the bilinear depth at projected points with small tables.

    Attributes
    ----------
    index : (k,) intp array
        Ascending, the quads that show the surface in some frame.
    near, far : (k,) float32 array
        Metres, the least and greatest depth of their pixels over the frames where they do.
    lookup : (Hp*Wp,) int32 array
        Each quad's row (1 + its place in index; 0 for the others).
    rows : (F, k + 1, 4) float32 array
        Per frame and row d0, d1 - d0, d2, d3 - d2 of the quad's pixels (Quads.corners), NaN in row
        0 and where that frame's quad does not show the surface.
    """

    index: np.ndarray
    near: np.ndarray
    far: np.ndarray
    lookup: np.ndarray
    rows: np.ndarray

    @classmethod
    def of(cls, quads: list[Quads]) -> "QuadTable":
        """Return the table of one view's Quads in each frame.

        Parameters
        ----------
        quads : list of Quads

        Returns
        -------
        QuadTable
        """
        index = quads[0].index if len(quads) == 1 else np.unique(np.concatenate([q.index
                                                                                 for q in quads]))
        h, w = quads[0].image.shape
        lookup = np.zeros((h + 2 * BORDER) * (w + 2 * BORDER), np.int32)
        lookup[index] = np.arange(1, len(index) + 1, dtype=np.int32)
        rows = np.full((len(quads), len(index) + 1, 4), np.nan, np.float32)
        near, far = np.full(len(index), np.inf, np.float32), np.full(len(index), -np.inf,
                                                                     np.float32)
        for frame, q in zip(rows, quads):
            d, at = q.corners, np.searchsorted(index, q.index)
            frame[at + 1] = np.stack([d[:, 0], d[:, 1] - d[:, 0], d[:, 2], d[:, 3] - d[:, 2]],
                                     axis=1)
            near[at] = np.minimum(near[at], d.min(axis=1))
            far[at] = np.maximum(far[at], d.max(axis=1))
        return cls(index, near, far, lookup, rows)

    def slots(self, projection: "Projection") -> np.ndarray:
        """Return the rows of the quads the projected points fall in.

        Parameters
        ----------
        projection : Projection

        Returns
        -------
        (n,) intp array
        """
        return np.take(self.lookup, projection.index).astype(np.intp)

    def surface_depth(self, frame: int, slots: np.ndarray, projection: "Projection") -> np.ndarray:
        """Return the bilinear depth in a frame at the projected points.

        Parameters
        ----------
        frame : int
        slots : (n,) intp array
            The points' rows (`slots`).
        projection : Projection

        Returns
        -------
        (n,) float32 array
            Metres; NaN where their quad does not show the surface.
        """
        items = self.rows[frame].view(np.dtype((np.void, 16))).reshape(-1)
        d = np.take(items, slots).view(np.float32).reshape(-1, 4)
        top = d[:, 0] + projection.fu * d[:, 1]
        bottom = d[:, 2] + projection.fu * d[:, 3]
        bottom -= top
        bottom *= projection.fv
        top += bottom
        return top


@dataclass(frozen=True, eq=False)
class Projection:
    """Points seen in one view, flat (n,) in the block layout's C order.

    Attributes
    ----------
    z : (n,) float32 array
        Metres, their depth in the view's frame.
    index : (n,) intp array
        Their quad (Quads).
    fu, fv : (n,) float32 array
        Their offset from the quad's top-left pixel in [0, 1] (meaningless where the quad is
        padding).
    """

    z: np.ndarray
    index: np.ndarray
    fu: np.ndarray
    fv: np.ndarray


def project_blocks(intr: Intrinsics, to_view: np.ndarray, x: np.ndarray, y: np.ndarray,
                   z: np.ndarray) -> Projection:
    """Project voxel centres in the block layout into a view.

    The same float32 values as transforming each centre (`transform`) and projecting it
    (`project`), by broadcasting, with the temporaries reused.

    Parameters
    ----------
    intr : Intrinsics
    to_view : (3, 4) float64 array
        The view's extrinsic (View.to_view).
    x, y, z : float32 array
        Voxel centres in the block layout, x (B, 1, 1, m), y (1, B, 1, m), z (1, 1, B, m), metres,
        camera frame (`Blocks.axes`).

    Returns
    -------
    Projection
    """
    shape = np.broadcast_shapes(x.shape, y.shape, z.shape)
    if np.array_equal(to_view, np.eye(3, 4)):
        p = (x, y, z)                             # the camera: u depends on x and z, v on y and z
    else:
        m = to_view.astype(np.float32)
        p = []
        for r in range(3):
            row = m[r, 0] * x + m[r, 1] * y + m[r, 2] * z
            row += m[r, 3]
            p.append(row)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.float32(1) / p[2]
        np.copyto(inv, np.float32(np.nan), where=p[2] <= 0)
    width = intr.width + 2 * BORDER
    cells, fractions = [], []
    for f, c, coordinate, size in ((intr.fx, intr.cx, p[0], intr.width),
                                   (intr.fy, intr.cy, p[1], intr.height)):
        t = coordinate * np.float32(f)
        t = np.multiply(t, inv,
                        out=t if t.shape == np.broadcast_shapes(t.shape, inv.shape) else None)
        t += np.float32(c)
        low = np.fmax(t, np.float32(-BORDER))
        np.fmin(low, np.float32(size), out=low)
        np.floor(low, out=low)
        t -= low
        np.maximum(t, 0, out=t)
        np.minimum(t, 1, out=t)
        fractions.append(t)
        cells.append(low)
    # whole numbers below 2^24 are exact in float32
    if (intr.height + 2 * BORDER) * width < 1 << 24:
        cells[1] *= np.float32(width)
        index = cells[1] + cells[0]
    else:
        index = cells[1].astype(np.float64) * width + cells[0]
    index += BORDER * width + BORDER
    flat = [np.broadcast_to(a, shape).reshape(-1)
            for a in (p[2], index.astype(np.intp), *fractions)]
    return Projection(*flat)


def nearest_pixels(intr: Intrinsics, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Return the camera's pixel nearest to each voxel centre of the block layout.

    u depends on x and z only, v on y and z: the full-size work is one sum.

    Parameters
    ----------
    intr : Intrinsics
    x, y, z : float32 array
        Voxel centres in the block layout, x (B, 1, 1, m), y (1, B, 1, m), z (1, 1, B, m), metres,
        camera frame (`Blocks.axes`).

    Returns
    -------
    (B, B, B, m) intp array
        Flat pixel index; H*W (the pad cell of View's flat images) off the image or behind the
        camera.
    """
    inv_z = np.where(z > 0, np.float32(1) / np.maximum(z, np.float32(1e-9)), np.float32(np.nan))
    pad = intr.width * intr.height
    with np.errstate(invalid="ignore"):
        iu = np.rint(np.float32(intr.fx) * x * inv_z + np.float32(intr.cx))
        iv = np.rint(np.float32(intr.fy) * y * inv_z + np.float32(intr.cy))
        iu = np.where((iu >= 0) & (iu < intr.width), iu, pad).astype(np.intp)
        iv = np.where((iv >= 0) & (iv < intr.height), iv, intr.height).astype(np.intp) * intr.width
    return np.minimum(iu + iv, pad)


def in_front_of_mirrors(rig: Rig, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Tell which points lie in front of every calibrated mirror plane.

    That is the volume the algorithms carve.

    Parameters
    ----------
    rig : Rig
    x, y, z : float32 array
        Metres, camera frame; they broadcast together.

    Returns
    -------
    bool array
        Of their broadcast shape.
    """
    ok = np.ones(np.broadcast_shapes(x.shape, y.shape, z.shape), bool)
    for m in rig.mirrors:
        if m.plane is not None:
            n = m.plane.n.astype(np.float32)
            ok &= n[0] * x + n[1] * y + n[2] * z + np.float32(m.plane.d) > 0
    return ok


def transform(to_view: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Map points into the frame of a view, one multiply-add per coefficient.

    A (n, 3) @ (3, 3) product is several times slower.

    Parameters
    ----------
    to_view : (3, 4) array
        The view's extrinsic.
    points : (3, n) float32 array
        Rows x, y, z, camera frame.

    Returns
    -------
    (3, n) float32 array
    """
    m = to_view.astype(np.float32)
    return np.stack([m[r, 0] * points[0] + m[r, 1] * points[1] + m[r, 2] * points[2] + m[r, 3]
                     for r in range(3)])


def project(intr: Intrinsics, p) -> tuple[np.ndarray, np.ndarray]:
    """Project points in a view's frame to pixel coordinates.

    Parameters
    ----------
    intr : Intrinsics
    p : (x, y, z) float32 arrays
        They broadcast together.

    Returns
    -------
    u, v : float32 array
        Pixels; NaN where z <= 0.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(p[2] > 0, np.float32(1) / p[2], np.float32(np.nan))
    return (np.float32(intr.fx) * p[0] * inv + np.float32(intr.cx),
            np.float32(intr.fy) * p[1] * inv + np.float32(intr.cy))


def pixel_index(intr: Intrinsics, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Return the nearest pixel of real coordinates.

    Parameters
    ----------
    intr : Intrinsics
    u, v : array
        Any broadcastable shapes; NaN allowed.

    Returns
    -------
    int64 array
        Flat index v*W + u; H*W (the pad cell) off the image.
    """
    iu, iv = np.rint(u), np.rint(v)
    ok = (iu >= 0) & (iu < intr.width) & (iv >= 0) & (iv < intr.height)
    with np.errstate(invalid="ignore"):
        return np.where(ok, iv * intr.width + iu, intr.width * intr.height).astype(np.int64)

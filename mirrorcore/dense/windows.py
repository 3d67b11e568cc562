"""Whole blocks of voxels decided at once (carving, mirrorcore.dense.carve; fusion,
mirrorcore.dense.tsdf): a view's least and greatest depth over a window of pixels around each
block's projection (an OpenCV erosion and dilation of an image of the view, one window size per
view), and from them the two block tests:

- the view sees through every voxel of the block: the block's greatest depth in the view's frame is
less than the
  least depth of its window minus th (the camera's view uses its 3x3-minimum depth, and a voxel
  projected off its image counts as seen through, as the voxel tests do);
- the view sees every voxel of the block behind its surface by more than th, or nothing of it: the
block's least
  depth exceeds the greatest depth of its window plus th (carving: the measured depth, unknown
  pixels ignored; fusion: the depth of the pixels that show the surface, the only ones it reads).

The window holds every pixel whose depth a voxel of the block can read (the quads around its
projections, one pixel more each side for rounding), so each test holds for every voxel when it
holds for the block: only the blocks that neither test decides are carved voxel by voxel. A block
whose window would need more than MAX_HALF pixels each side of its centre, that comes within Z_MIN
of a view's plane, or (for the tests that need it) whose window leaves the image is left undecided
by that view. mirror_sides tells the blocks wholly behind a mirror's plane and those wholly in front
of every one."""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.rig.model import Rig
from mirrorcore.dense.views import View

MAX_HALF = 16          # pixels: the largest window is 33 x 33
Z_MIN = 1e-3           # metres: blocks nearer a view's plane than this are left to the voxel tests
DEPTH_MARGIN = 1e-5    # metres: the float32 rounding of voxel centres and of depths minus th
PLANE_MARGIN = 1e-5    # metres: the float32 rounding of voxel centres against a mirror plane


@dataclass(frozen=True, eq=False)
class Window:
    """A view's window tables.

    Attributes
    ----------
    to_view : (3, 4) array
        Its extrinsic.
    half : int
        The window's half size, pixels.
    least, most : (H*W,) float32 array or None
        Metres, the least depth that a voxel test of the view may read in the window centred on each
        pixel, and the greatest (None: that test never holds).
    """

    to_view: np.ndarray
    half: int
    least: np.ndarray | None
    most: np.ndarray | None

    @classmethod
    def for_carving(cls, view: View, half: int) -> "Window":
        """Return the tables of carving for a view.

        The camera's least depth is its cull depth (+inf off the image: a voxel projected there is
        carved); a mirror's is its depth with unknown pixels and the outside as -inf (they carve
        nothing, so they decide nothing). The greatest ignores unknown pixels; off the image it is
        +inf for the camera (undecided) and ignored for the others.

        Parameters
        ----------
        view : View
        half : int
            Pixels.

        Returns
        -------
        Window
        """
        camera = view.source == 0
        depth = view.depth[:-1].reshape(view.shape)
        known = np.where(np.isnan(depth), np.float32(-np.inf), depth)
        least = view.cull_depth[:-1].reshape(view.shape) if camera else known
        border = np.inf if camera else -np.inf
        return cls(view.to_view, half, _extreme(cv2.erode, least, half, border),
                   _extreme(cv2.dilate, known, half, border))

    @classmethod
    def for_fusion(cls, views: list[View], half: int) -> "Window":
        """Return the tables of fusion for one view of every frame.

        The greatest depth of the pixels that show the surface in some frame (nothing elsewhere, nor
        off the image).

        Parameters
        ----------
        views : list of View
            The same virtual camera in each frame.
        half : int
            Pixels.

        Returns
        -------
        Window
        """
        shown = np.full(views[0].shape, -np.inf, np.float32)
        for view in views:
            np.copyto(shown.reshape(-1), np.fmax(shown.reshape(-1), view.depth[:-1]),
                      where=view.surface[:-1])
        return cls(views[0].to_view, half, None, _extreme(cv2.dilate, shown, half, -np.inf))

    @classmethod
    def for_cull(cls, cull: np.ndarray, shape: tuple[int, int], half: int) -> "Window":
        """Return the camera's cull depth over windows: its least and greatest.

        +inf off the image (a voxel whose nearest pixel is off the image is culled).

        Parameters
        ----------
        cull : (H*W + 1,) float32 array
            View.cull_depth.
        shape : (int, int)
            (H, W).
        half : int
            Pixels.

        Returns
        -------
        Window
        """
        image = cull[:-1].reshape(shape)
        return cls(np.eye(3, 4), half, _extreme(cv2.erode, image, half, np.inf),
                   _extreme(cv2.dilate, image, half, np.inf))

    def test(self, intr: Intrinsics, box: tuple[np.ndarray, np.ndarray],
             th: float) -> tuple[np.ndarray, np.ndarray]:
        """Test blocks against the view.

        The block's x, y, z ranges in the view's frame are exact for its box; its pixels are bounded
        by the ratios of their ends (a box a little larger).

        Parameters
        ----------
        intr : Intrinsics
        box : ((3, m), (3, m)) float64 arrays
            Centre and half size of m blocks (Blocks.bounds).
        th : float
            Metres.

        Returns
        -------
        free : (m,) bool array
            The view sees through every voxel.
        behind : (m,) bool array
            The view sees every voxel behind its surface by more than th (or nothing of it).
        """
        (x0, x1), (y0, y1), (z0, z1) = box_ranges(self.to_view, box)
        ahead = z0 > Z_MIN
        z_near, z_far = np.where(ahead, z0, 1), np.where(ahead, z1, 1)
        fits = ahead
        centre = []
        for f, c, lo, hi, size in ((intr.fx, intr.cx, x0, x1, intr.width),
                                   (intr.fy, intr.cy, y0, y1, intr.height)):
            # the quads' pixels, one more
            first = np.floor(f * np.minimum(lo / z_near, lo / z_far) + c) - 1
            last = np.floor(f * np.maximum(hi / z_near, hi / z_far) + c) + 2      # each side
            middle = np.floor((first + last) / 2)
            fits = fits & (middle - first <= self.half) & (last - middle <= self.half) & (
                middle >= 0) & (middle < size)
            centre.append(middle)
        pixel = np.where(fits, centre[1] * intr.width + centre[0], 0).astype(np.intp)
        free, behind = np.zeros(len(fits), bool), np.zeros(len(fits), bool)
        if self.least is not None:
            free = fits & (z1 + DEPTH_MARGIN < self.least[pixel] - th)
        if self.most is not None:
            behind = fits & (z0 - DEPTH_MARGIN > self.most[pixel] + th)
        return free, behind


def mirror_sides(rig: Rig, box: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Tell which blocks lie wholly behind a mirror, and which wholly in front of every one.

    By more than PLANE_MARGIN (the float32 rounding of voxel centres).

    Parameters
    ----------
    rig : Rig
    box : ((3, m), (3, m)) float64 arrays
        Blocks.bounds().

    Returns
    -------
    behind : (m,) bool array
        Wholly behind some calibrated mirror's plane.
    in_front : (m,) bool array
        Wholly in front of every one.
    """
    behind_one, in_front = np.zeros(box[0].shape[1], bool), np.ones(box[0].shape[1], bool)
    for mirror in rig.mirrors:
        if mirror.plane is not None:
            (near, far), = box_ranges(np.append(mirror.plane.n, mirror.plane.d)[None], box)
            behind_one |= far < -PLANE_MARGIN
            in_front &= near > PLANE_MARGIN
    return behind_one, in_front


def box_ranges(transform: np.ndarray,
               box: tuple[np.ndarray, np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Return the range of each row of a transform over boxes.

    Parameters
    ----------
    transform : (r, 4) array
        A linear function and offset per row.
    box : ((3, m), (3, m)) float64 arrays
        Centre and half size.

    Returns
    -------
    list of ((m,) float64 array, (m,) float64 array)
        r pairs (least, greatest).
    """
    centre, half = box
    ranges = []
    for row in np.asarray(transform, float):
        middle = row[:3] @ centre + row[3]
        spread = np.abs(row[:3]) @ half
        ranges.append((middle - spread, middle + spread))
    return ranges


def _extreme(operation, image: np.ndarray, half: int, border: float) -> np.ndarray:
    """(H*W,) float32: cv2.erode or cv2.dilate of image (H, W) over (2 half + 1)^2 windows, `border`
    off the image."""
    kernel = np.ones((2 * half + 1, 2 * half + 1), np.uint8)
    return operation(np.asarray(image, np.float32), kernel, borderType=cv2.BORDER_CONSTANT,
                     borderValue=border).reshape(-1)


def window_half(intr: Intrinsics, to_view: np.ndarray, volume_corners: np.ndarray,
                block_extent: float) -> int:
    """Return the half size of a window holding the projection of any block in a volume.

    Plus two pixels each side (the quads and rounding).

    Parameters
    ----------
    intr : Intrinsics
    to_view : (3, 4) array
        The view's extrinsic.
    volume_corners : (8, 3) float64 array
        Metres, camera frame.
    block_extent : float
        Metres, a block's edge.

    Returns
    -------
    int
        Pixels, at most MAX_HALF.
    """
    p = volume_corners @ to_view[:, :3].T + to_view[:, 3]
    z = p[:, 2]
    if not (z > Z_MIN).all():
        return MAX_HALF
    # the steepest ray through the volume, as tan
    slope = np.abs(p[:, :2] / z[:, None]).max()
    width = max(intr.fx, intr.fy) * block_extent * np.sqrt(3) * (1 + slope) / z.min()
    return int(min(MAX_HALF, np.ceil(width / 2) + 3))

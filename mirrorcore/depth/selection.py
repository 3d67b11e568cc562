"""Object selection: which pixels of a depth frame are the object (background subtraction with a
depth-dependent tolerance, depth range, region of interest, removal of specks and flying pixels)."""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import cv2
import numpy as np

from mirrorcore.depth.ops import bounding_window, masked_copy
from mirrorcore.base.errors import FileFormatError, MirrorscanError
from mirrorcore.base.jsonfile import finite_number
from mirrorcore.geometry.camera import Intrinsics, check_depth_shape
from mirrorcore.geometry.polygon import polygon_mask, validate_polygon
from mirrorcore.depth.noise import axial_sigma


# the keys of a selection in metres, and in standard deviations: numbers from 0
_METRES = ("depth_min", "depth_max", "min_gap", "flying_gap")
_SIGMAS = ("background_sigmas", "flying_sigmas")


def _number(value, where: str) -> float:
    """A finite number from 0 (not a boolean), as a float; FileFormatError naming `where`."""
    number = finite_number(value)
    if number is None or number < 0:
        raise FileFormatError(f"{where}: must be a finite number from 0, got {repr(value)[:40]}")
    return number


@dataclass(frozen=True)
class Selection:
    """How to find the object in a frame. Distances in metres.

    Attributes
    ----------
    depth_min, depth_max : float
        Readings outside [depth_min, depth_max] are not the object (mirror views read the virtual
        depth, farther than the object itself: leave room for it).
    background_sigmas : float
        A pixel is the object when it is closer than the background by more than this many standard
        deviations of the difference of two readings (sqrt(2) * sigma(z)), and at least `min_gap`.
    min_gap : float
        Metres, the smallest difference that counts as the object.
    flying_sigmas, flying_gap : float
        A pixel whose depth is farther than the nearest object neighbour by more than
        max(flying_sigmas * sigma(z), flying_gap * z) is a flying pixel at a depth edge and is
        dropped.
    min_blob : int
        Connected pieces of the object with fewer pixels than this are specks and are dropped.
    roi : tuple of (float, float), optional
        Polygon (u, v), pixels; only pixels inside it (or on its edge) can be the object.
    smooth : bool
        Smooth the object's depth (edge-aware, in disparity; pipeline.prepare_frame) before
        reconstruction.
    """

    depth_min: float = 0.4
    depth_max: float = 6.0
    background_sigmas: float = 4.0
    min_gap: float = 0.02
    flying_sigmas: float = 6.0
    flying_gap: float = 0.03
    min_blob: int = 40
    roi: tuple[tuple[float, float], ...] | None = None
    smooth: bool = True

    @classmethod
    def from_json(cls, data, where: str = "selection") -> "Selection":
        """Read a session.json 'selection' object.

        Parameters
        ----------
        data : dict or None
            The object; unknown keys are refused, missing ones take the defaults (None: all
            defaults).
        where : str
            What the object is, for the messages.

        Returns
        -------
        Selection

        Raises
        ------
        FileFormatError
            Naming `where` and the key: not an object, unknown keys, a length or number of
            deviations that is not a finite number from 0, a depth range not 0 <= depth_min <
            depth_max, a min_blob not a whole number from 0, a smooth not a boolean, an invalid
            roi.
        """
        if data is None:
            return cls()
        if not isinstance(data, dict):
            raise FileFormatError(f"{where}: must be a JSON object")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise FileFormatError(f"{where}: unknown key(s) {', '.join(unknown)}")
        values = dict(data)
        if values.get("roi") is not None:
            try:
                values["roi"] = tuple(map(tuple,
                                          validate_polygon(values["roi"], None,
                                                           f"{where}: roi").tolist()))
            except MirrorscanError as exc:
                raise FileFormatError(str(exc)) from None
        for key in _METRES + _SIGMAS:
            if key in values:
                values[key] = _number(values[key], f"{where}: {key}")
        if "min_blob" in values:
            blob = finite_number(values["min_blob"])
            if blob is None or blob != int(blob) or blob < 0:
                raise FileFormatError(f"{where}: min_blob: must be a whole number of pixels from "
                                      f"0, got {repr(values['min_blob'])[:40]}")
            values["min_blob"] = int(blob)
        if not isinstance(values.get("smooth", True), bool):
            raise FileFormatError(f"{where}: smooth: must be true or false, got "
                                  f"{repr(values['smooth'])[:40]}")
        sel = cls(**values)
        if not 0 <= sel.depth_min < sel.depth_max:
            raise FileFormatError(f"{where}: depth_min, depth_max: need 0 <= depth_min < "
                                  f"depth_max metres, got {sel.depth_min:g}, {sel.depth_max:g}")
        return sel

    def to_json(self) -> dict:
        """The session.json 'selection' object."""
        data = asdict(self)
        data["roi"] = None if self.roi is None else [list(p) for p in self.roi]
        return data


# pixels: the clean-up looks this far around the candidates that have a solid 3x3 core
CORE_MARGIN = 16


@dataclass(frozen=True, eq=False)
class Backdrop:
    """The scene without the object, ready for subtraction.

    A pixel is the object where its depth is below `limit`. Made once per background and selection
    (`Backdrop.of`), not per frame.

    Attributes
    ----------
    depth : (H, W) float32 array
        Metres, 0 = no reading.
    limit : (H, W) float32 array
        Metres: the background's depth less the tolerance
        max(background_sigmas * sqrt(2) * sigma(z), min_gap) (the noise of the difference of two
        readings); +inf where the background has no reading (any reading there counts as the
        object).
    """

    depth: np.ndarray
    limit: np.ndarray

    @classmethod
    def of(cls, background: np.ndarray, selection: "Selection" = None) -> "Backdrop":
        """Make the backdrop of a background for a selection.

        Parameters
        ----------
        background : (H, W) float array
            Metres, 0 = no reading.
        selection : Selection, optional
            Its background_sigmas and min_gap make the tolerance (default Selection()).

        Returns
        -------
        Backdrop
        """
        selection = Selection() if selection is None else selection
        depth = np.asarray(background, np.float32)
        tolerance = np.maximum(np.float32(selection.background_sigmas * np.sqrt(2.0)) * axial_sigma(
            depth),
                               np.float32(selection.min_gap))
        return cls(depth,
                   np.where(depth > 0, depth - tolerance, np.float32(np.inf)).astype(np.float32))


def object_mask(intr: Intrinsics, depth: np.ndarray, background: np.ndarray | Backdrop | None,
                selection: Selection = Selection()) -> np.ndarray:
    """Find the object's pixels in a depth frame.

    A pixel with no background reading counts as the object when it has a reading now. The clean-up
    (flying pixels, specks) looks only within CORE_MARGIN pixels of the candidates that have a
    solid 3x3 core: the scattered single pixels that background subtraction leaves are dropped
    without a pass over the whole frame (a piece with no 3x3 core reaching farther than that is
    dropped too).

    Parameters
    ----------
    intr : Intrinsics
        The camera.
    depth : (H, W) float array
        Metres, 0 = no reading.
    background : (H, W) float array, Backdrop or None
        The scene without the object, metres (0 = no reading there), or a Backdrop made once for
        it; None selects by depth range and region only.
    selection : Selection
        How to find the object.

    Returns
    -------
    (H, W) bool array
    """
    depth = check_depth_shape(intr, depth)
    mask = (depth >= selection.depth_min) & (depth <= selection.depth_max)
    if background is not None:
        if not isinstance(background, Backdrop):
            background = Backdrop.of(check_depth_shape(intr, background, "background"), selection)
        check_depth_shape(intr, background.limit, "background")
        mask &= depth < background.limit
    if selection.roi is not None:
        mask &= polygon_mask(np.asarray(selection.roi), intr.shape)
    cores = cv2.erode(mask.view(np.uint8), np.ones((3, 3), np.uint8))
    # beyond, a piece with no 3x3 core is a speck
    win = bounding_window(cores.view(bool), CORE_MARGIN)
    cleaned = np.zeros_like(mask)
    if mask[win].size:
        cleaned[win] = remove_specks(mask[win] & ~flying_pixels(depth[win], mask[win], selection),
                                     selection.min_blob)
    return cleaned


def flying_pixels(depth: np.ndarray, mask: np.ndarray,
                  selection: Selection = Selection()) -> np.ndarray:
    """Find masked pixels lying well behind their nearest masked 8-neighbour.

    These are mixed readings at depth edges, behind by more than max(flying_sigmas * sigma(z),
    flying_gap * z). The depth-dependent gap is computed only where the pixel is behind by more than
    its part flying_gap * z (a few hundred pixels of a frame), with the same result.

    Parameters
    ----------
    depth : (H, W) float array
        Metres.
    mask : (H, W) bool array
        The candidate pixels.
    selection : Selection
        Its flying_sigmas and flying_gap.

    Returns
    -------
    (H, W) bool array
        The flying pixels.
    """
    depth = np.asarray(depth, dtype=np.float32)
    nearest = np.full(depth.shape, np.inf, np.float32)
    masked_copy(depth, mask, nearest)
    nearest = cv2.erode(nearest, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_REPLICATE)
    behind = np.subtract(depth, nearest, out=nearest).reshape(-1)
    beyond = np.float32(selection.flying_gap) * depth.reshape(-1)
    candidates = np.flatnonzero(np.greater(behind, beyond) & mask.reshape(-1))
    z = np.take(depth.reshape(-1), candidates)
    gap = np.maximum(np.float32(selection.flying_sigmas) * axial_sigma(z),
                     np.take(beyond, candidates))
    flying = np.zeros(depth.shape, bool)
    flying.reshape(-1)[candidates[np.take(behind, candidates) > gap]] = True
    return flying


def remove_specks(mask: np.ndarray, min_blob: int) -> np.ndarray:
    """Drop the 8-connected pieces of a mask smaller than `min_blob` pixels.

    Parameters
    ----------
    mask : (H, W) bool array
    min_blob : int
        Pixels.

    Returns
    -------
    (H, W) bool array
    """
    count, labels = cv2.connectedComponents(mask.view(np.uint8), connectivity=8)
    # (its ...WithStats is 4x slower here)
    keep = np.bincount(labels[mask], minlength=count) >= min_blob
    keep[0] = False
    if count > 256:
        return np.take(keep, labels)
    # few pieces (the usual case): OpenCV's 8-bit lookup, 2x faster
    table = np.zeros(256, np.uint8)
    table[:count] = keep
    return cv2.LUT(labels.astype(np.uint8), table).view(bool)

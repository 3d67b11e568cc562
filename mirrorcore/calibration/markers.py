"""Markers on a mirror's glass: the depth pixels around a clicked marker, each marker's centre, how
far each lies from a plane against the depth noise there (graded good, fair, poor), and the review
of a new fit against the plane it would replace (a large move, or markers that disagree, asks the
user to confirm)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mirrorcore.depth.ops import robust_mean_depth
from mirrorcore.geometry.camera import Intrinsics, reproject_pixels
from mirrorcore.geometry.plane import Plane
from mirrorcore.depth.noise import axial_sigma

# a marker contributes the valid pixels within this many pixels of its click (5x5)
MARKER_WINDOW = 2
MIN_MARKER_PIXELS = 3      # ... and is usable when at least this many of them have a reading
GOOD_SIGMAS = 2.0          # a marker's centre within this many noise sigmas of the plane is good,
FAIR_SIGMAS = 3.0          # within this many fair (the fit's inlier threshold), beyond it poor
MAX_TILT_DEG = 3.0         # a fit that turns a calibrated plane by more than this...
MAX_SHIFT_MM = 20.0        # ... or moves it by more than this at the markers asks for confirmation
# the same markers fitted again on other frames turn their plane by less than this...
REFIT_TILT_DEG = 0.25
# ... and move it by less than this (the demo's live frames: up to 0.07° and 0.2 mm)
REFIT_SHIFT_MM = 2.0
GRADES = ("good", "fair", "poor", "unknown")


def marker_points(intr: Intrinsics, depth: np.ndarray, marker: tuple[float, float],
                  window: int = MARKER_WINDOW) -> np.ndarray:
    """Return the 3D points of the valid depth pixels within `window` pixels of a marker pixel.

    Parameters
    ----------
    intr : Intrinsics
    depth : (H, W) or (k, H, W) float array
        Metres; frames are reduced inside the window only to their per-pixel robust mean
        (depth.ops.robust_mean_depth: a median snaps to the camera's disparity steps).
    marker : (float, float)
        Pixel (u, v).
    window : int
        Pixels.

    Returns
    -------
    (m, 3) float32 array
        Metres, camera frame.
    """
    u0, v0 = int(round(marker[0])), int(round(marker[1]))
    u1, u2 = max(u0 - window, 0), min(u0 + window + 1, intr.width)
    v1, v2 = max(v0 - window, 0), min(v0 + window + 1, intr.height)
    patch = robust_mean_depth(np.asarray(depth)[..., v1:v2, u1:u2])
    vv, uu = np.nonzero(patch > 0)
    return reproject_pixels(intr, uu + u1, vv + v1, patch[vv, uu])


@dataclass(frozen=True)
class MarkerResiduals:
    """How far each marker lies from a plane against the depth noise at it.

    Attributes
    ----------
    signed_mm : tuple of float
        Per marker, the signed distance of the marker's centre (the median of its points) to a plane
        (> 0 on the camera's side: something in front of the glass hides it; < 0 behind: the click
        missed the marker and the glass shows a virtual point); NaN for a marker without
        MIN_MARKER_PIXELS readings.
    sigma_mm : tuple of float
        Per marker, the depth noise there; NaN likewise.
    """

    signed_mm: tuple[float, ...]
    sigma_mm: tuple[float, ...]

    @property
    def distance_mm(self) -> tuple[float, ...]:
        """|signed_mm| per marker."""
        return tuple(abs(d) for d in self.signed_mm)

    @property
    def grades(self) -> tuple[str, ...]:
        """Per marker, 'good', 'fair', 'poor' or 'unknown'.

        'good' is within GOOD_SIGMAS, 'fair' within FAIR_SIGMAS; 'unknown' is a marker without
        depth.
        """
        ratio = np.asarray(self.distance_mm) / np.asarray(self.sigma_mm)
        grade = np.select([ratio <= GOOD_SIGMAS, ratio <= FAIR_SIGMAS, ratio > FAIR_SIGMAS],
                          [0, 1, 2], 3)
        return tuple(GRADES[g] for g in grade)

    def poor(self) -> tuple[int, ...]:
        """0-based indices of the poor markers."""
        return tuple(i for i, g in enumerate(self.grades) if g == "poor")


def marker_centres(intr: Intrinsics, depth: np.ndarray, markers,
                   window: int = MARKER_WINDOW) -> np.ndarray:
    """Return the median point of each marker's window.

    Parameters
    ----------
    intr : Intrinsics
    depth : (H, W) or (k, H, W) float array
        Metres.
    markers : sequence of (u, v)
        Pixels.
    window : int
        Pixels.

    Returns
    -------
    (k, 3) float64 array
        Metres, camera frame; NaN rows for markers without depth.
    """
    centres = np.full((len(markers), 3), np.nan)
    for i, marker in enumerate(markers):
        points = marker_points(intr, depth, marker, window)
        if len(points) >= MIN_MARKER_PIXELS:
            centres[i] = np.median(points, axis=0)
    return centres


def marker_residuals(intr: Intrinsics, depth: np.ndarray, markers, plane: Plane,
                     window: int = MARKER_WINDOW) -> MarkerResiduals:
    """Measure how far each marker lies from a plane against the depth noise at it.

    Parameters
    ----------
    intr : Intrinsics
    depth : (H, W) or (k, H, W) float array
        Metres.
    markers : sequence of (u, v)
        Pixels.
    plane : Plane
    window : int
        Pixels.

    Returns
    -------
    MarkerResiduals
    """
    centres = marker_centres(intr, depth, markers, window)
    with np.errstate(invalid="ignore"):
        signed = plane.signed_distance(centres) * 1e3
        sigma = axial_sigma(centres[:, 2]) * 1e3
    return MarkerResiduals(tuple(signed.tolist()),
                           tuple(np.where(np.isnan(centres[:, 2]), np.nan, sigma).tolist()))


@dataclass(frozen=True)
class FitReview:
    """A new plane against the one it would replace.

    Attributes
    ----------
    tilt_deg, shift_mm : float
        The angle between the two planes, degrees, and the shift along the normal at the markers'
        centre, mm; NaN without a previous plane.
    poor : tuple of int
        The poor markers (0-based).
    moved : bool
        The plane turns by more than MAX_TILT_DEG or moves by more than MAX_SHIFT_MM.
    refit : bool
        The same markers, fitted before and applied, fitted again within a refit's noise.
    """

    tilt_deg: float
    shift_mm: float
    poor: tuple[int, ...]
    moved: bool = False
    refit: bool = False

    @property
    def needs_confirmation(self) -> bool:
        """Whether the user should look before the plane is applied.

        The plane moved far, or a marker is poor, unless it is a refit (its poor markers are still
        named, nothing is asked).
        """
        return (self.moved or bool(self.poor)) and not self.refit


def review_fit(previous: Plane | None, new: Plane, residuals: MarkerResiduals, at: np.ndarray,
               same_markers: bool = False) -> FitReview:
    """Review a fit against the plane it would replace.

    Parameters
    ----------
    previous : Plane or None
        The mirror's plane now (None: the first fit).
    new : Plane
        The plane just fitted.
    residuals : MarkerResiduals
        The markers against the new plane.
    at : (3,) float
        Metres: where the shift between the two planes is measured (the markers' centre, on their
        faces: in front of the new plane by its glass).
    same_markers : bool
        `previous` was fitted on these markers and applied (a proposal asked about them then).
    """
    tilt = shift = float("nan")
    if previous is not None:
        tilt = previous.angle_to(new)
        at = np.asarray(at, float)
        shift = abs(float(previous.signed_distance(at) - new.signed_distance(at))) * 1e3
    moved = bool(tilt > MAX_TILT_DEG or shift > MAX_SHIFT_MM)
    refit = same_markers and tilt < REFIT_TILT_DEG and shift < REFIT_SHIFT_MM
    return FitReview(tilt, shift, residuals.poor(), moved, bool(refit))



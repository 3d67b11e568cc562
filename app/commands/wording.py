"""What the `mirrorscan` commands print, built from the library's typed results.

Every message is a headline of at most HEADLINE_WORDS words (what happened, what to do), then the
figures behind it, which the commands print indented under it with `-v/--verbose`."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from mirrorcore.base.palette import source_name
from mirrorcore.base.words import listed
from mirrorcore.batch import BatchReport
from mirrorcore.calibration.fit import Calibration
from mirrorcore.calibration.markers import GRADES
from mirrorcore.calibration.results import METHOD_BIAS, NOISE_EXPLAINS, SAME_GLASS_MM, SAME_PLANE
from mirrorcore.calibration.refine import MirrorRefinement
from mirrorcore.geometry.shapes import FitErrors, ShapeFit
from mirrorcore.sim.truth import PlaneError, SurfaceError

HEADLINE_WORDS = 25
INDENT = "  "


@dataclass(frozen=True)
class Message:
    """A headline (at most HEADLINE_WORDS words) and the lines of figures behind it.

    Attributes
    ----------
    headline : str
        What happened and what to do.
    details : tuple of str
        The figures behind it, printed under `-v/--verbose`.
    """

    headline: str
    details: tuple[str, ...] = ()

    def lines(self, verbose: bool) -> list[str]:
        """The headline, then with `verbose` each detail indented by INDENT.

        Parameters
        ----------
        verbose : bool
            Add the details after the headline.

        Returns
        -------
        list of str
            The lines to print.
        """
        return [self.headline, *(INDENT + d for d in self.details if verbose)]


def show(message: Message, verbose: bool, file: TextIO | None = None) -> None:
    """Print the message's lines (see Message.lines) to `file`.

    Parameters
    ----------
    message : Message
        What to print.
    verbose : bool
        Print its details too.
    file : TextIO, optional
        Where to print; stdout by default. Flushed after writing.
    """
    print("\n".join(message.lines(verbose)), file=file or sys.stdout, flush=True)


def plane_figures(abcd) -> str:
    """The plane's coefficients a, b, c, d, rounded to 5 decimals.

    Parameters
    ----------
    abcd : array_like, shape (4,)
        The plane ax + by + cz + d = 0 (metres).

    Returns
    -------
    str
        The list of the four rounded figures.
    """
    return str(np.round(np.asarray(abcd, dtype=float), 5).tolist())


# ------------------------------------------------------------------------------------- calibrate
def fitted(name: str, fit: Calibration, marker_names: list[str] | None = None) -> Message:
    """A plane fitted to a mirror's markers or its region (calibrate --method markers|region).

    Parameters
    ----------
    name : str
        The mirror's name.
    fit : Calibration
        The fit; without markers it was fitted to the region.
    marker_names : list of str, optional
        The markers' names; by default they are numbered from 1.

    Returns
    -------
    Message
        The headline names a marker lying off the plane; the details give the plane, its RMS
        (mm), the markers' grades, the farthest marker (mm and σ) and the glass (mm).
    """
    details = [
        f"plane {plane_figures(fit.plane.abcd)}",
        f"RMS {fit.rms_mm:.2f} mm over {fit.n_inliers} of {fit.n_points} points",
    ]
    if fit.markers is None:
        return Message(f"{name}: plane fitted to its region.", tuple(details))
    grades = fit.markers.grades
    counts = ", ".join(f"{grades.count(g)} {g}" for g in GRADES if grades.count(g))
    poor = [marker_names[i] if marker_names else str(i + 1) for i in fit.markers.poor()]
    headline = f"{name}: plane fitted to its {len(grades)} markers; " + (
        f"marker {listed(poor)} lies off it: check the click or move the marker."
        if poor
        else "they agree with it."
    )
    ratio = np.asarray(fit.markers.distance_mm) / np.asarray(fit.markers.sigma_mm)
    details.append(f"markers: {counts}")
    if np.any(np.isfinite(ratio)):
        worst = int(np.nanargmax(ratio))
        label = marker_names[worst] if marker_names else str(worst + 1)
        details.append(
            f"farthest: marker {label}, {fit.markers.distance_mm[worst]:.1f} mm from the plane "
            f"({ratio[worst]:.1f}σ)"
        )
    details.append(
        f"glass: plane {1e3 * fit.marker_offset:.1f} mm behind the markers"
        if fit.marker_offset
        else "glass: 0 mm, the plane on the markers' faces"
    )
    return Message(headline, tuple(details))


def refined(report: MirrorRefinement, searched: bool, saved: bool) -> Message:
    """A plane refined, or found by calibrate --method scene.

    Parameters
    ----------
    report : MirrorRefinement
        What the refinement did to the mirror.
    searched : bool
        The plane was found (calibrate --method scene) rather than refined.
    saved : bool
        The glass measured is written (False: the session holds it already).

    Returns
    -------
    Message
        Whether the view agrees with the others within the depth noise, then the plane, its move,
        the agreement before and after (mm), the noise, the 1σ, what was compared and the glass.
    """
    verdict = (
        "it agrees with the other views as well as the depth noise allows."
        if report.agreement_after_mm <= NOISE_EXPLAINS * report.noise_mm
        else "its view disagrees with the others beyond the depth noise: check its outline."
    )
    headline = f"{report.name}: plane {'found' if searched else 'refined'}; {verdict}"
    details = [f"plane {plane_figures(report.after.abcd)}"]
    if searched:
        details.append(
            f"agreement with the other views: RMS {report.agreement_after_mm:.2f} mm, mean "
            f"{report.offset_after_mm:+.2f} mm"
        )
    else:
        details += [
            f"moved {report.shift_mm:+.2f} mm at the object (> 0: away from the camera) and "
            f"{report.tilt_deg:.3f}°",
            f"agreement with the other views: RMS {report.agreement_before_mm:.2f} mm before, "
            f"{report.agreement_after_mm:.2f} mm after; mean {report.offset_before_mm:+.2f} mm "
            f"before, {report.offset_after_mm:+.2f} mm after",
        ]
    details.append(f"depth noise alone: {report.noise_mm:.2f} mm RMS over the frames used")
    details.append(f"known to ±{report.shift_std_mm:.2f} mm and ±{report.tilt_std_deg:.3f}° (1σ)")
    details += _compared(report)
    glass = _glass(report, saved)
    return Message(headline, tuple(details + ([glass] if glass else [])))


def _compared(report: MirrorRefinement) -> list[str]:
    """What the refinement compared, and what the method may add beyond the 1σ."""
    if report.sphere_radius_mm is not None:
        bias = METHOD_BIAS["sphere"]
        return [
            f"compared: the centres of the sphere (radius {report.sphere_radius_mm:.1f} mm) seen "
            "directly and in the mirror",
            f"the method may add {1e3 * bias.shift:.1f} mm and {bias.tilt_deg:.2f}°",
        ]
    bias, ball = METHOD_BIAS["surfaces"], METHOD_BIAS["sphere"]
    whom = (
        "the camera"
        if report.agreements == report.camera_agreements
        else f"the camera and the mirrors that fix it ({report.camera_agreements:,} with the "
        "camera)"
    )
    return [
        f"compared: {report.agreements:,} points seen both ways with {whom}",
        f"the method may add up to {1e3 * bias.shift:.1f} mm and {bias.tilt_deg:.2f}°; a ball in "
        f"every view {1e3 * ball.shift:.1f} mm",
    ]


def _glass(report: MirrorRefinement, saved: bool) -> str | None:
    """The glass the markers show in front of the refined plane, or None without usable markers."""
    if report.marker_offset is None:
        return None
    markers = (
        f"markers {1e3 * report.marker_offset:.1f} ± {1e3 * report.marker_offset_std:.1f} mm in "
        "front of the"
    )
    if report.glass_typed is not None:
        return (
            f"glass: {markers} refined plane; its glass stays {1e3 * report.glass_typed:.1f} mm, "
            "as typed in"
        )
    return f"glass: {markers} silver ({'saved as its glass' if saved else 'its glass already'})"


def unchanged(path: Path) -> Message:
    """A refinement that moved no plane and no glass by more than nothing (Refinement.changed).

    Parameters
    ----------
    path : Path
        The session file, not written.

    Returns
    -------
    Message
    """
    return Message(
        "nothing changed: the planes and the glass are already where this object puts them; "
        f"{path} not written.",
        (f"within {SAME_PLANE[0]} mm, {SAME_PLANE[1]}° and {SAME_GLASS_MM} mm of glass",),
    )


def markers_unused(names: list[str]) -> Message:
    """After calibrate --method scene: the mirrors found with markers, which set only their glass.

    Parameters
    ----------
    names : list of str
        Those mirrors' names.

    Returns
    -------
    Message
    """
    planes = "its plane was" if len(names) == 1 else "their planes were"
    return Message(
        f"{listed(names)}: {planes} found from the object alone; the markers only read the glass.",
        ("--method markers fits the planes to the markers",),
    )


# ------------------------------------------------------------------------------------- reconstruct
def cloud_written(out: Path, points: int, counts: dict[int, int]) -> Message:
    """One frame's merged cloud (Algorithm 1).

    Parameters
    ----------
    out : Path
        The PLY file written.
    points : int
        Points in it.
    counts : dict of int to int
        {source: points}; source 0 is the direct view, > 0 the mirror views.

    Returns
    -------
    Message
    """
    mirrors = sum(1 for source, points in counts.items() if source > 0 and points)
    return Message(
        f"wrote {out}: {points} points seen directly and in {mirrors} "
        + ("mirror view." if mirrors == 1 else "mirror views."),
        ("points per view: " + ", ".join(f"{source_name(k)} {v}" for k, v in counts.items()),),
    )


def carved_written(out: Path, voxels: int, shape: tuple[int, ...], voxel: float) -> Message:
    """A carved cloud (reconstruct --method paper|carve).

    Parameters
    ----------
    out : Path
        The PLY file written.
    voxels : int
        Voxels on the carved surface.
    shape : tuple of int
        The volume's shape in voxels.
    voxel : float
        A voxel's edge (metres).

    Returns
    -------
    Message
    """
    return Message(
        f"wrote {out}: the carved surface, {voxels} voxels.",
        (f"volume {'x'.join(map(str, shape))} voxels of {voxel * 1e3:g} mm",),
    )


def mesh_written(
    out: Path, vertices: int, faces: int, frames: int, shape: tuple[int, ...], voxel: float
) -> Message:
    """A fused mesh (reconstruct --method tsdf).

    Parameters
    ----------
    out : Path
        The PLY file written.
    vertices, faces : int
        The mesh's size.
    frames : int
        Frames fused.
    shape : tuple of int
        The volume's shape in voxels.
    voxel : float
        A voxel's edge (metres).

    Returns
    -------
    Message
    """
    return Message(
        f"wrote {out}: a mesh of {vertices} vertices fused from {frames} frame(s).",
        (f"{faces} faces", f"volume {'x'.join(map(str, shape))} voxels of {voxel * 1e3:g} mm"),
    )


def batch_done(report: BatchReport) -> Message:
    """How a batch (reconstruct --frame all) ended, its failures aside.

    Parameters
    ----------
    report : BatchReport
        The batch's outcome.

    Returns
    -------
    Message
        Nothing to do when every frame was there already; else the files written, whether every
        frame is done, the frame rate and the manifest.
    """
    if report.complete and not report.written:
        return Message(
            f"nothing to do: the {report.total} frames are in {report.out} already.",
            (f"manifest {report.manifest}",),
        )
    done = report.kept + report.written
    headline = f"wrote {report.written} PLY files into {report.out}; " + (
        "every frame is done."
        if report.complete
        else f"{done} of {report.total} frames done: run it again to go on."
    )
    details = [
        f"{report.fps:.1f} frames/s over {report.seconds:.2f} s"
        + (
            f", after {report.startup_seconds:.1f} s starting the workers"
            if report.startup_seconds >= 1.0
            else ""
        )
    ]
    if report.kept:
        details.append(f"{report.kept} frames kept from an earlier run")
    return Message(headline, (*details, f"manifest {report.manifest}"))


def retried(worker: str, frames: list[int]) -> Message:
    """Frames run again after their worker left the cluster.

    Parameters
    ----------
    worker : str
        The worker's address.
    frames : list of int
        The frames run again.

    Returns
    -------
    Message
    """
    return Message(
        f"worker {worker} left the cluster: its {len(frames)} frame(s) were run again.",
        ("frames run again: " + ", ".join(map(str, frames)),),
    )


def frame_list(frames: list[int], most: int = 10) -> str:
    """'3, 4, 9': at most `most` frames, then ' and N more'.

    Parameters
    ----------
    frames : list of int
        The frame numbers.
    most : int, optional
        How many to list.

    Returns
    -------
    str
    """
    shown = ", ".join(map(str, frames[:most]))
    return shown + (f" and {len(frames) - most} more" if len(frames) > most else "")


# ------------------------------------------------------------------------------------- fit, truth
def shape_fitted(fit: ShapeFit, name: str) -> Message:
    """A sphere or a cylinder fitted to a cloud (mirrorscan fit).

    Parameters
    ----------
    fit : ShapeFit
        The fit.
    name : str
        The cloud's name for the headline.

    Returns
    -------
    Message
        Radius and RMSE (mm), then where the shape lies and the errors over all points, the
        inliers and each source.
    """
    shape = fit.shape
    where = (
        f"centre ({', '.join(f'{x:.4f}' for x in shape.centre)}) m"
        if shape.kind == "sphere"
        else f"axis through ({', '.join(f'{x:.4f}' for x in shape.axis_point)}) m, "
        f"direction ({', '.join(f'{x:.4f}' for x in shape.axis_direction)})"
    )
    rows = [
        ("all points", fit.errors),
        ("inliers", fit.inlier_errors),
        *((source_name(s), e) for s, e in fit.per_source.items()),
    ]
    return Message(
        f"{name}: {shape.kind} of radius {1e3 * shape.radius:.2f} mm, RMSE "
        f"{1e3 * fit.errors.rmse:.2f} mm over its {fit.errors.points} points.",
        (
            where,
            f"{np.count_nonzero(fit.inliers)} of {len(fit.inliers)} points within "
            f"{1e3 * fit.threshold:g} mm",
            *(f"{label:<11} {_errors(e)}" for label, e in rows),
        ),
    )


def _errors(errors: FitErrors) -> str:
    """One row of errors: points, RMSE, mean error and mean absolute error (mm)."""
    return (
        f"{errors.points:>7} points  RMSE {1e3 * errors.rmse:7.2f} mm  mean error "
        f"{1e3 * errors.mean_error:+7.2f} mm  mean |error| {1e3 * errors.mean_abs_error:6.2f} mm"
    )


def plane_error(error: PlaneError) -> Message:
    """A plane against the simulator's truth (mirrorscan truth).

    Parameters
    ----------
    error : PlaneError
        The plane's offset (mm) and tilt (degrees) from the true plane and its glass; no offset
        when the mirror has no plane yet.

    Returns
    -------
    Message
    """
    glass = f"glass {error.glass_mm:.1f} mm (true {error.true_glass_mm:.1f} mm)"
    if error.offset_mm is None:
        return Message(f"{error.name}: no plane yet; {glass}.")
    return Message(
        f"{error.name}: plane {error.offset_mm:+.2f} mm at the object, tilted "
        f"{error.tilt_deg:.3f}°; {glass}.",
        ("offset along the normal at the object's middle; > 0: too far from the camera",),
    )


def surface_error(error: SurfaceError, cloud: str) -> Message:
    """A cloud's distances to the objects' true surfaces (mirrorscan truth --cloud).

    Parameters
    ----------
    error : SurfaceError
        RMSE, mean and 95th percentile (mm) over the points.
    cloud : str
        The cloud's name for the headline.

    Returns
    -------
    Message
    """
    return Message(
        f"{cloud}: RMSE {error.rmse_mm:.2f} mm to the true surface over {error.points:,} points.",
        (f"mean {error.mean_mm:.2f} mm, 95 % within {error.p95_mm:.2f} mm",),
    )

"""What `mirrorscan fit` and `mirrorscan truth` print: a shape fitted to a cloud, and the errors
against the simulator's truth."""

from __future__ import annotations

import numpy as np

from mirrorcore.base.palette import source_name
from mirrorcore.geometry.shapes import FitErrors, ShapeFit
from mirrorcore.sim.colourtruth import WITHIN_LEVELS, ColourError
from mirrorcore.sim.truth import PlaneError, SurfaceError

from .message import Message


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


def no_mirrors(session: str) -> Message:
    """A session without mirrors has no plane to compare (mirrorscan truth).

    Parameters
    ----------
    session : str
        The session's folder.

    Returns
    -------
    Message
    """
    return Message(
        f"{session}: no mirror yet, so no plane to compare: add the mirrors and calibrate them "
        "(mirrorscan serve), then compare again."
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


def colour_error(errors: list[ColourError], cloud: str, names: list[str]) -> Message:
    """A cloud's colours against the albedo its points' pixels see (mirrorscan truth --cloud).

    Parameters
    ----------
    errors : list of ColourError
        Per source: mean bias per channel and RMSE (levels of 255), the RMSE's ratio to the
        direct view's, the shares within WITHIN_LEVELS.
    cloud : str
        The cloud's name for the headline.
    names : list of str
        The session's mirror names in label order.

    Returns
    -------
    Message
        The RMSE over every point measured and the largest mean bias of any source and channel,
        then each source's figures.
    """
    measured = [e for e in errors if e.points]
    if not measured:
        return Message(f"{cloud}: no colour figures, no point's pixel sees the scene; is the "
                       "cloud of this session and --frame?")
    points = sum(e.points for e in measured)
    rmse = float(np.sqrt(sum(e.points * e.rmse**2 for e in measured) / points))
    worst = max(measured, key=lambda e: max(abs(b) for b in e.bias))
    channel = int(np.argmax(np.abs(worst.bias)))
    return Message(
        f"{cloud}: colour RMSE {rmse:.1f} levels (of 255) to the albedo each point's pixel sees; "
        f"largest mean bias {worst.bias[channel]:+.1f}, {('red', 'green', 'blue')[channel]} of "
        f"{_source(worst, names)}.",
        tuple(_source_colour(e, names) for e in errors),
    )


def _source_colour(error: ColourError, names: list[str]) -> str:
    """One source's colour figures, a line."""
    unseen = f", {error.unseen:,} left out (their pixel sees nothing)" if error.unseen else ""
    if not error.points:
        return f"{_source(error, names)}: no point measured{unseen}"
    r, g, b = error.bias
    ratio = ("" if error.ratio is None or not error.source
             else f" ({error.ratio:.2f}x the direct view's)")
    return (f"{_source(error, names)}: {error.points:,} points, mean bias red {r:+.1f} green "
            f"{g:+.1f} blue {b:+.1f} levels, RMSE {error.rmse:.1f} levels{ratio}, "
            f"{100 * error.within:.1f} % within {WITHIN_LEVELS} levels "
            f"({100 * error.within_at_point:.1f} % at the point's own position){unseen}")


def _source(error: ColourError, names: list[str]) -> str:
    """The source a ColourError is of: its view's name, or 'all points' without labels."""
    return "all points" if error.source is None else source_name(error.source, names)


def no_scene_colour(cloud: str, has_colours: bool) -> Message:
    """A cloud without the scene's colour has no colour figures (mirrorscan truth --cloud).

    Parameters
    ----------
    cloud : str
        The cloud's name for the headline.
    has_colours : bool
        Whether the file has colours at all (then they are the source palette).

    Returns
    -------
    Message
    """
    why = "its colours are the source palette" if has_colours else "it has no colours"
    return Message(
        f"{cloud}: no colour figures, {why}, not the scene's; reconstruct it from a session with "
        "colour frames to compare colours."
    )

"""What `mirrorscan fit` and `mirrorscan truth` print: a shape fitted to a cloud, and the errors
against the simulator's truth."""

from __future__ import annotations

import numpy as np

from mirrorcore.base.palette import source_name
from mirrorcore.geometry.shapes import FitErrors, ShapeFit
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

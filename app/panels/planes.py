"""Where the session's planes come from, as the status header's start hint needs it: a markers
fit behind the glass typed in, the object, or markers with no glass set."""

from __future__ import annotations

from mirrorcore.io.session import Session

from ..jobs import Jobs


def from_markers(jobs: Jobs, editor, session: Session) -> tuple[str, ...]:
    """The names of the mirrors whose planes a markers fit set behind the glass typed in.

    A markers fit of this editor (SessionEditor.fitted_on_its_markers); a refinement then still
    makes them more accurate (on the walking figure at 3 m, 2 px clicks: tilts of 0.08 to 0.28
    degrees from the markers, 0.01 to 0.02 refined).
    """
    return tuple(
        m.name
        for m in session.mirrors
        if m.plane is not None
        and m.glass_typed
        and not jobs.from_object(m.id, m.plane)
        and editor.fitted_on_its_markers(m.id)
    )


def from_object(jobs: Jobs, session: Session) -> bool:
    """Whether every plane of the session came from a refinement or search of this app.

    False when there is no plane.
    """
    planes = [(m.id, m.plane) for m in session.mirrors if m.plane is not None]
    return bool(planes) and all(jobs.from_object(*plane) for plane in planes)


def no_glass(jobs: Jobs, session: Session) -> tuple[str, ...]:
    """The names of the mirrors whose planes come from their markers, with no glass set.

    Not from the object; on an ordinary mirror the markers stand 3 to 6 mm in front of the silver.
    """
    return tuple(
        m.name
        for m in session.mirrors
        if m.markers
        and m.plane is not None
        and not m.glass_set
        and not jobs.from_object(m.id, m.plane)
    )

"""What the session editor checks before an edit: pixels in the image, markers on their mirror,
markers and corners that exist, unique names, the inputs a computed plane depends on, and that
what an edit changes is still as the tab that made it drew it. Each check raises MirrorscanError
with a one-line message naming the mirror."""
from __future__ import annotations

import contextlib
from contextvars import ContextVar
from typing import Iterable, Iterator

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.geometry.camera import Intrinsics
from mirrorcore.geometry.plane import Plane
from mirrorcore.geometry.polygon import edge_distance
from mirrorcore.io.session import Session, SessionMirror
from mirrorcore.io.sessionfile import check_name

ON_EDGE = 1.5            # pixels: a marker this close outside its mirror's boundary is on it
# The undo scope of changes that are not one mirror's (mirror ids start at 1).
SESSION_SCOPE = 0
# The end of a refusal of an edit made on a stale state (StaleEdit).
REDRAWN = "this tab now shows it as it is: make the change again if it still applies"


# The session as the tab whose action runs drew it (None: edits are not checked against it).
_DRAWN: ContextVar[Session | None] = ContextVar("mirrorscan_drawn", default=None)


class StaleEdit(MirrorscanError):
    """An edit made on a state of the session that changed since (in another tab): refused."""


@contextlib.contextmanager
def made_on(session: Session | None) -> Iterator[None]:
    """Make the session editor's edits inside the block on `session`, as a tab drew it.

    Each edit is refused (StaleEdit) when what it changes differs from `session`
    (`check_drawn`); each edit made moves the drawing on to its result (`drawn_moves_to`), so
    that an action's edits in turn are made on the one before.

    Parameters
    ----------
    session : Session or None
        None: the edits are not checked.
    """
    token = _DRAWN.set(session)
    try:
        yield
    finally:
        _DRAWN.reset(token)


def check_drawn(now: Session, scopes: Iterable[int]) -> None:
    """Refuse an edit of `scopes` made (`made_on`) on a drawing they differ from.

    Parameters
    ----------
    now : Session
        The session as it is.
    scopes : iterable of int
        The mirror ids (or SESSION_SCOPE) the edit changes.

    Raises
    ------
    StaleEdit
    """
    drawn = _DRAWN.get()
    if drawn is not None:
        unchanged_since(drawn, now, scopes)


def drawn_moves_to(session: Session) -> None:
    """After an edit made on a drawing (`made_on`), the next is made on its result.

    Parameters
    ----------
    session : Session
        The session the edit left.
    """
    if _DRAWN.get() is not None:
        _DRAWN.set(session)


def scope_state(session: Session, scope: int) -> object:
    """What an edit in `scope` depends on and changes.

    Parameters
    ----------
    session : Session
    scope : int
        A mirror's id, or SESSION_SCOPE.

    Returns
    -------
    object
        The mirror's record (None when the session has no such mirror); of SESSION_SCOPE, the
        mirrors' ids in order, the object selection, the bounces followed and the background.
    """
    if scope == SESSION_SCOPE:
        return (tuple(m.id for m in session.mirrors), session.selection, session.bounces,
                session.background)
    return next((m for m in session.mirrors if m.id == scope), None)


def unchanged_since(drawn: Session, now: Session, scopes: Iterable[int]) -> None:
    """Refuse an edit made on `drawn` when what it changes is no longer as drawn.

    Only the scopes the edit changes are compared: a change of another mirror, or of the
    session's own scope, made meanwhile does not refuse it.

    Parameters
    ----------
    drawn : Session
        The session as the tab that made the edit drew it.
    now : Session
        The session as it is.
    scopes : iterable of int
        The mirror ids (or SESSION_SCOPE) the edit changes.

    Raises
    ------
    StaleEdit
        Naming what changed.
    """
    for scope in scopes:
        before, after = scope_state(drawn, scope), scope_state(now, scope)
        if before == after:
            continue
        if scope == SESSION_SCOPE:
            raise StaleEdit(f"the session's mirrors or settings changed since this tab drew "
                            f"them; {REDRAWN}")
        if after is None:
            raise StaleEdit(f"{before.name} was removed in another tab; {REDRAWN}")
        raise StaleEdit(f"{after.name} changed in another tab; {REDRAWN}")


def fit_inputs(mirror: SessionMirror | None) -> tuple | None:
    """What a plane computed for a mirror depends on.

    Parameters
    ----------
    mirror : SessionMirror or None

    Returns
    -------
    tuple or None
        Its markers, boundary, region, plane and glass; None when the mirror is gone. A plane
        computed on other inputs is never applied.
    """
    if mirror is None:
        return None
    return mirror.markers, mirror.boundary, mirror.region, mirror.plane, mirror.marker_offset


def pixel(camera: Intrinsics, uv) -> tuple[float, float]:
    """Pixel `uv` rounded to 0.01 pixel.

    Parameters
    ----------
    camera : Intrinsics
    uv : sequence of float
        (u, v), pixels.

    Returns
    -------
    tuple of float

    Raises
    ------
    MirrorscanError
        Outside the image.
    """
    u, v = float(uv[0]), float(uv[1])
    if not (np.isfinite(u) and np.isfinite(v)
            and -0.5 <= u <= camera.width - 0.5 and -0.5 <= v <= camera.height - 0.5):
        raise MirrorscanError(f"pixel ({u:g}, {v:g}) is outside the "
                              f"{camera.width}x{camera.height} image")
    return round(u, 2), round(v, 2)


def on_mirror(session: Session, mirror: SessionMirror, uv) -> tuple[float, float]:
    """A marker's pixel, refused outside the image or outside its mirror.

    Parameters
    ----------
    session : Session
    mirror : SessionMirror
    uv : sequence of float
        (u, v), pixels.

    Returns
    -------
    tuple of float
        Rounded as by `pixel`.

    Raises
    ------
    MirrorscanError
        Outside the image or, when the mirror has a boundary, more than ON_EDGE pixels outside
        it; the refusal names the mirror the pixel is on, if any.
    """
    uv = pixel(session.camera, uv)
    if mirror.boundary and edge_distance(mirror.boundary, uv) < -ON_EDGE:
        other = next((m.name for m in session.mirrors
                      if m.id != mirror.id and edge_distance(m.boundary, uv) >= 0), None)
        where = (f"on {other}: select {other} (Mirror, above) to mark it" if other
                 else "a marker must be on it")
        raise MirrorscanError(f"{mirror.name}: ({uv[0]:.0f}, {uv[1]:.0f}) is outside its "
                              f"boundary; {where}")
    return uv


def has_marker(mirror: SessionMirror, k: int) -> None:
    """Refuse marker index `k` that the mirror does not have.

    Parameters
    ----------
    mirror : SessionMirror
    k : int
        0-based.

    Raises
    ------
    MirrorscanError
    """
    if not 0 <= k < len(mirror.markers):
        raise MirrorscanError(f"{mirror.name}: no marker {mirror.marker_name(k)}")


def has_vertex(mirror: SessionMirror, vertex: int) -> None:
    """Refuse boundary vertex `vertex` that the mirror does not have.

    Parameters
    ----------
    mirror : SessionMirror
    vertex : int
        0-based.

    Raises
    ------
    MirrorscanError
    """
    if not 0 <= vertex < len(mirror.boundary):
        raise MirrorscanError(f"{mirror.name}: no corner {vertex + 1}")


def unused_name(session: Session, name: str, mirror_id: int | None) -> None:
    """Refuse a mirror name that is not valid or that another mirror holds.

    Parameters
    ----------
    session : Session
    name : str
    mirror_id : int or None
        The mirror being named (None: a new one).

    Raises
    ------
    MirrorscanError
        When check_name refuses it or another mirror than `mirror_id` holds it.
    """
    check_name(name)
    if any(m.name == name for m in session.mirrors if m.id != mirror_id):
        raise MirrorscanError(f"there is already a mirror named {name!r}; choose another name")


def planes_to_set(mirrors: dict[int, SessionMirror],
                  planes: dict[int, tuple[Plane | None, SessionMirror]],
                  glass: dict[int, tuple[float, float | None]],
                  what: str) -> dict[int, tuple[Plane | None, float, float | None]]:
    """The planes and glass of a fit or refinement that change their mirror.

    Parameters
    ----------
    mirrors : dict of int to SessionMirror
        By mirror id: each mirror of `planes` as it is now.
    planes : dict of int to (Plane or None, SessionMirror)
        By mirror id: the plane, and the mirror as it was when the plane was computed.
    glass : dict of int to (float, float or None)
        By mirror id: (marker_offset, marker_offset_std), metres, where measured; the others keep
        theirs.
    what : str
        What the planes are ('plane', 'refined plane'): names the refusal.

    Returns
    -------
    dict of int to (Plane or None, float, float or None)
        By mirror id: (plane, marker_offset, marker_offset_std) of the mirrors whose plane or
        glass changes.

    Raises
    ------
    MirrorscanError
        When a mirror's markers, boundary, region, plane or glass changed since its plane was
        computed: a result computed on another state is never applied.
    """
    for mirror_id, (_, based_on) in planes.items():
        current = mirrors[mirror_id]
        if fit_inputs(current) != fit_inputs(based_on):
            again = "refine it again" if what.startswith("refined") else "fit it again"
            raise MirrorscanError(f"{current.name} changed while its {what} was computed; {again}")
    out = {}
    for i, (plane, _) in planes.items():
        m = mirrors[i]
        offset, std = glass.get(i, (m.marker_offset, m.marker_offset_std))
        if (plane, offset, std) != (m.plane, m.marker_offset, m.marker_offset_std):
            out[i] = (plane, offset, std)
    return out

"""The server's shared state: the session and what is derived from it (rig, background, the grade of
every marker) as one immutable Snapshot, replaced whole (one reference, assigned atomically), so
that the live loop and the browser callbacks always see one consistent state."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from mirrorcore.calibration.markers import MarkerResiduals, marker_residuals
from mirrorcore.rig.model import Rig
from mirrorcore.depth.selection import Backdrop
from mirrorcore.io.session import Session


@dataclass(frozen=True, eq=False)
class Snapshot:
    """One consistent state.

    Attributes
    ----------
    session : Session
    rig : Rig
        Its reflection tables are built once.
    background : np.ndarray, shape (H, W), or None
        Depth in metres.
    backdrop : Backdrop or None
        The subtraction's limit map, made once.
    marker_residuals : dict of int to MarkerResiduals
        For each calibrated mirror (by id), how far each marker lies from its plane
        (mirrorcore.calibration.markers).
    """

    session: Session
    rig: Rig
    background: np.ndarray | None
    backdrop: Backdrop | None = None
    marker_residuals: dict[int, MarkerResiduals] = field(default_factory=dict)

    @property
    def marker_grades(self) -> dict[int, tuple[str, ...]]:
        """{mirror id: each marker's grade, 'good', 'fair', 'poor' or 'unknown'}."""
        return {mirror_id: r.grades for mirror_id, r in self.marker_residuals.items()}

    @classmethod
    def build(cls, session: Session, background: np.ndarray | None,
              depths: np.ndarray | None = None, previous: "Snapshot | None" = None) -> "Snapshot":
        """The snapshot of a session.

        Parameters
        ----------
        session : Session
        background : (H, W) ndarray or None
            Metres.
        depths : (k, H, W) ndarray, optional
            Metres: the recent frames, which grade the markers (none are graded without).
        previous : Snapshot, optional
            What it holds for the same inputs is reused: a marker added or a colour gain changed
            keeps the rig's tables, which take tens of ms to build.
        """
        rig = Rig.from_session(session)
        if previous is not None and rig.same_rays(previous.rig):
            rig = with_gains(previous.rig, rig.colour_gains)
        # built here, once, not in the first live frame
        rig.reflection_table
        residuals = {}
        if depths is not None:
            residuals = {m.id: marker_residuals(session.camera, depths, m.markers, m.marker_plane)
                         for m in session.mirrors if m.plane is not None and m.markers}
        if previous is not None and previous.background is background and \
                previous.session.selection == session.selection:
            backdrop = previous.backdrop
        else:
            backdrop = None if background is None else Backdrop.of(background, session.selection)
        return cls(session, rig, background, backdrop, residuals)



# the rig's cached tables that depend on its rays alone (Rig.same_rays), not on its colour gains
RAY_TABLES = ("inside_bits", "reflection_table")


def with_gains(rig: Rig, gains: tuple) -> Rig:
    """The rig with other colour gains, keeping its per-pixel tables.

    Parameters
    ----------
    rig : Rig
    gains : tuple of (3,) tuple of float or None
        Each mirror's colour gain, session order (Rig.colour_gains).

    Returns
    -------
    Rig
        `rig` itself when its gains are `gains`; else a new rig sharing the tables already built
        (they depend on the rays only), its colour correction made from `gains`.
    """
    if rig.colour_gains == gains:
        return rig
    other = replace(rig, colour_gains=gains)
    built = vars(rig)
    # cached_property keeps a table in the instance's __dict__, which a frozen dataclass allows
    vars(other).update({name: built[name] for name in RAY_TABLES if name in built})
    return other

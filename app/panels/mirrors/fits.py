"""The Mirrors step's markers fits: the planes that need no look applied at once, the others
proposed beside the plane they would replace and applied on confirmation."""

from __future__ import annotations

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.base.words import listed
from mirrorcore.calibration.fit import calibrate_session
from mirrorcore.calibration.markers import review_fit

from ...editor import fit_inputs
from ...jobs import REFINE, planes_key
from ...results import Fit, FitsApplied
from ...wording import Message, joined
from ...wording.mirrors import CROSSED, PROPOSAL_HEAD, fit_note, fit_report, proposal


def flags(fits: dict[int, Fit]) -> tuple[tuple[int, tuple[float, float]], ...]:
    """Every poor marker of the fits, crossed on the depth frame whichever mirror is selected.

    They stay crossed until that marker is moved or deleted.

    Parameters
    ----------
    fits : dict of int to Fit
        By mirror id.

    Returns
    -------
    tuple of (int, (float, float))
        (mirror id, marker's pixel (u, v)).
    """
    return tuple((f.mirror.id, f.mirror.markers[k]) for f in fits.values() for k in f.review.poor)


class MirrorFits:
    """The markers fits of the Mirrors panel (MirrorsPanel mixes it in)."""

    def fit_all_planes(self) -> None:
        """Fit every mirror that has markers (fit_planes).

        Those without are left as they are and named in the note.

        Raises
        ------
        MirrorscanError
            When no mirror has markers.
        """
        mirrors = self.services.editor.session.mirrors
        if not any(m.markers for m in mirrors):
            raise MirrorscanError(
                "no mirror has markers: click 3 or more on each in Markers mode, or use Find "
                "the planes from the object (no markers)"
            )
        self.fit_planes(
            [m.id for m in mirrors if m.markers], tuple(m.name for m in mirrors if not m.markers)
        )

    def fit_planes(self, mirror_ids: list[int], without_markers: tuple[str, ...] = ()) -> None:
        """Calibrate the given mirrors from their markers (on Jobs.marker_frames), all or nothing.

        A fit that needs a look (Fit.needs_confirmation) becomes a proposal; the others are applied
        at once.

        Parameters
        ----------
        mirror_ids : list of int
        without_markers : tuple of str, optional
            The names of the mirrors Fit all left out, for the note.

        Raises
        ------
        MirrorscanError
            While a calibration from the object runs (it applies what it computed on the planes as
            they were), before the first frame, or when a mirror with a boundary and no plane has no
            markers.
        """
        jobs = self.services.jobs
        if jobs.running(REFINE):
            raise MirrorscanError(
                "a calibration from the object runs: wait for it, or cancel it, then fit"
            )
        depth = jobs.marker_frames()
        if depth is None:
            raise MirrorscanError("no frame yet to calibrate from")
        session = self.services.editor.session
        indices = [session.mirror_index(i) for i in mirror_ids]
        bare = next((session.mirrors[i] for i in indices if not session.mirrors[i].markers), None)
        if bare is not None and bare.boundary and bare.plane is None:
            raise MirrorscanError(
                f"{bare.name} has no markers: click 3 or more in Markers mode, or use Find the "
                "planes from the object (no markers)"
            )
        _, results = calibrate_session(session, depth, np.random.default_rng(0), indices)
        fits = {}
        for i, calibration in results:
            mirror = session.mirrors[i]
            review = review_fit(
                mirror.plane,
                calibration.plane,
                calibration.markers,
                np.asarray(calibration.centre),
                self.services.editor.fitted_on_its_markers(mirror.id),
            )
            fits[mirror.id] = Fit(
                calibration, mirror, review, jobs.from_object(mirror.id, mirror.plane)
            )
        waiting = {i: fit for i, fit in fits.items() if fit.needs_confirmation}
        ready = {i: fit for i, fit in fits.items() if i not in waiting}
        if ready:
            self._apply_fits(ready, FitsApplied(tuple(ready.values())))
        self.proposal, self._ready = waiting or None, ready
        if not ready:
            self._report("")
        self.tab.state.flagged_markers = flags(fits)
        look = waiting or without_markers or any(f.review.poor for f in fits.values())
        said = fit_note(list(ready.values()), list(waiting.values()), without_markers)
        note = self.services.notify(
            self.tab.client, "Fit from the markers", said.plain, "warning" if look else "info"
        )
        if waiting:
            self._proposal_note = note
        self.tab.changed()

    def _apply(self) -> None:
        """The proposal applied; the report names the planes of the same fit applied at once too."""
        fits, self.proposal = self.proposal, None
        self.tab.state.flagged_markers = ()
        if fits:
            self._apply_fits(
                fits, FitsApplied((*self._ready.values(), *fits.values()), tuple(fits))
            )
        self.tab.changed()

    def _apply_fits(self, fits: dict[int, Fit], applied: FitsApplied) -> None:
        """Put markers fits' planes into the session, show their report, check the agreement.

        The report is kept by the planes they leave (Jobs.fits: an undo brings it back).
        """
        editor = self.services.editor
        editor.set_planes(
            {mirror_id: (f.calibration.plane, f.mirror) for mirror_id, f in fits.items()}
        )
        self.services.jobs.fits[planes_key(editor.session)] = applied
        self._report(joined(fit_report(applied)))
        self._check_agreement()

    def _discard(self) -> None:
        """The proposal discarded.

        The planes of the same fit applied at once stay, and their report.
        """
        waiting = tuple(f.mirror.name for f in (self.proposal or {}).values())
        self.proposal = None
        self.tab.state.flagged_markers = ()
        if self._ready:
            self._report(
                joined(fit_report(FitsApplied(tuple(self._ready.values()), discarded=waiting)))
            )
        else:
            self._report(
                Message("The proposed plane(s) were discarded; nothing changed.").markdown()
            )
        self.tab.changed()

    def _drop_stale_proposal(self) -> None:
        """Drop a proposal whose mirror's markers, boundary, glass or plane changed since the fit.

        It cannot be applied; Fit plane is offered again.
        """
        if self.proposal is None:
            return
        current = {m.id: m for m in self.services.editor.session.mirrors}
        stale = [
            f.mirror.name
            for f in self.proposal.values()
            if fit_inputs(current.get(f.mirror.id)) != fit_inputs(f.mirror)
        ]
        if stale:
            # as it was fitted
            again = "**Fit all planes**" if len(self.proposal) > 1 else "**Fit plane**"
            self.proposal, self.tab.state.flagged_markers = None, ()
            self._report(
                Message(
                    f"The proposal was dropped: {listed(stale)} changed since it was fitted. "
                    f"{again} again."
                ).markdown()
            )
            # its crossed-out markers leave the depth frame
            self.tab.changed()

    def _show_proposal(self) -> None:
        """The proposal's head, lines and buttons while one waits.

        The fits and the calibration from the object greyed out meanwhile (they would act on the
        planes it replaces).
        """
        fits = self.proposal
        for handle in (self.proposal_head, self.review, self.apply, self.discard):
            handle.visible = fits is not None
        for button in (self.fit, self.fit_all, self.refine, self.scene):
            button.disabled = button.disabled or fits is not None
        if fits is None:
            return
        self.proposal_head.content = PROPOSAL_HEAD.format(crossed=CROSSED if flags(fits) else "")
        self.review.content = joined(proposal(list(fits.values())))

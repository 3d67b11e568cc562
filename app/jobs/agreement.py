"""The agreement job: how well each mirror's view agrees with the others, with the planes as they
are."""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

import numpy as np

from mirrorcore.base.errors import MirrorscanError
from mirrorcore.calibration.residuals import view_agreement
from mirrorcore.rig.pipeline import prepare_frame

from ..results import AgreementReport, Checking, MirrorAgreement
from ..wording.agreement import disagrees
from .runner import AGREEMENT, Runner

if TYPE_CHECKING:
    from ..state import Snapshot

# frames the agreement lines pool: one frame's figures of the walking figure spread by 0.4 mm (RMS)
# and
# 0.5 mm (mean) from one check to the next, five frames' by 0.2 and 0.2 to 0.3 mm (0.2 s a frame)
AGREEMENT_FRAMES = 5
MARKERS_FIT = 3  # the markers a plane from markers has


class AgreementJob(Runner):
    """The views' agreement (Jobs mixes it in).

    Attributes
    ----------
    agreement : AgreementReport or None
        The last report (a tab opening later shows it).
    disagreeing : tuple of str
        The names of the mirrors it flags; none while a check of changed planes runs.
    """

    agreement: AgreementReport | None = None
    disagreeing: tuple[str, ...] = ()

    def start_agreement(self, depths: np.ndarray | None = None) -> None:
        """How well each mirror's view agrees with the others over frames (view_agreement).

        With the current session's planes and selection. While one runs, none is started: the
        running one checks again when the rig or the background changed meanwhile, so that its
        report is always the current planes'. Safe from any thread.

        Parameters
        ----------
        depths : np.ndarray, shape (k, H, W) or (H, W), optional
            Metres; the last AGREEMENT_FRAMES of them are used. None: the last live frames (nothing
            is started before the first).
        """
        depths = self.loop.recent_depths() if depths is None else np.asarray(depths)
        if depths is None:
            return
        depths = depths.reshape(-1, *depths.shape[-2:])[-AGREEMENT_FRAMES:]
        # the flags and every tab's lines are the old planes': no advice from them meanwhile
        self.disagreeing = ()
        self.progress(AGREEMENT, 0.0, Checking())

        def work(cancel: threading.Event) -> AgreementReport:
            snapshot = None
            while snapshot is None or not _same_views(snapshot, self.snapshot()):
                snapshot = self.snapshot()
                masks = np.stack(
                    [
                        prepare_frame(
                            snapshot.rig, depth, snapshot.backdrop, snapshot.session.selection
                        )[1]
                        for depth in depths
                    ]
                )
                # by the rig's mirror index
                found = view_agreement(snapshot.rig, depths, masks)
                mirrors = snapshot.session.mirrors
                report = AgreementReport(
                    tuple(
                        MirrorAgreement(mirrors[j].name, found[j], self._by_markers(mirrors[j]))
                        for j in sorted(found)
                    )
                )
            self.disagreeing = tuple(m.name for m in report.mirrors if disagrees(m.found))
            self.agreement = report
            return report

        try:
            self._start(AGREEMENT, work, "an agreement check is running")
        except MirrorscanError:
            # one runs (the check and the start are one step under the jobs' lock): it reports
            pass

    def _by_markers(self, mirror) -> bool:
        """Whether a mirror's plane comes from its markers (what the advice may send one back to).

        From 3 or more markers, and not a plane this app found or refined from the object.
        """
        return len(mirror.markers) >= MARKERS_FIT and not self.from_object(mirror.id, mirror.plane)


def _same_views(a: "Snapshot", b: "Snapshot") -> bool:
    """Whether two snapshots give the same clouds.

    The same rig (a Snapshot keeps the one before when the camera and the mirrors are unchanged),
    background and selection.
    """
    return (
        a.rig is b.rig and a.backdrop is b.backdrop and a.session.selection == b.session.selection
    )
